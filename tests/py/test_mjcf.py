"""pairgrasp hand import: a MuJoCo (MJCF) hand written as a URDF hand folder. The written hand is
checked against MuJoCo's own forward kinematics at random DOFs, and its couplings against MuJoCo's
constraint residuals; bad models get one error line and nothing is written."""
import json
import os
import pathlib
import re
import subprocess
import sys

import numpy as np
import pytest

import pairgrasp as pg

mujoco = pytest.importorskip("mujoco")
trimesh = pytest.importorskip("trimesh")

ROOT = pathlib.Path(__file__).resolve().parents[2]

# A three-finger hand on an arm link, in MJCF's own idioms: an <include>d file, default classes,
# degrees and euler frames, a mesh asset, primitive geoms, a visual-only geom, a joint away from its
# body's origin, a body with two joints, a joint with a ref, a linear joint equality and a narrow
# two-joint tendon (the Shadow hand's coupling of its distal joints).
PARTS = """<mujoco>
  <default>
    <default class="finger"><geom type="capsule" size="0.008 0.02" rgba="0.7 0.7 0.7 1"/>
      <joint type="hinge" axis="1 0 0" range="0 90" limited="true"/></default>
    <default class="visual"><geom contype="0" conaffinity="0" group="1"/></default>
  </default>
  <tendon>
    <fixed name="couple_f2" limited="true" range="-0.0004 0.0006">
      <joint joint="f2_distal" coef="0.01"/><joint joint="f2_proximal" coef="-0.012"/>
    </fixed>
  </tendon>
</mujoco>"""
HAND = """<mujoco model="three_finger">
  <compiler angle="degree" meshdir="."/>
  <include file="parts.xml"/>
  <asset><mesh name="palm" file="palm.stl"/></asset>
  <worldbody>
    <body name="arm" pos="0.1 -0.2 0.5" euler="10 20 30">
      <joint name="arm_joint" type="hinge" axis="0 0 1"/>
      <geom type="cylinder" size="0.03 0.1"/>
      <body name="palm" pos="0 0 0.12" quat="0.9 0.1 0.2 0.3">
        <geom type="mesh" mesh="palm"/>
        <geom class="visual" type="sphere" size="0.06"/>
        <body name="f1_proximal" childclass="finger" pos="0.03 0.045 0.02" euler="0 0 5">
          <joint name="f1_spread" axis="0 0 1" range="-30 30" pos="0 0 -0.005"/>
          <joint name="f1_proximal" pos="0 0.002 0" ref="10"/>
          <geom pos="0 0 0.02"/>
          <body name="f1_distal" pos="0 0 0.04">
            <joint name="f1_distal"/><geom pos="0 0 0.02" size="0.007 0.015"/>
          </body>
        </body>
        <body name="f2_proximal" childclass="finger" pos="-0.03 0.045 0.02">
          <joint name="f2_spread" axis="0 0 1" range="-30 30"/>
          <joint name="f2_proximal"/><geom pos="0 0 0.02"/>
          <body name="f2_distal" pos="0 0 0.04">
            <joint name="f2_distal"/><geom type="box" pos="0 0 0.015" size="0.007 0.005 0.015"/>
          </body>
        </body>
        <body name="thumb" childclass="finger" pos="0 -0.045 0.02" euler="0 0 180">
          <joint name="thumb_proximal"/><geom pos="0 0 0.02"/>
          <body name="thumb_distal" pos="0 0 0.04">
            <joint name="thumb_distal"/><geom type="ellipsoid" pos="0 0 0.015" size="0.008 0.007 0.015"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <equality><joint name="couple_spread" joint1="f2_spread" joint2="f1_spread" polycoef="0 -1 0 0 0"/></equality>
</mujoco>"""
INDEPENDENT = ["f1_spread", "f1_proximal", "f1_distal", "f2_proximal", "thumb_proximal", "thumb_distal"]


def write_model(folder: pathlib.Path, hand: str = HAND, parts: str = PARTS) -> pathlib.Path:
    folder.mkdir(parents=True, exist_ok=True)
    trimesh.creation.box(extents=(0.1, 0.08, 0.03)).export(folder / "palm.stl")
    (folder / "parts.xml").write_text(parts)
    (folder / "hand.xml").write_text(hand)
    return folder / "hand.xml"


def run(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "pairgrasp.cli", *args], capture_output=True, text=True, cwd=cwd,
                          env=dict(os.environ), timeout=300)


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("mjcf")
    model = write_model(tmp / "model")
    spec = pg.import_hand(str(model), "palm", str(tmp / "hand"))
    return model, tmp / "hand", spec


def test_the_written_hand_moves_as_mujoco_moves_the_model(imported):
    model, folder, _ = imported
    m = mujoco.MjModel.from_xml_path(str(model))
    d = mujoco.MjData(m)
    # A spec of our own: one DOF per independent joint, so its values are the joints' URDF angles.
    spec = {"urdf": str(folder / "hand.urdf"), "wrist_link": "palm", "approach": [0, 0, 1],
            "dofs": [{"name": j, "joints": [{"joint": j}]} for j in INDEPENDENT],
            "active_surfaces": [{"link": "thumb", "normal_cone": {"axis": [0, 0, 1], "half_angle_deg": 180}}]}
    path = folder / "fk.json"
    path.write_text(json.dumps(spec))
    hand = pg.load_hand(str(path))
    rng = np.random.default_rng(7)
    jid = lambda n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)   # noqa: E731
    bid = lambda n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, n)    # noqa: E731
    for _ in range(20):
        q = hand.dof_lower + rng.random(len(INDEPENDENT)) * (hand.dof_upper - hand.dof_lower)
        joints = hand.joint_values(q)          # joint name -> URDF angle, mimics included
        d.qpos[:] = m.qpos0
        d.qpos[m.jnt_qposadr[jid("arm_joint")]] = rng.uniform(-3, 3)      # above the wrist: ignored
        for name, u in joints.items():                                     # URDF angle = qpos - ref
            d.qpos[m.jnt_qposadr[jid(name)]] = u + m.qpos0[m.jnt_qposadr[jid(name)]]
        mujoco.mj_forward(m, d)
        W = np.eye(4)
        W[:3, :3], W[:3, 3] = d.xmat[bid("palm")].reshape(3, 3), d.xpos[bid("palm")]
        poses = hand.link_transforms(q)
        for body in ("palm", "f1_proximal", "f1_distal", "f2_proximal", "f2_distal", "thumb", "thumb_distal"):
            b = bid(body)
            X = np.eye(4)
            X[:3, :3], X[:3, 3] = d.xmat[b].reshape(3, 3), d.xpos[b]
            expected = np.linalg.inv(W) @ X
            # The link frame sits at the body's last joint anchor: the body frame is the link frame moved back.
            nj = m.body_jntnum[b]
            anchor = m.jnt_pos[m.body_jntadr[b] + nj - 1] if nj else np.zeros(3)
            body_in_link = np.eye(4)
            body_in_link[:3, 3] = -anchor
            assert poses[body] @ body_in_link == pytest.approx(expected, abs=1e-9), body
        # The couplings hold in MuJoCo's own terms: the joint equality's residual is zero, and the
        # narrow tendon sits at the middle of its range.
        assert np.abs(d.efc_pos[d.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY]).max() < 1e-9
        t = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TENDON, "couple_f2")
        assert d.ten_length[t] == pytest.approx(0.0001, abs=1e-12)


def test_the_folder_holds_a_urdf_meshes_and_a_spec_that_loads(imported):
    model, folder, spec = imported
    assert (folder / "hand.urdf").is_file() and (folder / "hand.json").is_file()
    assert json.loads((folder / "hand.json").read_text()) == spec
    assert spec["urdf"] == "hand.urdf" and "package_paths" not in spec
    hand = pg.load_hand(str(folder / "hand.json"))
    names = [l.name for l in hand.links]
    assert {"palm", "f1_proximal", "f1_distal", "thumb_distal"} <= set(names)
    assert "arm" not in names                      # above the wrist
    # Followers are mimics, not DOFs; the fingers' flexion and the thumb are proposed as closing.
    driven = {j["joint"] for dof in spec["dofs"] for j in dof["joints"]}
    assert "f2_spread" not in driven and "f2_distal" not in driven
    assert {"f1_proximal", "thumb_proximal"} <= driven
    assert {"f1_distal", "thumb_distal"} <= {a["link"] for a in spec["active_surfaces"]}
    # The visual-only sphere is not part of the palm: the palm's mesh is the box.
    palm = next(l for l in hand.links if l.name == "palm")
    extent = np.ptp(np.asarray(palm.mesh.vertices), axis=0)
    assert sorted(extent) == pytest.approx([0.03, 0.08, 0.1])
    # A primitive keeps its size: the capsule is 2 x 0.02 long plus its caps.
    f1 = next(l for l in hand.links if l.name == "f1_proximal")
    assert np.ptp(np.asarray(f1.mesh.vertices)[:, 2]) == pytest.approx(0.04 + 2 * 0.008, abs=1e-6)


def test_more_joints_than_the_planner_samples_are_proposed_as_synergies(imported):
    """Six independent joints (more than pairgrasp.hand_spec.SYNERGIES_ABOVE) become synergies: the two
    fingers' flexion together, the opposing thumb's, and the fingers' spread; each closing synergy
    sweeps its joints from one limit to the other, and closing both brings the fingertips to the thumb."""
    _, folder, spec = imported
    assert len(spec["dofs"]) <= pg.hand_spec.MAX_DOFS and pg.hand_spec.SYNERGIES_ABOVE < len(INDEPENDENT)
    joints = {d["name"]: sorted(j["joint"] for j in d["joints"]) for d in spec["dofs"]}
    assert joints == {"close": ["f1_distal", "f1_proximal", "f2_proximal"],
                      "close_opposing": ["thumb_distal", "thumb_proximal"], "spread": ["f1_spread"]}
    hand = pg.load_hand(str(folder / "hand.json"))
    names = list(hand.dof_names)
    i, k = names.index("close"), names.index("close_opposing")
    mid = (hand.dof_lower + hand.dof_upper) / 2
    urdf = {j.name: j for j in hand.joints}
    open_q, closed_q = mid.copy(), mid.copy()
    open_q[[i, k]], closed_q[[i, k]] = hand.dof_lower[[i, k]], hand.dof_upper[[i, k]]
    a, b = hand.joint_values(open_q), hand.joint_values(closed_q)
    for j in joints["close"] + joints["close_opposing"]:
        # The joint's own limits, narrowed by those of a joint that mimics it.
        lo, hi = urdf[j].lower, urdf[j].upper
        for f in (f for f in urdf.values() if f.mimic_joint == j):
            ends = sorted([(f.lower - f.offset) / f.multiplier, (f.upper - f.offset) / f.multiplier])
            lo, hi = max(lo, ends[0]), min(hi, ends[1])
        assert sorted([a[j], b[j]]) == pytest.approx([lo, hi], abs=1e-6), j

    def tip_gap(q):
        T = hand.link_transforms(q)
        centre = lambda n: (T[n] @ np.append(np.asarray(next(l for l in hand.links if l.name == n).mesh.vertices)  # noqa: E731
                                              .mean(axis=0), 1.0))[:3]
        return min(np.linalg.norm(centre(f) - centre("thumb_distal")) for f in ("f1_distal", "f2_distal"))
    assert tip_gap(closed_q) < 0.6 * tip_gap(open_q)


def test_cli_import_writes_the_folder_and_show_draws_it(tmp_path):
    model = write_model(tmp_path / "model")
    r = run("hand", "import", str(model), "--wrist", "palm", "-o", str(tmp_path / "out"), "--name", "three")
    assert r.returncode == 0, r.stderr
    assert "hand.json" in r.stdout and "pairgrasp hand show" in r.stdout
    assert json.loads((tmp_path / "out" / "hand.json").read_text())["name"] == "three"
    r = run("hand", "import", str(model), "--wrist", "palm", "-o", str(tmp_path / "out"))
    assert r.returncode != 0 and r.stderr.strip().splitlines() == [
        f"pairgrasp: error: -o: {tmp_path / 'out'} exists (--force replaces it)"]
    r = run("hand", "show", str(tmp_path / "out" / "hand.json"), "-o", str(tmp_path / "hand.png"))
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "hand.png").stat().st_size > 10_000


BAD = [
    ("no such body", HAND, PARTS, "wrist_body", "no body 'wrist_body'"),
    ("nonlinear coupling", HAND.replace('polycoef="0 -1 0 0 0"', 'polycoef="0 -1 0.5 0 0"'), PARTS, "palm",
     "equality 'couple_spread' couples joint 'f2_spread' by a polynomial of degree > 1"),
    ("no moving joint", HAND, PARTS, "thumb_distal", "has no moving joint"),
    ("ball joint", HAND.replace('<joint name="thumb_distal"/>', '<joint name="thumb_distal" type="ball"/>'), PARTS,
     "palm", "joint 'thumb_distal' is a ball joint"),
    ("closed loop", HAND.replace("</equality>", '<connect name="loop" body1="f1_distal" body2="f2_distal" '
                                 'anchor="0 0 0"/></equality>'), PARTS, "palm",
     "equality 'loop' (connect) ties bodies of the hand together"),
    ("names that clash in a URDF", HAND.replace('<body name="f2_distal"', '<body name="f1:distal"'), PARTS, "palm",
     "bodies of the hand share a URDF name once their characters outside [A-Za-z0-9_.-] become '_': f1_distal"),
    ("malformed XML", HAND.replace("</worldbody>", ""), PARTS, "palm", "MuJoCo cannot load it"),
    ("missing mesh", HAND.replace('file="palm.stl"', 'file="gone.stl"'), PARTS, "palm", "MuJoCo cannot load it"),
]


@pytest.mark.parametrize("case, hand, parts, wrist, message", BAD, ids=[b[0] for b in BAD])
def test_bad_models_get_one_line_and_nothing_is_written(tmp_path, case, hand, parts, wrist, message):
    model = write_model(tmp_path / "model", hand, parts)
    out = tmp_path / "out"
    r = run("hand", "import", str(model), "--wrist", wrist, "-o", str(out))
    lines = r.stderr.strip().splitlines()
    assert r.returncode != 0 and len(lines) == 1 and lines[0].startswith("pairgrasp: error: "), r.stderr
    assert message in lines[0]
    assert not out.exists() and not (tmp_path / "out.part").exists()
    with pytest.raises(ValueError, match=re.escape("MuJoCo cannot load" if "load" in message else message.split("'")[0])):
        pg.import_hand(str(model), wrist, str(tmp_path / "out2"))


def shadow_model():
    import importlib.util

    found = importlib.util.find_spec("gymnasium_robotics")
    if found is None:
        pytest.skip("gymnasium-robotics is not installed (scripts/install_deps.sh installs it)")
    return pathlib.Path(list(found.submodule_search_locations)[0]) / "envs" / "assets" / "hand" / "reach.xml"


@pytest.mark.slow
def test_the_shadow_hand_imports_as_four_synergies_moves_as_mujoco_and_plans(tmp_path):
    """gymnasium-robotics' Shadow hand (MJCF: includes, default classes, tendon couplings), as
    docs/hands.md imports it: the folder's hand moves as MuJoCo moves the model at random synergy
    values, and it plans on the mug."""
    model = shadow_model()
    r = run("hand", "import", str(model), "--wrist", "robot0:palm", "--name", "shadow", "-o", str(tmp_path / "shadow"))
    assert r.returncode == 0, r.stderr
    spec = json.loads((tmp_path / "shadow" / "hand.json").read_text())
    assert [d["name"] for d in spec["dofs"]] == ["close", "close_opposing", "spread", "turn_opposing"]
    hand = pg.load_hand(str(tmp_path / "shadow" / "hand.json"))
    m = mujoco.MjModel.from_xml_path(str(model))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = hand.dof_lower + rng.random(len(hand.dof_names)) * (hand.dof_upper - hand.dof_lower)
        d.qpos[:] = m.qpos0
        for name, u in hand.joint_values(q).items():
            j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name.replace("robot0_", "robot0:"))
            d.qpos[m.jnt_qposadr[j]] = u + m.qpos0[m.jnt_qposadr[j]]
        mujoco.mj_kinematics(m, d)
        palm = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "robot0:palm")
        W = np.eye(4)
        W[:3, :3], W[:3, 3] = d.xmat[palm].reshape(3, 3), d.xpos[palm]
        poses = hand.link_transforms(q)
        for b in range(palm + 1, m.nbody):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)
            if not name.startswith("robot0:") or name.replace("robot0:", "robot0_") not in poses:
                continue
            X = np.eye(4)
            X[:3, :3], X[:3, 3] = d.xmat[b].reshape(3, 3), d.xpos[b]
            nj = m.body_jntnum[b]
            back = np.eye(4)
            back[:3, 3] = -(m.jnt_pos[m.body_jntadr[b] + nj - 1] if nj else 0)
            assert poses[name.replace("robot0:", "robot0_")] @ back == pytest.approx(np.linalg.inv(W) @ X, abs=1e-9), name
    r = run("plan", "--hand", str(tmp_path / "shadow" / "hand.json"), "--target", str(ROOT / "models/targets/mug.stl"),
            "--top", "3", "--seed", "1", "--pictures", "0", "--quiet", "-o", str(tmp_path / "plan"))
    assert r.returncode == 0, r.stderr
    grasps = json.loads((tmp_path / "plan" / "grasps.json").read_text())["grasps"]
    assert grasps and all(len(g["dof"]) == 4 for g in grasps)
