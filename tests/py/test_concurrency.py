"""Concurrency: align_many, align, check_many, check and close called from several Python threads at
once (each call itself multithreaded, the GIL released) give exactly the results of serial calls."""
import pathlib
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import pairgrasp as pg

MODELS = pathlib.Path(__file__).resolve().parents[2] / "models"
CALLERS = 4


@pytest.fixture(scope="module")
def scene():
    hand = pg.load_hand(str(MODELS / "barrett" / "barrett.json"))
    mesh = pg.load_mesh(str(MODELS / "targets" / "mug.stl"))
    target = pg.build_target_index(mesh, edge=0.008, d_max=0.2, threads=1)
    lo, hi = np.asarray(hand.dof_lower), np.asarray(hand.dof_upper)
    samples = []
    for spread in (0.0, 0.5):
        for f in (0.3, 0.6, 0.9):
            q = lo + f * (hi - lo)
            q[0] = lo[0] + spread * (hi[0] - lo[0])
            samples.append(q)
    constellations = [hand.constellation(q, mode="per_link") for q in samples]
    return hand, mesh, target, samples, constellations


def pose_key(p):
    """Everything an AlignedPose holds, as exact bytes."""
    return (np.asarray(p.rotation).tobytes(), np.asarray(p.translation).tobytes(), p.votes, p.quality,
            p.variance, np.asarray(p.contacts).tobytes())


def result_key(poses_and_stats):
    poses, stats = poses_and_stats
    return [pose_key(p) for p in poses], (stats.correspondences, stats.rotation_votes, stats.position_votes)


def check_key(r):
    return (r.pruned, r.collision, r.depth, r.target_depth, r.reason,
            [(link.link, link.depth, link.colliding, tuple(link.colliding_with)) for link in r.links],
            [(c.link, c.other, c.depth, c.intersecting, c.inside) for c in r.pairs])


def run_at_once(fn, n=CALLERS):
    """fn(t) on n Python threads started together; results in caller order."""
    with ThreadPoolExecutor(max_workers=n) as pool:
        return list(pool.map(fn, range(n)))


def test_align_many_and_align_from_threads_equal_serial(scene):
    _, _, target, _, cs = scene
    serial = pg.Aligner(target.index, threads=1)
    ref = [result_key(serial.align(c.points, c.normals, return_stats=True)) for c in cs]
    assert ref[0][0], "the reference alignment found no pose"
    shared = pg.Aligner(target.index, threads=2)

    def caller(t):
        many = [result_key(r) for r in shared.align_many(cs, return_stats=True)]
        one = [result_key(shared.align(cs[(k + t) % len(cs)].points, cs[(k + t) % len(cs)].normals,
                                       return_stats=True)) for k in range(len(cs))]
        return many, one

    for t, (many, one) in enumerate(run_at_once(caller)):
        assert many == ref, f"align_many on caller {t} differs from serial align"
        assert one == [ref[(k + t) % len(cs)] for k in range(len(cs))], f"align on caller {t} differs"


def test_check_many_check_and_close_from_threads_equal_serial(scene):
    hand, mesh, target, samples, cs = scene
    aligner = pg.Aligner(target.index, threads=1, max_poses=3)
    poses, dofs = [], []
    for q, c in zip(samples, cs):
        for p in aligner.align(c.points, c.normals):
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = p.rotation, p.translation
            away = T.copy()  # backed off along the approach: clear of the mug
            away[:3, 3] -= 0.15 * (np.asarray(p.rotation) @ np.asarray(hand.approach, float).ravel())
            poses += [T, away]
            dofs += [q, q]
    poses, dofs = np.array(poses), np.array(dofs)
    assert len(poses) >= 6
    checker = pg.GraspChecker(hand, mesh, depth_tolerance=0.002, threads=2)
    ref = [check_key(checker.check(T, q)) for T, q in zip(poses, dofs)]
    assert any(r[0] for r in ref) and not all(r[0] for r in ref), "want both pruned and kept poses"
    n_close = 4
    open_dofs = np.asarray(hand.dof_lower)
    close_ref = [checker.close(poses[k], open_dofs) for k in range(n_close)]
    close_ref = [(np.asarray(c.dofs).tobytes(), check_key(c.check)) for c in close_ref]

    def caller(t):
        many = [check_key(r) for r in checker.check_many(poses, dofs, threads=2)]
        one = [check_key(checker.check(poses[(k + t) % len(poses)], dofs[(k + t) % len(poses)]))
               for k in range(len(poses))]
        closed = []
        for k in range(n_close):
            c = checker.close(poses[(k + t) % n_close], open_dofs)
            closed.append((np.asarray(c.dofs).tobytes(), check_key(c.check)))
        return many, one, closed

    for t, (many, one, closed) in enumerate(run_at_once(caller)):
        assert many == ref, f"check_many on caller {t} differs from serial check"
        assert one == [ref[(k + t) % len(ref)] for k in range(len(ref))], f"check on caller {t} differs"
        assert closed == [close_ref[(k + t) % n_close] for k in range(n_close)], f"close on caller {t} differs"


def test_area_constellation_cache_filled_from_threads_equals_serial(scene):
    """The area constellation cache of a freshly loaded hand, filled by several threads at once."""
    _, _, _, samples, _ = scene
    fresh = pg.load_hand(str(MODELS / "barrett" / "barrett.json"))
    got = run_at_once(lambda t: fresh.constellation(samples[1], mode="area", spacing=0.012))
    ref = pg.load_hand(str(MODELS / "barrett" / "barrett.json")).constellation(samples[1], mode="area", spacing=0.012)
    assert len(ref.points) > 7
    for c in got:
        assert np.array_equal(c.points, ref.points) and np.array_equal(c.normals, ref.normals)
