"""The held-out benchmark's peers: GPG's (bench/gpg_peer.py) jaw geometry as GPG models it, read from
the hand's meshes, against the bundled jaw's URDF numbers, and GPG's hand frame put on the jaw (GPG
itself is not needed); the baselines' grasps (bench/baseline_peer.py) read back by pairgrasp's own
reader, as `pairgrasp simulate` reads them, and checked independently."""
import pathlib
import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import pairgrasp as pg

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench"))
import baseline_peer  # noqa: E402
import gpg_peer  # noqa: E402

JAW = ROOT / "models" / "parallel_jaw" / "parallel_jaw.json"


def test_jaw_geometry_from_the_urdf():
    # parallel_jaw.urdf: the fingers' joints at z = 0.05, each opening 0.04 m along -x / +x; the finger
    # mesh is 0.025 thick (x), 0.02 high (y) and 0.07 long (z); the approach is +z.
    g = gpg_peer.jaw_geometry(pg.load_hand(str(JAW)))
    assert g["opening"] == pytest.approx(0.08, abs=1e-6)
    assert g["finger_width"] == pytest.approx(0.025, abs=1e-6)
    assert g["depth"] == pytest.approx(0.07, abs=1e-6)
    assert g["half_height"] == pytest.approx(0.01, abs=1e-6)
    F = g["frame"]
    np.testing.assert_allclose(F[:3, 3], [0.0, 0.0, 0.05], atol=1e-9)
    np.testing.assert_allclose(F[:3, 2], [0.0, 0.0, 1.0], atol=1e-9)
    assert abs(F[0, 0]) == pytest.approx(1.0)             # the closing axis is x (either way)
    assert np.linalg.det(F[:3, :3]) == pytest.approx(1.0)


def test_gpg_frame_put_on_the_jaw():
    hand = pg.load_hand(str(JAW))
    g = gpg_peer.jaw_geometry(hand)
    rng = np.random.default_rng(3)
    for _ in range(5):
        H = np.eye(4)
        H[:3, :3] = Rotation.random(random_state=rng).as_matrix()
        H[:3, 3] = rng.uniform(-0.2, 0.2, 3)
        W = gpg_peer.wrist_pose(H, g)
        # the point between the fingers' roots lands on GPG's hand base, the approach on its approach
        np.testing.assert_allclose(W[:3, :3] @ [0.0, 0.0, 0.05] + W[:3, 3], H[:3, 3], atol=1e-12)
        np.testing.assert_allclose(W[:3, :3] @ np.asarray(hand.approach, float), H[:3, 2], atol=1e-12)
        # the open fingertips lie hand_depth along the approach, +-opening/2 + finger width across
        T = hand.link_transforms(np.asarray(hand.dof_upper, float))
        tips = []
        for name in ("pj_left_finger", "pj_right_finger"):
            V = np.asarray(hand.links[hand.link_index(name)].mesh.vertices, float)
            A = W @ np.asarray(T[name])
            tips.append(V @ A[:3, :3].T + A[:3, 3])
        along = np.concatenate(tips) @ H[:3, 2] - H[:3, 3] @ H[:3, 2]
        assert along.min() == pytest.approx(0.0, abs=1e-9) and along.max() == pytest.approx(g["depth"], abs=1e-9)
        across = np.concatenate(tips) @ H[:3, 0] - H[:3, 3] @ H[:3, 0]
        assert np.abs(across).max() == pytest.approx(0.04 + 0.025, abs=1e-9)
        assert np.sort(np.abs(across))[0] == pytest.approx(0.04, abs=1e-9)


def test_a_hand_that_is_not_a_jaw_is_refused():
    with pytest.raises(ValueError, match="one DOF"):
        gpg_peer.jaw_geometry(pg.load_hand(str(ROOT / "models" / "barrett" / "barrett.json")))


def test_baseline_grasps_read_back_as_a_plan(tmp_path):
    barrett = ROOT / "models" / "barrett" / "barrett.json"
    box = ROOT / "models" / "targets" / "box.stl"
    doc = baseline_peer.run("random", str(barrett), str(box), str(tmp_path), top=2, seed=3)
    planned = pg.grasps_file.load_planned(str(tmp_path / "grasps.json"))
    assert len(planned.grasps.grasps) == len(doc["grasps"]) == 2
    assert planned.hand.name == "barrett_bh8_28x" and len(planned.target.faces) == 12
    for g in planned.grasps.grasps:
        R = g.wrist_pose[:3, :3]
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-9)
        # the hand was brought in from outside: its wrist lies outside the box (0.06 x 0.06 x 0.12 m)
        x, y, z = g.wrist_pose[:3, 3]
        assert max(abs(x), abs(y)) > 0.03 or not 0.0 <= z <= 0.12
    with pytest.raises(ValueError, match="method"):
        baseline_peer.run("nearest", str(barrett), str(box), str(tmp_path))
