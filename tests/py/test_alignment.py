"""Alignment from Python: the six-pairing versor solver and the Aligner, checked against known
rigid transforms."""
import threading

import numpy as np
import pytest

import pairgrasp as pg


def random_rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def unit_rows(a):
    return a / np.linalg.norm(a, axis=1, keepdims=True)


def rot_deg(a, b):
    return np.degrees(np.arccos(np.clip((np.trace(a.T @ b) - 1) / 2, -1, 1)))


# ------------------------------------------------------------------ solver

def test_random_rigid_transforms_recovered():
    rng = np.random.default_rng(1)
    for _ in range(300):
        R, t = random_rotation(rng), rng.normal(size=3) * 0.1
        gp = rng.normal(size=(2, 3)) * 0.05
        gn = unit_rows(rng.normal(size=(2, 3)))
        cands = pg.solve_pair_pose(gp, gn, gp @ R.T + t, -(gn @ R.T))
        best = cands[0]
        assert np.abs(best.rotation - R).max() < 1e-9
        assert np.abs(best.translation - t).max() < 1e-9
        assert best.agreement == 3 and best.order == 0
        P = best.pose
        assert P.shape == (4, 4)
        assert np.allclose(P[:3, :3], best.rotation) and np.allclose(P[:3, 3], best.translation)
        assert np.allclose(P[3], [0, 0, 0, 1])


def test_candidate_versor_and_axis_angle_agree_with_rotation():
    rng = np.random.default_rng(2)
    R, t = random_rotation(rng), np.zeros(3)
    gp = rng.normal(size=(2, 3)) * 0.05
    gn = unit_rows(rng.normal(size=(2, 3)))
    c = pg.solve_pair_pose(gp, gn, gp @ R.T + t, -(gn @ R.T))[0]
    w, x, y, z = c.versor
    assert w >= 0 and abs(np.linalg.norm(c.versor) - 1) < 1e-12
    assert np.allclose(pg.versor_rotation(c.angle, c.axis), R, atol=1e-12)
    assert c.axis[2] >= 0  # upper hemisphere
    # rotation angle from the trace equals |angle|
    assert abs(rot_deg(np.eye(3), R) - np.degrees(abs(c.angle))) < 1e-8
    with pytest.raises(ValueError):
        c.rotation[0, 0] = 2.0  # read-only view


def test_underdetermined_antipodal_pair_returns_empty_list():
    gp = np.array([[0, 0, 0], [0.05, 0, 0.]])
    gn = np.array([[1, 0, 0], [-1, 0, 0.]])  # fingers facing each other along the line
    R = random_rotation(np.random.default_rng(3))
    tp, tn = gp @ R.T, -(gn @ R.T)
    assert pg.solve_pair_pose(gp, gn, tp, tn) == []
    status = pg.solve_pair_pose_status(gp, gn, tp, tn)
    assert status == pg.PairPoseStatus.underdetermined and str(status) == "underdetermined"
    gn_ok = unit_rows(np.array([[1, 0.3, 0], [-1, 0, 0.2]]))
    assert pg.solve_pair_pose_status(gp, gn_ok, gp @ R.T, -(gn_ok @ R.T)) == pg.PairPoseStatus.ok


def test_parallel_normals_across_the_line():
    rng = np.random.default_rng(4)
    gp = np.array([[0, 0, 0], [0.05, 0, 0.]])
    gn = np.array([[0, 0, 1], [0, 0, 1.]])
    for _ in range(20):
        R, t = random_rotation(rng), rng.normal(size=3) * 0.1
        cands = pg.solve_pair_pose(gp, gn, gp @ R.T + t, -(gn @ R.T))
        assert np.abs(cands[0].rotation - R).max() < 1e-9
        # the pair is symmetric: a half turn about the normal maps it onto itself, both orders fit
        assert sorted(c.order for c in cands if c.agreement == 3) == [0, 1]


def test_no_agreement_status():
    z = np.array([[0, 0, 1], [0, 0, 1.]])
    p = np.array([[0, 0, 0], [0.05, 0, 0.]])
    tn = unit_rows(np.array([[1, 0, 1], [-1, 0.5, 1.]]))
    assert pg.solve_pair_pose(p, z, p, tn) == []
    assert pg.solve_pair_pose_status(p, z, p, tn) == pg.PairPoseStatus.no_agreement


def test_solver_degenerate_fuzz_is_finite():
    rng = np.random.default_rng(5)
    dirs = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0], [0, -1, 0], [0, 0, -1.]])
    for _ in range(500):
        gp = 0.05 * dirs[rng.integers(6, size=2)]
        gn = dirs[rng.integers(6, size=2)]
        R = [np.eye(3), random_rotation(rng), -np.eye(3) + 2 * np.outer(dirs[0], dirs[0])][rng.integers(3)]
        for c in pg.solve_pair_pose(gp, gn, gp @ R.T, -(gn @ R.T)):
            assert np.isfinite(c.rotation).all() and np.isfinite(c.translation).all()
            assert np.allclose(c.rotation.T @ c.rotation, np.eye(3), atol=1e-12)


def test_solver_bad_input():
    p = np.zeros((2, 3))
    n = np.array([[0, 0, 1], [0, 0, 1.]])
    with pytest.raises(ValueError, match=r"gripper_points: expected \(2, 3\), got \(3, 3\)"):
        pg.solve_pair_pose(np.zeros((3, 3)), n, p, n)
    with pytest.raises(ValueError, match=r"target_normals: expected \(2, 3\), got \(2,\)"):
        pg.solve_pair_pose(p, n, p, np.zeros(2))
    with pytest.raises(ValueError, match="gripper_normals: row 1"):
        pg.solve_pair_pose(p, np.array([[0, 0, 1], [0, 0, 2.]]), p, n)
    with pytest.raises(ValueError, match="finite"):
        pg.solve_pair_pose(np.array([[np.nan, 0, 0], [0, 0, 0]]), n, p, n)
    with pytest.raises(ValueError, match="angle_tolerance"):
        pg.solve_pair_pose(p, n, p, n, angle_tolerance=-1.0)
    with pytest.raises(ValueError):
        pg.solve_pair_pose("not an array", n, p, n)


# ------------------------------------------------------------------ aligner

def potato_mesh():
    """A closed, smooth, asymmetric 'potato' of radius ~5 cm."""
    trimesh = pytest.importorskip("trimesh")
    ico = trimesh.creation.icosphere(subdivisions=4)
    d = np.asarray(ico.vertices)
    x, y, z = d.T
    r = 0.05 * (1 + 0.18 * np.sin(3 * x + 1) * np.cos(2 * y) + 0.12 * np.sin(4 * z + 2 * x + 0.5) + 0.1 * x * y)
    return pg.make_mesh(d * r[:, None], np.asarray(ico.faces, dtype=np.int32), "potato")


EDGE = 0.008


@pytest.fixture(scope="module")
def target():
    f = pg.tessellate(potato_mesh(), EDGE)
    fp, fn = np.asarray(f.points), np.asarray(f.normals)
    return fp, fn, pg.PairIndex(fp, fn, d_max=0.06)


def make_patch(fp, fn, centre, radius, count, rng):
    near = np.nonzero(np.linalg.norm(fp - fp[centre], axis=1) < radius)[0]
    sel = rng.choice(near, size=min(count, len(near)), replace=False)
    R, t = random_rotation(rng), rng.normal(size=3) * 0.1
    # gripper samples: p_G = R^T (p_T - t); normals point out of the finger: n_G = -R^T n_T
    return sel, R, t, (fp[sel] - t) @ R, -(fn[sel] @ R)


def is_truth(pose, sel, R, gp, fp):
    moved = gp @ np.asarray(pose.rotation).T + np.asarray(pose.translation)
    return rot_deg(np.asarray(pose.rotation), R) < 1.0 and np.abs(moved - fp[sel]).max() < 0.25 * EDGE


def test_aligner_defaults_from_spacing(target):
    fp, fn, index = target
    a = pg.Aligner(index)
    h = index.spacing
    assert np.allclose(a.tolerance, [0.5 * h, 0.1, 0.1])
    assert a.angle_tolerance == pytest.approx(np.radians(4))
    assert a.position_tolerance == pytest.approx(0.5 * h)
    b = pg.Aligner(index, tolerance=(0.002, 0.05, 0.05), angle_tolerance=0.1)
    assert np.allclose(b.tolerance, [0.002, 0.05, 0.05]) and b.angle_tolerance == 0.1


def test_aligner_recovers_moved_patch(target):
    fp, fn, index = target
    aligner = pg.Aligner(index)
    rng = np.random.default_rng(11)
    for _ in range(6):
        sel, R, t, gp, gn = make_patch(fp, fn, rng.integers(len(fp)), 0.025, 7, rng)
        poses = aligner.align(gp, gn)
        best = poses[0]
        assert is_truth(best, sel, R, gp, fp)
        assert best.votes >= 3 * 7 * 6 // 2  # every pair of 7 exact contacts agrees on three meetings
        assert best.quality == pytest.approx(best.votes / (1 + best.variance))
        assert np.allclose(best.pose[:3, :3], best.rotation) and np.allclose(best.pose[:3, 3], best.translation)
        contacts = {tuple(c) for c in np.asarray(best.contacts)}
        assert {(k, int(s)) for k, s in enumerate(sel)} <= contacts
        assert np.asarray(best.contacts).dtype == np.int32
        assert [p.quality for p in poses] == sorted((p.quality for p in poses), reverse=True)


def test_aligner_recovers_moved_patch_on_a_thinned_index(target):
    CAP = 64  # keeps 41% of the potato's pairs (at 16, 15%, 25 of 40 patches are still recovered)
    """With the index thinned (PairIndexOptions::max_pairs_per_cell) to well under half its pairs,
    random rigid motions of surface patches are still recovered, with the votes of the kept pairs:
    never more than the whole index gives the same patch."""
    fp, fn, full = target
    index = pg.PairIndex(fp, fn, d_max=0.06, max_pairs_per_cell=CAP)
    assert len(index) < 0.45 * len(full) and index.pairs_found == len(full)
    thinned, whole = pg.Aligner(index), pg.Aligner(full)
    rng = np.random.default_rng(12)
    for _ in range(6):
        sel, R, t, gp, gn = make_patch(fp, fn, rng.integers(len(fp)), 0.025, 7, rng)
        best = thinned.align(gp, gn)[0]
        assert is_truth(best, sel, R, gp, fp)
        assert best.votes <= whole.align(gp, gn)[0].votes


def test_pose_spread_follows_its_definition(target):
    """position_rms (m), angle_rms (rad) and the dimensionless variance as aligner.hpp defines them:
    an exact patch supported by its true votes alone has no spread; gripper points moved by Gaussian noise of sigma per axis leave
    position residuals of about sigma (a vote's residual is the mean of two points' noise, ~1.2 sigma
    in 3-D, less what the fitted pose absorbs) and rotations a fraction of the angle tolerance off;
    the variance is the weighted mean of the squared residuals, (position_rms / h)^2 +
    (angle_rms / tau)^2."""
    fp, fn, index = target
    aligner = pg.Aligner(index)
    h, tau = index.spacing, aligner.angle_tolerance
    rng = np.random.default_rng(21)
    sigma = 0.0003
    only_true = 0
    for _ in range(6):
        sel, R, t, gp, gn = make_patch(fp, fn, rng.integers(len(fp)), 0.025, 7, rng)
        exact = aligner.align(gp, gn)[0]
        assert is_truth(exact, sel, R, gp, fp)
        if exact.votes == 3 * 7 * 6 // 2:  # only the true votes (a neighbouring facet pair can join)
            only_true += 1
            assert exact.position_rms < 1e-8 and exact.angle_rms < 1e-9 and exact.variance < 1e-12
        noisy = aligner.align(gp + rng.normal(scale=sigma, size=gp.shape), gn)[0]
        assert is_truth(noisy, sel, R, gp, fp)
        assert 0.4 * sigma < noisy.position_rms < 2.5 * sigma
        assert 0.0 < noisy.angle_rms < tau
        for p in (exact, noisy):
            assert p.variance == pytest.approx((p.position_rms / h) ** 2 + (p.angle_rms / tau) ** 2,
                                               rel=1e-9, abs=1e-15)
            assert p.quality == pytest.approx(p.votes / (1 + p.variance))
    assert only_true >= 3


def test_align_many_matches_align_and_accepts_tuples_and_objects(target):
    fp, fn, index = target
    rng = np.random.default_rng(12)
    patches = [make_patch(fp, fn, rng.integers(len(fp)), 0.025, 6, rng) for _ in range(3)]

    class Samples:  # anything with .points and .normals
        def __init__(self, p, n):
            self.points, self.normals = p, n

    items = [(patches[0][3], patches[0][4]), Samples(patches[1][3], patches[1][4]), [patches[2][3], patches[2][4]]]
    ref = [pg.Aligner(index, threads=1).align(p[3], p[4]) for p in patches]
    for threads in (1, 2):
        many = pg.Aligner(index, threads=threads).align_many(items)
        assert len(many) == 3
        for got, want in zip(many, ref):
            assert len(got) == len(want)
            for x, y in zip(got, want):
                assert np.array_equal(x.rotation, y.rotation) and np.array_equal(x.translation, y.translation)
                assert x.votes == y.votes and np.array_equal(x.contacts, y.contacts)
    with_stats = pg.Aligner(index).align_many(items[:1], return_stats=True)
    assert isinstance(with_stats[0][1], pg.AlignStats)


def test_align_stats_and_saturation(target):
    fp, fn, index = target
    rng = np.random.default_rng(13)
    sel, R, t, gp, gn = make_patch(fp, fn, 40, 0.025, 7, rng)
    poses, stats = pg.Aligner(index).align(gp, gn, return_stats=True)
    assert stats.gripper_pairs == 21 and stats.correspondences > 0 and not stats.saturated
    poses, stats = pg.Aligner(index, capacity=16, min_agreement=1).align(gp, gn, return_stats=True)
    assert stats.saturated and stats.rotation_bins <= 16 and stats.dropped_rotation_votes > 0
    assert "saturated=True" in repr(stats)


def test_align_releases_the_gil_and_is_thread_safe(target):
    fp, fn, index = target
    aligner = pg.Aligner(index, threads=1)
    rng = np.random.default_rng(14)
    sel, R, t, gp, gn = make_patch(fp, fn, 70, 0.025, 7, rng)
    want = aligner.align(gp, gn)[0]
    out = [None] * 4

    def run(k):
        out[k] = aligner.align(gp, gn)[0]

    threads = [threading.Thread(target=run, args=(k,)) for k in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for got in out:
        assert np.array_equal(got.rotation, want.rotation) and got.votes == want.votes


def test_aligner_bad_input(target):
    fp, fn, index = target
    a = pg.Aligner(index)
    with pytest.raises(ValueError, match=r"points: expected \(P, 3\), got \(4,\)"):
        a.align(np.zeros(4), np.zeros((4, 3)))
    with pytest.raises(ValueError, match=r"normals: expected \(3,3\) like points, got \(2,3\)"):
        a.align(np.zeros((3, 3)), np.tile([0, 0, 1.0], (2, 1)))
    with pytest.raises(ValueError, match="normals: row 0"):
        a.align(np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"constellations\[1\]"):
        a.align_many([(np.zeros((2, 3)), np.tile([0, 0, 1.0], (2, 1))), 5])
    with pytest.raises(ValueError, match="tolerance: expected 3 values"):
        pg.Aligner(index, tolerance=(0.1, 0.1))
    with pytest.raises(ValueError, match="capacity"):
        pg.Aligner(index, capacity=0)
    with pytest.raises(ValueError, match="threads"):
        pg.Aligner(index, threads=-1)


def test_align_many_takes_hand_constellations(target):
    from pathlib import Path
    fp, fn, index = target
    hand = pg.load_hand(str(Path(__file__).resolve().parents[2] / "models" / "barrett" / "barrett.json"))
    lo, hi = np.asarray(hand.dof_lower), np.asarray(hand.dof_upper)
    cs = [hand.constellation(lo + f * (hi - lo), mode="per_link") for f in (0.2, 0.5, 0.8)]
    assert all(isinstance(c, pg.Constellation) for c in cs)
    aligner = pg.Aligner(index, threads=2)
    many = aligner.align_many(cs, return_stats=True)
    for c, (poses, stats) in zip(cs, many):
        want, want_stats = aligner.align(c.points, c.normals, return_stats=True)
        assert stats.correspondences == want_stats.correspondences and stats.gripper_pairs == 21
        assert [p.votes for p in poses] == [p.votes for p in want]
        assert all(np.array_equal(p.rotation, q.rotation) for p, q in zip(poses, want))
