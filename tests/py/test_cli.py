"""The `pairgrasp` command line: the summary of the bundled models, and one-line errors."""
import json
import os
import pathlib
import re
import subprocess
import sys

import numpy as np
import pytest

import pairgrasp as pg

ROOT = pathlib.Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"


def run(*args):
    env = dict(os.environ)
    return subprocess.run([sys.executable, "-m", "pairgrasp.cli", *args], capture_output=True,
                          text=True, cwd=ROOT, env=env, timeout=300)


def _numbers(text):
    return [float(x) for x in re.findall(r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?", text)]


@pytest.mark.parametrize("target", ["mug", "flask"])
def test_info_against_trimesh_and_the_spec(target):
    """info's counts, area, volume, extent and centre of mass equal trimesh's (which welds the STL's
    vertices the same way), its DOFs the hand spec's, its per-link samples the spec's active surfaces."""
    import trimesh

    hand = MODELS / "barrett" / "barrett.json"
    mesh = MODELS / "targets" / f"{target}.stl"
    r = run("info", "--hand", str(hand), "--target", str(mesh))
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    spec = json.loads(hand.read_text())
    assert f"{len(spec['dofs'])} DOF" in lines[1]
    assert [ln.split()[1] for ln in lines if ln.strip().startswith("dof ")] == [d["name"] for d in spec["dofs"]]
    assert _numbers(next(ln for ln in lines if "per-link samples" in ln))[0] == len(spec["active_surfaces"])
    tm = trimesh.load(str(mesh))
    head = next(ln for ln in lines if ln.startswith("target "))
    nv, nf = _numbers(head.split(":", 1)[1])[:2]
    assert (nv, nf) == (len(tm.vertices), len(tm.faces))
    assert head.endswith("closed yes") == tm.is_watertight
    geo = _numbers(next(ln for ln in lines if "extent" in ln))
    extent, area, volume, com = geo[0:3], geo[3], geo[5], geo[7:10]  # (skips the exponents of m^2, m^3)
    np.testing.assert_allclose(extent, tm.extents, rtol=1e-3)
    assert area == pytest.approx(tm.area, rel=1e-4) and volume == pytest.approx(tm.volume, rel=1e-4)
    np.testing.assert_allclose(com, tm.center_mass, rtol=1e-3, atol=1e-6)


def test_info_counts_the_painted_faces():
    paint = MODELS / "targets" / "box.paint.json"
    r = run("info", "--target", str(MODELS / "targets" / "box.stl"), "--paint", str(paint))
    assert r.returncode == 0, r.stderr
    doc = json.loads(paint.read_text())
    free = doc["faces"] - len(doc["occluded"])
    assert f"{free} of {doc['faces']} faces free" in r.stdout


def _write_ply(path, vertices, faces):
    """A binary PLY with double-precision vertices (what is written is what is read, to the bit)."""
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(vertices)}\nproperty double x\n"
            f"property double y\nproperty double z\nelement face {len(faces)}\n"
            "property list uchar int vertex_indices\nend_header\n").encode()
    rows = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    rows["n"], rows["i"] = 3, faces
    path.write_bytes(head + np.asarray(vertices, "<f8").tobytes() + rows.tobytes())
    return str(path)


@pytest.mark.slow
def test_plan_in_millimetres_with_scale_equals_the_plan_in_metres(tmp_path):
    """The mug in millimetres planned with --scale 0.001 gives the same grasps as the mug in metres
    (the metre file holds the millimetre coordinates times 0.001, so the planner sees the same mesh),
    and the scale is recorded; without --scale the millimetre mug is refused, naming --scale."""
    mug = pg.load_mesh(str(MODELS / "targets" / "mug.stl"))
    mm = np.asarray(mug.vertices, float) * 1000.0
    faces = np.asarray(mug.faces)
    files = {"m": _write_ply(tmp_path / "mug_m.ply", mm * 0.001, faces), "mm": _write_ply(tmp_path / "mug_mm.ply", mm, faces)}
    common = ["--hand", str(MODELS / "parallel_jaw" / "parallel_jaw.json"), "--top", "3", "--seed", "1",
              "--step", "0.5", "--pictures", "0"]
    a = run("plan", "--target", files["m"], *common, "-o", str(tmp_path / "m"))
    b = run("plan", "--target", files["mm"], "--scale", "0.001", *common, "-o", str(tmp_path / "mm"))
    assert a.returncode == 0 and b.returncode == 0, a.stderr + b.stderr
    ga = json.loads((tmp_path / "m" / "grasps.json").read_text())
    gb = json.loads((tmp_path / "mm" / "grasps.json").read_text())
    assert gb["inputs"]["scale"] == 0.001 and "scale" not in ga["inputs"]
    assert gb["counts"] == ga["counts"] and len(ga["grasps"]) > 0
    assert gb["grasps"] == ga["grasps"]
    wrong = run("plan", "--target", files["mm"], *common, "-o", str(tmp_path / "wrong"))
    assert wrong.returncode != 0 and "--scale" in wrong.stderr and not (tmp_path / "wrong").exists()


@pytest.mark.slow
def test_figures_draw_the_plans_data(tmp_path, monkeypatch, barrett_flask):
    """`pairgrasp figures` (in process) draws Figure 8 from exactly the candidates of the same plan
    (the session's Barrett flask plan: the candidates do not depend on fine-tuning), and Figure 7's
    matched fractions equal a brute-force scan of the target's pair features; both PNGs are images
    with something drawn."""
    from matplotlib.image import imread

    from pairgrasp import cli, render

    planner, planned = barrett_flask
    drawn = {}
    save = render._save

    def record(fig, path):
        drawn[pathlib.Path(path).name] = fig
        save(fig, path)

    monkeypatch.setattr(render, "_save", record)
    out = tmp_path / "figs"
    assert cli.main(["figures", "--hand", str(MODELS / "barrett" / "barrett.json"),
                     "--target", str(MODELS / "targets" / "flask.stl"),
                     "--paint", str(MODELS / "targets" / "flask.paint.json"),
                     "--step", "0.5", "--seed", "1", "--quiet", "-o", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["fig7_flask.png", "fig8_flask.png"] == sorted(drawn)
    for name in drawn:
        img = imread(str(out / name))
        assert img.ndim == 3 and img.shape[0] > 300 and img[..., :3].std() > 0.05

    # Figure 8: grey points (not force-closure) then red ones, (Q_A, epsilon) of every candidate.
    ax = drawn["fig8_flask.png"].axes[0]
    grey, red = (np.asarray(c.get_offsets(), float) for c in ax.collections)
    fc = [c for c in planned.candidates if c.force_closure]
    nfc = [c for c in planned.candidates if not c.force_closure]
    assert len(red) == len(fc) and len(grey) == len(nfc) and len(fc) > 0
    np.testing.assert_allclose(red, [(c.alignment_quality, c.epsilon) for c in fc], rtol=1e-12)
    np.testing.assert_allclose(grey, [(c.alignment_quality, c.epsilon) for c in nfc], rtol=1e-12)

    # Figure 7: "DOF [...]: N% matched" for each sample, against every stored feature scanned.
    feats = np.asarray(planner.tindex.index.features, float)
    tol = np.asarray(planner.aligner.tolerance, float)
    labels = [t.get_text() for t in drawn["fig7_flask.png"].axes[0].get_legend().get_texts()][1:]
    assert len(labels) >= 3
    for label in labels:
        q = np.array(json.loads(label[len("DOF "):label.index("]") + 1]))
        c = planner.constellation(q)
        pts, nrm = np.asarray(c.points), -np.asarray(c.normals)
        i, j = np.triu_indices(len(pts), 1)
        f = np.asarray(pg.pair_feature(pts[i], nrm[i], pts[j], nrm[j]))
        hit = [np.any(np.all(np.abs(feats - x) <= tol, axis=1)) for x in f]
        assert int(label.split(": ")[1].split("%")[0]) == round(100 * sum(hit) / len(f))


@pytest.mark.parametrize("args, needle", [
    (["info", "--target", "models/targets/no-such-target.stl"], "no-such-target.stl"),
    (["info", "--hand", "models/no-such-hand.json"], "no-such-hand.json"),
    (["info", "--target", "models/targets/flask.stl", "--scale", "-1"], "scale"),
    (["info"], "--hand"),
    (["frobnicate"], "invalid choice"),
])
def test_errors_are_one_line(args, needle):
    r = run(*args)
    assert r.returncode != 0
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("pairgrasp: error:")
    assert needle in lines[0]
    assert "Traceback" not in r.stderr


@pytest.mark.long
def test_plan_writes_grasps_and_pictures(tmp_path):
    out = tmp_path / "out"
    r = run("plan", "--hand", str(MODELS / "parallel_jaw" / "parallel_jaw.json"),
            "--target", str(MODELS / "targets" / "box.stl"), "--paint", str(MODELS / "targets" / "box.paint.json"),
            "--edge", "0.008", "--top", "2", "--seed", "1", "-o", str(out))
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""  # no progress bar when stderr is not a terminal
    assert "epsilon" in r.stdout and "time" in r.stdout
    doc = json.loads((out / "grasps.json").read_text())
    assert doc["format"] == "pairgrasp.grasps/1"
    assert set(doc["timings"]) >= {"index", "schedule", "align", "settle", "evaluate", "fine_tune", "total"}
    assert doc["parameters"]["schedule"] == "fast" and doc["parameters"]["seed"] == 1
    assert doc["inputs"]["target"].endswith("box.stl")
    g = doc["grasps"][0]
    for key in ("rank", "wrist_pose", "dof", "joints", "epsilon", "volume", "force_closure", "alignment_quality",
                "votes", "penetration_depth", "contacts"):
        assert key in g
    assert g["force_closure"] and g["epsilon"] > 0
    assert len(g["dof"]) == 1 and len(g["joints"]) >= 1
    assert {"point", "normal", "link"} <= set(g["contacts"][0])
    pictures = sorted(p.name for p in out.glob("*.png"))
    assert pictures == doc["pictures"] and pictures
    assert not list(tmp_path.glob(".pairgrasp-*")), "temporary folder left behind"


@pytest.mark.parametrize("args, needle", [
    (["--target", "models/targets/no-such.stl"], "no-such.stl"),
    (["--step", "-0.5"], "--step"),
    (["--top", "0"], "--top"),
    (["--schedule", "slow"], "--schedule"),
    (["--paint", "models/targets/mug.paint.json"], "paint"),
    (["--viewpoint", "1", "2"], "--viewpoint"),
    (["--max-pairs-per-cell", "-1"], "--max-pairs-per-cell"),
])
def test_plan_errors_write_nothing(tmp_path, args, needle):
    out = tmp_path / "out"
    base = {"--hand": str(MODELS / "parallel_jaw" / "parallel_jaw.json"), "--target": str(MODELS / "targets" / "box.stl")}
    for k in list(base):
        if k in args:
            base.pop(k)
    argv = ["plan"] + [x for kv in base.items() for x in kv] + args + ["--edge", "0.008", "-o", str(out)]
    r = run(*argv)
    assert r.returncode != 0
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("pairgrasp: error:"), r.stderr
    assert needle in lines[0]
    assert not out.exists()
    assert not list(tmp_path.glob(".pairgrasp-*"))


def _panda_spec(tmp_path, urdf=None):
    """A hand spec for the Franka Panda's hand inside pybullet_data's whole-arm URDF (a robot
    description as it usually comes; nothing cut out of it), or inside `urdf`."""
    import pybullet_data
    folder = pathlib.Path(pybullet_data.getDataPath()) / "franka_panda"
    spec = {"name": "panda", "urdf": str(urdf or folder / "panda.urdf"), "package_paths": [str(folder)],
            "wrist_link": "panda_hand", "approach": [0, 0, 1],
            "dofs": [{"name": "opening", "joints": [{"joint": "panda_finger_joint1"}], "step": 0.01}],
            "active_surfaces": [
                {"link": "panda_leftfinger", "normal_cone": {"axis": [0, -1, 0], "half_angle_deg": 30}},
                {"link": "panda_rightfinger", "normal_cone": {"axis": [0, 1, 0], "half_angle_deg": 30}}]}
    path = tmp_path / ("panda.json" if urdf is None else "panda_cut.json")
    path.write_text(json.dumps(spec))
    return path


def _cut_urdf(source, wrist, target):
    """The subtree of `wrist` cut out of the URDF `source` by hand (ElementTree), written to `target`."""
    import xml.etree.ElementTree as ET
    robot = ET.parse(source).getroot()
    joints = robot.findall("joint")
    keep = {wrist}
    while True:
        more = {j.find("child").get("link") for j in joints if j.find("parent").get("link") in keep} - keep
        if not more:
            break
        keep |= more
    for e in list(robot):
        if (e.tag == "link" and e.get("name") not in keep) or (
                e.tag == "joint" and e.find("parent").get("link") not in keep):
            robot.remove(e)
    ET.ElementTree(robot).write(target)
    return target


def test_a_robots_whole_urdf_supplies_its_hand(tmp_path):
    """wrist_link may be any link: the hand is its subtree, the arm's seven joints are ignored."""
    h = pg.load_hand(str(_panda_spec(tmp_path)))
    assert h.link_names[0] == "panda_hand"
    assert not any(n.startswith("panda_link") for n in h.link_names)
    assert h.joint_names == ["panda_finger_joint1", "panda_finger_joint2"]     # the second mimics the first
    np.testing.assert_allclose([h.dof_lower[0], h.dof_upper[0]], [0.0, 0.04])
    T = h.link_transforms([0.03])
    gap = T["panda_leftfinger"][:3, 3] - T["panda_rightfinger"][:3, 3]
    assert np.linalg.norm(gap) == pytest.approx(0.06, abs=1e-9)               # both fingers slide 3 cm
    # The same hand as the hand-only URDF a user would cut out: same links, meshes and transforms.
    import pybullet_data
    whole = pathlib.Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf"
    cut = pg.load_hand(str(_panda_spec(tmp_path, _cut_urdf(whole, "panda_hand", tmp_path / "hand_only.urdf"))))
    assert cut.link_names == h.link_names and cut.joint_names == h.joint_names
    for a, b in zip(h.links, cut.links):
        np.testing.assert_array_equal(a.mesh.vertices, b.mesh.vertices)
    for q in np.random.default_rng(7).uniform(h.dof_lower, h.dof_upper, size=(5, 1)):
        Ta, Tb = h.link_transforms(q), cut.link_transforms(q)
        for name in h.link_names:
            np.testing.assert_allclose(Ta[name], Tb[name], atol=1e-12)


@pytest.mark.slow
def test_the_hand_inside_a_robot_plans_simulates_and_draws(tmp_path):
    out = tmp_path / "out"
    r = run("plan", "--hand", str(_panda_spec(tmp_path)), "--target", str(MODELS / "targets" / "box.stl"),
            "--top", "2", "--seed", "1", "--pictures", "1", "-o", str(out))
    assert r.returncode == 0, r.stderr
    doc = json.loads((out / "grasps.json").read_text())
    assert any(g["force_closure"] for g in doc["grasps"])
    assert {c["link"] for g in doc["grasps"] for c in g["contacts"]} <= {"panda_hand", "panda_leftfinger",
                                                                          "panda_rightfinger"}
    assert doc["pictures"] and all((out / p).exists() for p in doc["pictures"])
    r = run("simulate", str(out / "grasps.json"), "--top", "1", "--trials", "1")
    assert r.returncode == 0, r.stderr
    assert "held" in r.stdout
    r = run("view", str(out / "grasps.json"), "--export", str(tmp_path / "scene.glb"))
    assert r.returncode == 0, r.stderr
    trimesh = pytest.importorskip("trimesh")
    names = set(trimesh.load(str(tmp_path / "scene.glb"), force="scene").geometry)
    assert not any("panda_link" in n for n in names) and any("leftfinger" in n for n in names), names
