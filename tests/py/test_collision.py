"""Validation from Python: SurfaceQuery against analytic boxes and a NumPy brute force, free masks
from occluders and viewpoints, and GraspChecker (penetration pruning, closing, contacts) on boxes
whose answers follow from their dimensions."""
import math
import pathlib
import threading

import numpy as np
import pytest

import pairgrasp as pg

ROOT = pathlib.Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
JAW = MODELS / "parallel_jaw" / "parallel_jaw.json"
BARRETT = MODELS / "barrett" / "barrett.json"


def box_mesh(lo, hi, name="box"):
    """Axis-aligned box [lo, hi] as 12 outward triangles."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    v = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    f = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                  [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return pg.make_mesh(v, f, name)


def box_sd(p, lo, hi):
    """Analytic signed distance to the box [lo, hi]."""
    c, h = (np.asarray(lo) + np.asarray(hi)) / 2, (np.asarray(hi) - np.asarray(lo)) / 2
    q = np.abs(p - c) - h
    return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)


def brute_distance(mesh, p):
    """Distance of points to a mesh by scanning every triangle (projection + clamped edges)."""
    V, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    best = np.full(len(p), np.inf)
    for a, b, c in V[F]:
        n = np.cross(b - a, c - a)
        n /= np.linalg.norm(n)
        q = p - np.outer((p - a) @ n, n)
        inside = ((np.cross(b - a, q - a) @ n >= 0) & (np.cross(c - b, q - b) @ n >= 0)
                  & (np.cross(a - c, q - c) @ n >= 0))
        d = np.where(inside, np.abs((p - a) @ n), np.inf)
        for s, e in ((a, b), (b, c), (c, a)):
            t = np.clip((p - s) @ (e - s) / ((e - s) @ (e - s)), 0, 1)
            d = np.minimum(d, np.linalg.norm(s + np.outer(t, e - s) - p, axis=1))
        best = np.minimum(best, d)
    return best


def pose(t=(0, 0, 0), angle=0.0, axis=(1, 0, 0)):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    T = np.eye(4)
    T[:3, :3] = np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K
    T[:3, 3] = t
    return T


# ---------------------------------------------------------------- SurfaceQuery

def test_surface_query_matches_analytic_box_and_brute_force():
    box = pg.load_mesh(MODELS / "targets" / "box.stl")  # 0.06 x 0.06 x 0.12 on z = 0
    lo, hi = (-0.03, -0.03, 0.0), (0.03, 0.03, 0.12)
    q = pg.SurfaceQuery(box)
    tol = 1e-8  # the STL stores float32 coordinates
    assert q.closed
    rng = np.random.default_rng(1)
    p = rng.uniform([-0.06, -0.06, -0.03], [0.06, 0.06, 0.15], size=(2000, 3))
    ref = box_sd(p, lo, hi)
    np.testing.assert_allclose(q.signed_distance(p), ref, atol=tol)
    np.testing.assert_array_equal(q.inside(p), ref <= 0)
    c = q.closest(p)
    np.testing.assert_allclose(c.distances, np.abs(ref), atol=tol)
    np.testing.assert_allclose(q.distance(p), np.abs(ref), atol=tol)
    np.testing.assert_allclose(np.linalg.norm(c.points - p, axis=1), c.distances, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(c.normals, axis=1), 1.0, atol=1e-12)
    # The normal is the reported face's own outward normal.
    np.testing.assert_allclose(c.normals, box.face_normals()[c.faces], atol=1e-12)
    assert c.points.flags.writeable is False  # a view of the result's own buffer


def test_surface_query_closest_matches_brute_force_on_the_mug():
    mug = pg.load_mesh(MODELS / "targets" / "mug.stl")
    q = pg.SurfaceQuery(mug)
    rng = np.random.default_rng(2)
    p = rng.uniform([-0.07, -0.05, -0.01], [0.09, 0.05, 0.11], size=(60, 3))
    np.testing.assert_allclose(q.distance(p), brute_distance(mug, p), atol=1e-12)


def test_ray_cast_matches_slab_intersection():
    lo, hi = np.array([-0.03, -0.03, 0.0]), np.array([0.03, 0.03, 0.12])
    q = pg.SurfaceQuery(pg.load_mesh(MODELS / "targets" / "box.stl"))
    rng = np.random.default_rng(3)
    o = rng.uniform(-0.2, 0.2, size=(500, 3))
    d = rng.normal(size=(500, 3))
    hits = q.ray_cast(o, d)
    dn = d / np.linalg.norm(d, axis=1, keepdims=True)
    with np.errstate(divide="ignore"):
        t1, t2 = (lo - o) / dn, (hi - o) / dn
    tin = np.maximum(np.minimum(t1, t2).max(axis=1), 0)
    tout = np.maximum(t1, t2).min(axis=1)
    expect = tin <= tout
    np.testing.assert_array_equal(hits.hit, expect)
    inside = box_sd(o, lo, hi) < 0
    ref_t = np.where(inside, tout, tin)
    np.testing.assert_allclose(hits.t[expect], ref_t[expect], atol=1e-7)  # float32 STL, grazing rays
    assert np.all(np.isinf(hits.t[~expect])) and np.all(hits.faces[~expect] == -1)
    t, faces = q.ray_hits([0, 0, -1], [0, 0, 1])  # through the box along z: enter at z=0, leave at 0.12
    assert len(t) >= 2 and abs(t[0] - 1.0) < 1e-8 and abs(t[-1] - 1.12) < 1e-8


def test_surface_query_errors():
    q = pg.SurfaceQuery(box_mesh((-1, -1, -1), (1, 1, 1)))
    with pytest.raises(ValueError, match=r"points: expected an \(N, 3\) array"):
        q.closest(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="points: row 1 is not finite"):
        q.signed_distance([[0, 0, 0], [np.nan, 0, 0]])
    with pytest.raises(ValueError, match="directions: row 0 is zero"):
        q.ray_cast([[0, 0, 0]], [[0, 0, 0]])
    open_mesh = pg.make_mesh(np.asarray(q.mesh.vertices), np.asarray(q.mesh.faces)[:-2], "open")
    with pytest.raises(ValueError, match="not closed"):
        pg.SurfaceQuery(open_mesh).inside([[0, 0, 0]])


# ---------------------------------------------------------------- free masks

def test_occluded_by_and_visible_from():
    box = pg.load_mesh(MODELS / "targets" / "box.stl")
    table = box_mesh((-0.5, -0.5, -0.05), (0.5, 0.5, 0.0), "table")  # the box stands on it
    n = box.face_normals()
    free = pg.occluded_by(box, [table], 0.001)
    assert free.dtype == bool and free.shape == (len(np.asarray(box.faces)),)
    # Every face touches z = 0 except the top two (the sides reach down to the table).
    np.testing.assert_array_equal(free, n[:, 2] > 0.5)
    free = pg.visible_from(box, [[1.0, 0.0, 0.06]])
    np.testing.assert_array_equal(free, n[:, 0] > 0.5)
    free = pg.visible_from(box, [[1.0, 0.0, 0.06], [0, 0, 1]], free=n[:, 2] < 0.5)
    np.testing.assert_array_equal(free, n[:, 0] > 0.5)
    with pytest.raises(ValueError, match="no free face left: "):
        pg.visible_from(box, [[1.0, 0.0, 0.06]], occluders=[box_mesh((0.5, -1, -1), (0.6, 1, 1), "wall")])
    with pytest.raises(ValueError, match="no free face left: "):
        pg.combine_free(n[:, 0] > 0.5, n[:, 0] < -0.5)
    with pytest.raises(ValueError, match="free: expected a boolean array"):
        pg.occluded_by(box, [table], 0.001, free=np.ones(12))
    with pytest.raises(ValueError, match="distance: "):
        pg.occluded_by(box, [table], -1.0)


# ---------------------------------------------------------------- GraspChecker

@pytest.fixture(scope="module")
def jaw():
    return pg.load_hand(JAW)


@pytest.fixture(scope="module")
def jaw_box():
    # 50 mm wide in x, between the jaw's fingers (wrist z 0.05..0.12, pads at x = -+opening/2).
    return box_mesh((-0.025, -0.02, 0.06), (0.025, 0.02, 0.11), "jaw box")


def test_check_depth_touching_and_wholly_inside(jaw, jaw_box):
    checker = pg.GraspChecker(jaw, jaw_box, depth_tolerance=0.00125, gap=0.001)
    # Opening 0.04: each pad 5 mm inside the 50 mm box.
    r = checker.check(np.eye(4), [0.04])
    assert r.collision and r.pruned and r.penetrating
    assert abs(r.depth - 0.005) < 1e-9
    assert "penetration 5.00 mm" in r.reason
    assert {p.link for p in r.pairs} == {"pj_left_finger", "pj_right_finger"}
    assert [lc.link for lc in r.links] == [l.name for l in jaw.links]
    # Opening 0.0502: 0.1 mm clear on each side: kept.
    r = checker.check(np.eye(4), [0.0502])
    assert not r.collision and not r.pruned and r.depth == 0 and r.reason == ""
    # A small target wholly inside the left finger's pad (x in [-0.048, -0.04], |y| <= 0.01,
    # z in [0.07, 0.12] at opening 0.08).
    pebble = box_mesh((-0.046, -0.005, 0.09), (-0.042, 0.005, 0.1), "pebble")
    r = pg.GraspChecker(jaw, pebble).check(np.eye(4), [0.08])
    pair = r.pairs[0]
    assert pair.link == "pj_left_finger" and not pair.intersecting and pair.inside
    # Deepest pebble points have x = -0.044: 4 mm from both pad faces (and >= 5 mm from the rest).
    assert abs(r.depth - 0.004) < 1e-9 and r.pruned


def test_check_many_equals_check_and_releases_the_gil(jaw, jaw_box):
    checker = pg.GraspChecker(jaw, jaw_box)
    rng = np.random.default_rng(5)
    K = 40
    poses = np.stack([pose(rng.uniform(-0.03, 0.03, 3), rng.uniform(-0.5, 0.5), rng.normal(size=3))
                      for _ in range(K)])
    dofs = rng.uniform(0, 0.08, size=(K, 1))
    many = checker.check_many(poses, dofs)
    serial = [checker.check(poses[k], dofs[k]) for k in range(K)]
    assert [r.pruned for r in many] == [r.pruned for r in serial]
    assert [r.depth for r in many] == [r.depth for r in serial]
    assert [r.reason for r in many] == [r.reason for r in serial]
    assert 0 < sum(r.pruned for r in many) < K
    # Several Python threads at once (the GIL is released inside).
    out = [None] * 4
    def work(i):
        out[i] = [r.depth for r in checker.check_many(poses, dofs, threads=1)]
    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(o == [r.depth for r in serial] for o in out)


def test_close_and_contacts_on_a_box(jaw, jaw_box):
    checker = pg.GraspChecker(jaw, jaw_box, gap=0.001)
    c = checker.close(np.eye(4), [0.08])
    assert c.reasons == ["contact"]
    assert list(c.directions) == [-1]
    assert 0.05 < c.dofs[0] <= 0.052 + 1e-12  # the box width plus at most twice the gap
    assert not c.check.pruned
    k = checker.contacts(np.eye(4), c.dofs)
    assert len(k) > 0
    assert k.points.shape == (len(k), 3) and k.normals.shape == (len(k), 3)
    left = k.points[:, 0] < 0
    np.testing.assert_allclose(k.normals[left], np.tile([-1, 0, 0], (left.sum(), 1)), atol=1e-12)
    np.testing.assert_allclose(k.normals[~left], np.tile([1, 0, 0], ((~left).sum(), 1)), atol=1e-12)
    np.testing.assert_allclose(np.abs(k.target_points[:, 0]), 0.025, atol=1e-12)
    assert left.sum() == (~left).sum() > 0
    assert set(k.link_names) == {"pj_left_finger", "pj_right_finger"}
    assert np.all((k.distances > 0) & (k.distances <= 0.001))
    # On air the jaw closes to its limit.
    far = pg.GraspChecker(jaw, box_mesh((1, 1, 1), (1.05, 1.04, 1.05)))
    assert far.close(np.eye(4), [0.06]).reasons == ["limit"]
    # Barrett: the spread does not close, the flexions do.
    bh = pg.load_hand(BARRETT)
    assert list(pg.closing_directions(bh, [0.3, 0.5, 0.5, 0.5])) == [0, 1, 1, 1]


def test_obstacles_and_occluded_faces(jaw, jaw_box):
    n = jaw_box.face_normals()
    free = n[:, 0] < 0.5  # +x face held by someone else
    plate = box_mesh((-0.035, -0.03, 0.055), (-0.03, 0.03, 0.13), "plate")
    checker = pg.GraspChecker(jaw, jaw_box, free=free, obstacles=[plate])
    assert checker.obstacle_names == ["plate"]
    r = checker.check(np.eye(4), [0.0505])  # right pad 0.25 mm from the occluded face; left in the plate
    assert r.touches_occluded and r.obstacle_collision and r.pruned
    assert "obstacle collision (pj_left_finger with plate)" in r.reason
    assert "touches occluded target faces (pj_right_finger)" in r.reason
    named = pg.GraspChecker(jaw, jaw_box, obstacles={"shelf": plate})
    assert named.obstacle_names == ["shelf"]


def test_checker_errors(jaw, jaw_box):
    checker = pg.GraspChecker(jaw, jaw_box)
    with pytest.raises(ValueError, match="wrist_pose: expected a 4x4 array"):
        checker.check(np.eye(3), [0.04])
    bad = np.eye(4)
    bad[0, 3] = np.nan
    with pytest.raises(ValueError, match="wrist_pose: not finite"):
        checker.check(bad, [0.04])
    with pytest.raises(ValueError, match="wrist_pose: rotation is not orthonormal"):
        checker.check(np.diag([2.0, 1, 1, 1]), [0.04])
    with pytest.raises(ValueError, match="dofs: expected 1, got 2"):
        checker.check(np.eye(4), [0.04, 0.0])
    with pytest.raises(ValueError, match="dofs"):
        checker.check(np.eye(4), [0.5])  # beyond the limit
    with pytest.raises(ValueError, match=r"poses: expected a \(K, 4, 4\) array"):
        checker.check_many(np.zeros((2, 3, 3)), np.zeros((2, 1)))
    with pytest.raises(ValueError, match=r"dofs: expected a \(2, 1\) array"):
        checker.check_many(np.stack([np.eye(4)] * 2), np.zeros((3, 1)))
    with pytest.raises(ValueError, match=r"poses\[1\]: "):
        checker.check_many(np.stack([np.eye(4), np.diag([1.0, 1, 1, 2])]), np.zeros((2, 1)))
    with pytest.raises(ValueError, match="free: expected 12, got 3"):
        pg.GraspChecker(jaw, jaw_box, free=np.ones(3, bool))
    with pytest.raises(ValueError, match="no free face left"):
        pg.GraspChecker(jaw, jaw_box, free=np.zeros(12, bool))
    with pytest.raises(ValueError, match="obstacles\\[0\\]: expected a pairgrasp.Mesh"):
        pg.GraspChecker(jaw, jaw_box, obstacles=[42])
    with pytest.raises(ValueError, match="depth_tolerance: "):
        pg.GraspChecker(jaw, jaw_box, depth_tolerance=-1)
    with pytest.raises(ValueError, match=r"directions\[0\]: expected -1, 0 or \+1"):
        checker.close(np.eye(4), [0.08], directions=[2])


def test_distance_field_checks_equal_the_exact_path(jaw, jaw_box):
    field = pg.GraspChecker(jaw, jaw_box)
    exact = pg.GraspChecker(jaw, jaw_box, use_distance_field=False)
    assert field.use_distance_field and not exact.use_distance_field
    assert field.distance_field_bytes > 0 and field.distance_field_seconds > 0
    assert exact.distance_field_bytes == 0
    rng = np.random.default_rng(3)
    poses = np.repeat(np.eye(4)[None], 64, axis=0)
    poses[:, :3, 3] = rng.uniform(-0.01, 0.01, (64, 3))
    dofs = rng.uniform(0.0, 0.08, (64, 1))
    bound = math.sqrt(3) / 2 * 0.001 + 1e-7
    for a, b in zip(exact.check_many(poses, dofs), field.check_many(poses, dofs)):
        assert (a.pruned, a.penetrating, a.collision, a.touches_occluded) == \
            (b.pruned, b.penetrating, b.collision, b.touches_occluded)
        assert abs(a.target_depth - b.target_depth) <= bound
    with pytest.raises(ValueError, match="field_cell"):
        pg.GraspChecker(jaw, jaw_box, field_cell=0.0)
