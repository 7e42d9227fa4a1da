"""The hand spec proposal (pairgrasp hand init) and the hand picture (pairgrasp hand show): the
proposal recovers what the bundled hands' hand-written specs say."""
import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import pairgrasp as pg

ROOT = pathlib.Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
HANDS = [("barrett", "bh8_28x.urdf"), ("parallel_jaw", "parallel_jaw.urdf")]


def run(*args):
    return subprocess.run([sys.executable, "-m", "pairgrasp.cli", *args], capture_output=True, text=True, cwd=ROOT,
                          env=dict(os.environ), timeout=300)


@pytest.mark.parametrize("name, urdf", HANDS)
def test_the_proposal_recovers_the_bundled_specs(name, urdf):
    written = json.loads((MODELS / name / f"{name}.json").read_text())
    proposed = pg.propose_spec(str(MODELS / name / urdf), written["wrist_link"])
    assert proposed["approach"] == pytest.approx(written["approach"])
    assert [a["link"] for a in proposed["active_surfaces"]] == [a["link"] for a in written["active_surfaces"]]
    # The same DOFs: each drives the same joints with the same ratios, up to the DOF's sign (the Barrett
    # spread's two knuckles, one motor and two URDF joints, are found as a mirrored pair).
    def couplings(spec):
        out = set()
        for d in spec["dofs"]:
            r = {j["joint"]: j.get("ratio", 1.0) for j in d["joints"]}
            first = r[min(r)]
            out.add(tuple(sorted((k, v / first) for k, v in r.items())))
        return out
    assert couplings(proposed) == couplings(written)
    # Turning DOFs step by 0.25 rad or an eighth of their range (the Barrett hand's written steps).
    if name == "barrett":
        assert [d.get("step") for d in proposed["dofs"]] == [d["step"] for d in written["dofs"]]


@pytest.mark.parametrize("name, urdf", HANDS)
def test_the_proposed_active_faces_close_like_the_written_ones(tmp_path, name, urdf):
    """closing_directions (which reads the active faces) agrees with the hand-written spec on every
    joint they share, and the proposed faces of each link are mostly the written ones."""
    written_path = MODELS / name / f"{name}.json"
    written = pg.load_hand(str(written_path))
    spec = pg.propose_spec(str(MODELS / name / urdf), written.wrist_link)
    path = tmp_path / "proposed.json"
    path.write_text(json.dumps(spec))
    proposed = pg.load_hand(str(path))
    q = written.dof_lower + 0.3 * (written.dof_upper - written.dof_lower)
    joints_w = written.joint_values(q)
    # The proposed hand at the same joint values: each proposed DOF's first joint has ratio 1.
    qp = np.array([joints_w[d["joints"][0]["joint"]] for d in spec["dofs"]])
    assert proposed.joint_values(qp) == pytest.approx(joints_w)
    dirs_w = dict(zip(written.dof_names, pg._core.closing_directions(written, q)))
    dirs_p = dict(zip(proposed.dof_names, pg._core.closing_directions(proposed, qp)))
    # Each joint's closing sense: its DOF's closing direction times the sign of its ratio.
    sense = lambda dofs, dirs: {j["joint"]: dirs[d["name"]] * np.sign(j.get("ratio", 1.0))  # noqa: E731
                                for d in dofs for j in d["joints"] if dirs[d["name"]] != 0}
    sense_w = sense(json.loads(written_path.read_text())["dofs"], dirs_w)
    sense_p = sense(spec["dofs"], dirs_p)
    for joint, s in sense_w.items():
        if joint in sense_p:
            assert sense_p[joint] == s, joint
    for lw, lp in zip(written.links, proposed.links):
        assert lw.name == lp.name
        a, b = set(lw.active_faces), set(lp.active_faces)
        if a:
            assert len(a & b) >= 0.5 * len(a), lw.name


@pytest.mark.long
def test_init_writes_a_spec_that_plans_and_show_draws_it(tmp_path):
    spec, png = tmp_path / "jaw.json", tmp_path / "jaw.png"
    r = run("hand", "init", str(MODELS / "parallel_jaw" / "parallel_jaw.urdf"), "--wrist", "pj_base", "-o", str(spec))
    assert r.returncode == 0, r.stderr
    assert "active links pj_left_finger, pj_right_finger" in r.stdout
    r = run("hand", "show", str(spec), "-o", str(png))
    assert r.returncode == 0, r.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    planner = pg.Planner(str(spec), str(MODELS / "targets" / "box.stl"), top=2, seed=1)
    assert any(g.force_closure for g in planner.plan(progress=False).grasps)
    r = run("hand", "init", str(MODELS / "parallel_jaw" / "parallel_jaw.urdf"), "--wrist", "pj_base", "-o", str(spec))
    assert r.returncode == 1 and "--force" in r.stderr


@pytest.mark.parametrize("wrist, needle", [
    ("no_such_link", "no link 'no_such_link'"),
    ("bh_f1_dist", "no moving joint"),          # a fingertip: nothing below it moves
])
def test_init_errors_are_one_line_and_write_nothing(tmp_path, wrist, needle):
    out = tmp_path / "spec.json"
    r = run("hand", "init", str(MODELS / "barrett" / "bh8_28x.urdf"), "--wrist", wrist, "-o", str(out))
    assert r.returncode == 1 and r.stdout == ""
    assert r.stderr.startswith("pairgrasp: error:") and needle in r.stderr and r.stderr.count("\n") == 1
    assert not out.exists() and not list(tmp_path.iterdir())


def _two_finger_urdf(path, right_lower=0.0, right_z=0.0, right_axis="0 1 0"):
    """A palm and two box fingers on prismatic joints, stated without a <mimic>: the right finger is
    the left one turned half a turn about the approach (z), unless the arguments break that."""
    finger = '<visual><geometry><box size="0.01 0.01 0.05"/></geometry></visual>' \
             '<collision><geometry><box size="0.01 0.01 0.05"/></geometry></collision>'
    path.write_text(f"""<robot name="two_finger">
  <link name="palm"><collision><geometry><box size="0.04 0.1 0.01"/></geometry></collision></link>
  <link name="left">{finger}</link>
  <link name="right">{finger}</link>
  <joint name="left_slide" type="prismatic"><parent link="palm"/><child link="left"/>
    <origin xyz="0 0.03 0.03" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.02" effort="1" velocity="1"/></joint>
  <joint name="right_slide" type="prismatic"><parent link="palm"/><child link="right"/>
    <origin xyz="0 -0.03 {0.03 + right_z}" rpy="0 0 3.141592653589793"/><axis xyz="{right_axis}"/>
    <limit lower="{right_lower}" upper="0.02" effort="1" velocity="1"/></joint>
</robot>
""")
    return str(path)


@pytest.mark.parametrize("kwargs, merged", [
    ({}, {("left_slide", 1.0), ("right_slide", 1.0)}),              # half a turn apart: one DOF
    ({"right_axis": "0 -1 0"}, None),                               # the right finger slides the left's way
    ({"right_lower": 0.005}, None),                                 # other limits
    ({"right_z": 0.004}, None),                                     # not level with the left finger
])
def test_fingers_that_mirror_each_other_are_proposed_as_one_dof(tmp_path, kwargs, merged):
    """Two fingers whose URDF states no coupling: one DOF when they move as mirror images of each other
    (the same limits, centroids half a turn apart about the approach at every value), two otherwise."""
    spec = pg.propose_spec(_two_finger_urdf(tmp_path / "hand.urdf", **kwargs), "palm")
    dofs = {d["name"]: {(j["joint"], j.get("ratio", 1.0)) for j in d["joints"]} for d in spec["dofs"]}
    if merged:
        assert spec["approach"] == [0.0, 0.0, 1.0]
        assert list(dofs.values()) == [merged]
        path = tmp_path / "spec.json"
        path.write_text(json.dumps(spec))
        hand = pg.load_hand(str(path))
        for x in (0.0, 0.01, 0.02):     # both fingers' centres 3 cm + x from the middle
            T = dict(zip([l.name for l in hand.links], np.asarray(hand.link_poses(np.array([x])))))
            assert T["left"][1, 3] == pytest.approx(0.03 + x) and T["right"][1, 3] == pytest.approx(-0.03 - x)
    else:
        assert dofs == {"left_slide": {("left_slide", 1.0)}, "right_slide": {("right_slide", 1.0)}}


def test_the_pr2_grippers_two_fingers_are_one_dof_stepped_by_an_eighth_of_their_range():
    """pybullet_data's PR2 gripper: two revolute fingers (0 to 0.548 rad, one mesh turned over) and no
    <mimic>. They are one DOF, stepped by an eighth of the range (the default 0.25 rad samples it thrice)."""
    pybullet_data = pytest.importorskip("pybullet_data")
    spec = pg.propose_spec(os.path.join(pybullet_data.getDataPath(), "pr2_gripper.urdf"), "gripper_pole")
    fingers = [{"joint": "left_gripper_joint"}, {"joint": "right_gripper_joint", "ratio": 1.0}]
    assert spec["dofs"] == [{"name": "left_gripper_joint+right_gripper_joint", "step": pytest.approx(0.548 / 8),
                             "joints": fingers}]
