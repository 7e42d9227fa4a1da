"""The approach-ray baseline of the peers benchmark (bench/approach_ray.py): ray grid, hits,
orientation and the straight move onto contact, checked on the bundled box by hand."""
import math
import pathlib
import sys

import numpy as np
import pytest

import pairgrasp as pg

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench"))
import approach_ray as ar  # noqa: E402

BOX = ROOT / "models" / "targets" / "box.stl"
BARRETT = ROOT / "models" / "barrett" / "barrett.json"


def test_side_offsets_by_hand():
    # e = 0.05, delta = 0.02: arange(-0.05, -0.005, 0.02), 0, arange(0.02, 0.05, 0.02)
    np.testing.assert_allclose(ar.side_offsets(0.05, 0.02), [-0.05, -0.03, -0.01, 0.0, 0.02, 0.04], atol=1e-12)
    np.testing.assert_allclose(ar.side_offsets(0.0, 0.02), [0.0])
    with pytest.raises(ValueError):
        ar.side_offsets(0.05, 0.0)


@pytest.fixture(scope="module")
def box():
    return pg.load_mesh(str(BOX))


def test_box_rays_grid_and_hits(box):
    """The box is 0.06 x 0.06 x 0.12 on z = 0: the grown box has half extents 0.04, 0.04, 0.07
    about (0, 0, 0.06), so 4 offsets along x and y and 8 along z: 2 (4*4) + 4 (4*8) = 160 rays,
    each starting on a side of the grown box and pointing inwards along an axis."""
    rays = ar.box_approach_rays(pg.SurfaceQuery(box), delta=0.02, margin=0.01)
    assert len(rays.origins) == 160
    centre, half = np.array([0.0, 0.0, 0.06]), np.array([0.04, 0.04, 0.07])
    box_half = np.array([0.03, 0.03, 0.06])
    for o, d, hit, p, n in zip(rays.origins, rays.directions, rays.hit, rays.points, rays.normals):
        axis = int(np.argmax(np.abs(d)))
        assert np.abs(d).sum() == pytest.approx(1.0) and abs(d[axis]) == 1.0
        # on the grown box's side, pointing inwards
        assert abs(o[axis] - centre[axis]) == pytest.approx(half[axis], abs=1e-6)  # STL: float32
        assert np.sign(o[axis] - centre[axis]) == -d[axis]
        lateral = [a for a in range(3) if a != axis]
        inside = np.abs(o[lateral] - centre[lateral]) - box_half[lateral]
        if np.all(inside < -1e-6):
            # hits the box face facing the ray, with the outward normal facing back along the ray
            assert hit
            assert abs(p[axis] - centre[axis]) == pytest.approx(box_half[axis], abs=1e-6)
            np.testing.assert_allclose(n, -d, atol=1e-9)
            np.testing.assert_allclose(p[lateral], o[lateral], atol=1e-12)
        elif np.any(inside > 1e-6):
            assert not hit


def test_approach_rotation_faces_the_direction_and_rolls():
    rng = np.random.default_rng(0)
    a = np.array([0.0, 0.0, 1.0])
    for d in list(rng.normal(size=(20, 3))) + [-a, a]:
        d = d / np.linalg.norm(d)
        r0 = ar.approach_rotation(a, d, 0.0)
        np.testing.assert_allclose(r0 @ a, d, atol=1e-12)
        np.testing.assert_allclose(r0.T @ r0, np.eye(3), atol=1e-12)
        assert np.linalg.det(r0) == pytest.approx(1.0)
        roll = rng.uniform(-math.pi, math.pi)
        r = ar.approach_rotation(a, d, roll)
        np.testing.assert_allclose(r @ a, d, atol=1e-12)
        rel = r0.T @ r  # a rotation about the approach axis by the roll
        np.testing.assert_allclose(rel @ a, a, atol=1e-12)
        assert math.atan2(rel[1, 0], rel[0, 0]) == pytest.approx(roll, abs=1e-9)
        if abs(d @ a) < 0.99:  # the smallest turn: its axis is perpendicular to both
            from scipy.spatial.transform import Rotation

            v = Rotation.from_matrix(r0).as_rotvec()
            assert abs(v @ a) < 1e-9 and abs(v @ d) < 1e-9


def test_touching_pose_touches_along_the_ray(box):
    """The hand ends on the ray's line, clear of the box, and 2 mm further along its approach it
    collides: it has moved until it touches."""
    hand = pg.load_hand(str(BARRETT))
    checker = pg.GraspChecker(hand, box)
    sampler = ar.ApproachRaySampler(checker, resolution=0.001)
    q = np.asarray(hand.dof_lower, float)
    side = [k for k in sampler.usable if sampler.rays.directions[k][0] == -1.0]  # rays onto the +x face
    k = min(side, key=lambda i: np.abs(sampler.rays.points[i][1:] - [0.0, 0.06]).sum())  # the face centre
    for roll, standoff in ((0.0, 0.0), (math.pi / 2, 0.025)):
        T = sampler.touching_pose(int(k), roll, q, standoff)
        assert T is not None
        approach = T[:3, :3] @ np.asarray(hand.approach, float)
        np.testing.assert_allclose(approach, [-1.0, 0.0, 0.0], atol=1e-12)
        offset = sampler.rays.points[k] - T[:3, 3]
        np.testing.assert_allclose(offset - (offset @ approach) * approach, 0.0, atol=1e-12)  # on the line
        assert not checker.check(T, q).collision
        closer = T.copy()
        closer[:3, 3] += (standoff + 0.002) * approach
        assert checker.check(closer, q).collision
        if standoff:
            nearer = T.copy()
            nearer[:3, 3] += (standoff - 0.002) * approach
            assert not checker.check(nearer, q).collision  # backed off by the standoff
