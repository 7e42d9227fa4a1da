"""The planner: DOF grids, early rejection, settling, the whole pipeline on small cases, determinism,
parameter errors, contact reduction and the MDS projection of Figure 7."""
import dataclasses
import math
import os
import pathlib
import time

import numpy as np
import pytest

import pairgrasp as pg
from pairgrasp.render import classical_mds

MODELS = pathlib.Path(__file__).resolve().parents[2] / "models"
JAW = MODELS / "parallel_jaw" / "parallel_jaw.json"
BARRETT = MODELS / "barrett" / "barrett.json"
BOX = MODELS / "targets" / "box.stl"
BOX_PAINT = MODELS / "targets" / "box.paint.json"


# ----------------------------------------------------------------------------- DOF grid

def test_dof_axes_values():
    axes = pg.dof_axes([0.0, 0.0, 1.0], [1.0, 0.5, 1.0], [0.25, 0.2, 0.1])
    np.testing.assert_allclose(axes[0], [0.0, 0.25, 0.5, 0.75, 1.0])
    np.testing.assert_allclose(axes[1], [0.0, 0.2, 0.4, 0.5])  # last step shorter, upper limit kept
    np.testing.assert_allclose(axes[2], [1.0])  # a fixed DOF has one value
    with pytest.warns(DeprecationWarning, match="dof_axes"):  # the old name, kept for a release
        old = pg.dof_grid([0.0, 0.0, 1.0], [1.0, 0.5, 1.0], [0.25, 0.2, 0.1])
    assert all(np.array_equal(a, b) for a, b in zip(old, axes)) and len(old) == len(axes)


def test_grid_schedule_counts_every_sample():
    # The paper's grid: the Barrett hand at 0.25 rad has ceil(pi/0.25)+1 spread values and
    # ceil(2.44/0.25)+1 values per finger.
    hand = pg.load_hand(str(BARRETT))
    axes = pg.dof_axes(hand.dof_lower, hand.dof_upper, [0.25] * 4)
    n_spread = math.ceil(math.pi / 0.25) + 1
    n_flex = math.ceil(2.44 / 0.25) + 1
    assert [len(a) for a in axes] == [n_spread, n_flex, n_flex, n_flex]


# ----------------------------------------------------------------------------- jaw on a box

@pytest.fixture(scope="module")
def jaw_planner():
    # Area-sampled pads, aligned by the pair votes: the search's mechanics (ranks, deepening, early
    # rejection) on a hand with one DOF. The jaw's default, antipodal alignment is tested below.
    return pg.Planner(str(JAW), str(BOX), paint=str(BOX_PAINT), edge=0.008, top=3, seed=1, fine_tune=2,
                      fine_tune_iterations=6, poses_per_sample=3, constellation="area")


@pytest.fixture(scope="module")
def jaw_result(jaw_planner):
    return jaw_planner.plan(progress=False)


def test_jaw_box_antipodal_force_closure(jaw_planner, jaw_result):
    """A parallel jaw on a box: the best grasp is force-closure, every contact lies on a face of the
    box (its normal that face's, its point on the face's plane within the contact gap of 1 mm), and
    the two fingers press two opposite faces, one each."""
    g = jaw_result.grasps[0]
    assert g.force_closure and g.epsilon > 0
    lo, hi = np.asarray(jaw_planner.target.bounds)
    half = (hi - lo) / 2
    centre = (hi + lo) / 2
    n = np.asarray(g.contact_normals)
    axes = np.argmax(np.abs(n), axis=1)
    rows = np.arange(len(n))
    assert np.all(np.abs(np.abs(n[rows, axes]) - 1.0) < 1e-6), "contact normals are not a box face's"
    np.testing.assert_allclose(np.abs(g.contact_points[rows, axes] - centre[axes]), half[axes], atol=1e-3 + 1e-6)
    links = np.asarray(g.contact_links)
    opposed = False
    for a in range(3):
        plus = set(links[(axes == a) & (n[rows, axes] > 0)])
        minus = set(links[(axes == a) & (n[rows, axes] < 0)])
        opposed |= any(len({l, m}) == 2 for l in plus for m in minus)
    assert opposed, "no two opposite faces pressed by the two fingers"
    assert set(g.contact_links) == {"pj_left_finger", "pj_right_finger"}


def test_grasps_are_rigid_ranked_and_not_penetrating(jaw_planner, jaw_result):
    tol = jaw_planner.edge / 4
    eps = [g.epsilon for g in jaw_result.grasps]
    fc = [g.force_closure for g in jaw_result.grasps]
    assert fc == sorted(fc, reverse=True)
    for g in jaw_result.grasps:
        R = g.wrist_pose[:3, :3]
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-9)
        assert np.linalg.det(R) > 0
        assert g.penetration_depth <= tol + 1e-9
        lo, hi = np.asarray(jaw_planner.hand.dof_lower), np.asarray(jaw_planner.hand.dof_upper)
        assert np.all(g.dofs >= lo - 1e-12) and np.all(g.dofs <= hi + 1e-12)
    fc_eps = [e for e, f in zip(eps, fc) if f]
    assert fc_eps == sorted(fc_eps, reverse=True)


def test_reported_epsilon_uses_every_contact(jaw_planner, jaw_result):
    """The returned epsilon is the quality of all the grasp's contacts, not the reduced set."""
    g = jaw_result.grasps[0]
    q = pg.grasp_quality(g.contact_points, g.contact_normals, jaw_planner.center, jaw_planner.radius)
    assert q.epsilon == pytest.approx(g.epsilon, rel=1e-9)


def test_counts_and_timings(jaw_result):
    c = jaw_result.counts
    assert c["samples"] == c["rejected"] + c["aligned_samples"] + c["skipped"] and c["skipped"] == 0
    assert c["evaluated"] <= c["settled"] <= c["aligned_poses"]
    assert len(jaw_result.candidates) == c["evaluated"]
    for stage in ("index", "schedule", "align", "settle", "evaluate", "fine_tune", "total"):
        assert jaw_result.timings[stage] >= 0
    assert jaw_result.constellation == "area"  # as asked (the jaw's default is "antipodal")


def test_deterministic_for_a_seed(jaw_planner, jaw_result):
    again = jaw_planner.plan(progress=False)
    a, b = jaw_result.to_dict(), again.to_dict()
    a.pop("timings"), b.pop("timings")
    assert a == b


@pytest.mark.long
def test_time_limit_stops_the_search_between_chunks(jaw_planner):
    """A limit already passed when the search starts leaves every kept sample unsearched, counted
    as skipped, and returns no grasp rather than failing; a generous one changes nothing."""
    r = jaw_planner.plan(progress=False, time_limit=1e-9)
    c = r.counts
    assert r.grasps == [] and c["aligned_samples"] == 0 and c["evaluated"] == 0
    assert c["skipped"] == c["samples"] - c["rejected"] > 0
    again = jaw_planner.plan(progress=False, time_limit=1e6).to_dict()
    plain = jaw_planner.plan(progress=False).to_dict()
    for d in (again, plain):
        d.pop("timings")
        d["parameters"].pop("time_limit")
    assert again == plain


def test_time_limit_stops_within_the_chunk_under_way(barrett_flask):
    """A limit reached during the search: the chunk under way finishes and no other starts, so every
    candidate evaluated after the limit comes from the last chunk's samples; the samples left out
    are counted as skipped and no grasp is fine-tuned after the limit."""
    planner, full = barrett_flask
    chunk = 8
    search = sum(full.timings[k] for k in ("schedule", "align", "settle", "evaluate"))
    limit = 0.3 * search
    r = planner.plan(progress=False, chunk=chunk, time_limit=limit)
    c = r.counts
    assert 0 < c["aligned_samples"] < c["samples"] and c["skipped"] > 0
    assert c["samples"] == c["rejected"] + c["aligned_samples"] + c["skipped"]
    # Candidates evaluated after the limit all come from the chunk under way (which may have
    # evaluated none: its poses can all be dropped or duplicates, as happened under ASan's timing).
    late = [cand for cand in r.candidates if cand.time > limit]
    assert all(cand.sample_index >= c["aligned_samples"] - chunk for cand in late)
    assert not any(g.fine_tuned for g in r.grasps)


def _coarse_indices(n):
    """The coarse grid's indices on an axis of n values: every third, and the upper limit when it is
    2 or more fine steps beyond the last of them."""
    last = (n - 1) // 3 * 3
    return list(range(0, n, 3)) + ([n - 1] if n - 1 - last >= 2 else [])


@pytest.mark.long
def test_fast_refine_rounds_climb_from_the_last_round(jaw_planner):
    """Round 0 is the coarse grid alone (every third value, and the upper limit unless it is one
    fine step beyond the last of them); each further
    round appends samples (the neighbours of the best samples not yet a centre) and keeps every
    earlier candidate, so the best candidate's epsilon never falls."""
    hand = jaw_planner.hand
    n = len(pg.dof_axes(hand.dof_lower, hand.dof_upper, hand.dof_step)[0])
    runs = [jaw_planner.plan(progress=False, fine_tune=0, refine_rounds=k, min_force_closure_rate=0.0)
            for k in range(4)]
    assert runs[0].counts["samples"] == len(_coarse_indices(n))
    for a, b in zip(runs, runs[1:]):
        assert b.counts["samples"] >= a.counts["samples"]
        best = lambda r: max((c.epsilon for c in r.candidates), default=0.0)  # noqa: E731
        assert best(b) >= best(a)
        key = lambda c: (c.sample_index, c.epsilon, c.alignment_quality)  # noqa: E731
        assert [key(c) for c in b.candidates[:len(a.candidates)]] == [key(c) for c in a.candidates]
    assert runs[0].counts["samples"] < runs[1].counts["samples"] <= n


def _aligned_pose_counts(planner, qs, max_poses):
    """Poses an aligner of its own (same index, default tolerances) returns for each sample."""
    aligner = pg.Aligner(planner.tindex.index, max_poses=max_poses)
    return [len(poses) for poses in aligner.align_many([planner.constellation(q) for q in qs])]


def test_schedule_poses_per_sample():
    assert pg.PlanParams(schedule="grid").poses() == (3, 3)
    assert pg.PlanParams(schedule="fast").poses() == (6, 12)
    assert pg.PlanParams(schedule="grid", poses_per_sample=4).poses() == (4, 4)
    assert pg.PlanParams(schedule="fast", poses_per_sample=4, max_poses_per_sample=2).poses() == (4, 4)


@pytest.mark.long
def test_plan_time_poses_per_sample_above_the_constructors_is_honoured(jaw_planner):
    """The planner's aligner returns at most 10 poses per sample by default; asking plan() for 20
    must give up to 20 (what an aligner of its own returns), not silently 10."""
    assert jaw_planner.aligner.max_poses == 10
    r = jaw_planner.plan(schedule="grid", poses_per_sample=20, fine_tune=0, progress=False)
    hand = jaw_planner.hand
    qs = [np.array([v]) for v in pg.dof_axes(hand.dof_lower, hand.dof_upper, hand.dof_step)[0]]
    expect = _aligned_pose_counts(jaw_planner, qs, 20)
    assert max(expect) > 10
    assert r.counts["aligned_poses"] == sum(expect)


@pytest.mark.long
def test_deepening_adds_the_coarse_samples_next_poses(jaw_planner):
    """Asked for force closure in every candidate (a rate of 1), fast takes every coarse sample's
    poses of rank 3 to 11 after its first 3; asked for none (0), it takes none."""
    kw = dict(progress=False, fine_tune=0, refine_rounds=0, min_match_fraction=0.0)
    deep = jaw_planner.plan(min_force_closure_rate=1.0, **kw)
    none = jaw_planner.plan(min_force_closure_rate=0.0, **kw)
    assert 0 < sum(c.force_closure for c in deep.candidates) < len(deep.candidates)
    hand = jaw_planner.hand
    axis = pg.dof_axes(hand.dof_lower, hand.dof_upper, hand.dof_step)[0]
    coarse = [np.array([axis[k]]) for k in _coarse_indices(len(axis))]
    counts = _aligned_pose_counts(jaw_planner, coarse, 12)
    assert deep.counts["rejected"] == 0 and deep.counts["aligned_samples"] == len(coarse)
    assert deep.counts["deepened_poses"] == sum(max(n - 3, 0) for n in counts) > 0
    assert deep.counts["aligned_poses"] == sum(counts)
    assert none.counts["deepened_poses"] == 0 and none.counts["aligned_poses"] == sum(min(n, 3) for n in counts)
    # Deepening only adds candidates after the others.
    key = lambda c: (c.sample_index, c.epsilon, c.alignment_quality)  # noqa: E731
    assert [key(c) for c in deep.candidates[:len(none.candidates)]] == [key(c) for c in none.candidates]


def test_barrett_coarse_grid():
    """At 0.25 rad the Barrett spread has 14 values (0, ..., 3.0, pi) and each flexion 11 (0, ...,
    2.25, 2.44): the coarse grid takes every third, 5 and 4, and no upper limit, each only one
    fine step beyond the last coarse value (320 samples, counted though a spent time limit aligns
    none of them)."""
    pl = pg.Planner(str(BARRETT), str(BOX), edge=0.012, top=1)
    r = pl.plan(progress=False, step=0.25, refine_rounds=0, time_limit=1e-9)
    assert r.counts["samples"] == 5 * 4 * 4 * 4 and r.counts["aligned_samples"] == 0


def test_grid_schedule_runs_every_sample(jaw_planner):
    r = jaw_planner.plan(schedule="grid", progress=False, fine_tune=0)
    n = len(pg.dof_axes(jaw_planner.hand.dof_lower, jaw_planner.hand.dof_upper, jaw_planner.hand.dof_step)[0])
    assert r.counts["samples"] == n and r.counts["rejected"] == 0


def test_link_groups_follow_the_kinematic_tree():
    """The Barrett hand's palm and knuckles move with no flexion (the spread turns knuckles only),
    each flexion moves its own proximal and distal links: what the settling backs off for and what
    it opens."""
    pl = pg.Planner(str(BARRETT), str(BOX), edge=0.012, top=1)
    pipe = pg.CandidatePipeline(pl.checker, edge=pl.edge, backoff=pl.backoff)
    names = [l.name for l in pl.hand.links]
    fixed = {n for n, f in zip(names, pipe.fixed_links) if f}
    assert fixed == {"bh_palm", "bh_f1_knuckle", "bh_f2_knuckle", "bh_f3_knuckle"}
    for d, finger in ((1, "f1"), (2, "f2"), (3, "f3")):
        moved = {n for n, m in zip(names, pipe.dof_links[d]) if m}
        assert moved == {f"bh_{finger}_prox", f"bh_{finger}_dist"}
    spread = {n for n, m in zip(names, pipe.dof_links[0]) if m}
    assert {"bh_f1_knuckle", "bh_f2_knuckle"} <= spread and "bh_f3_knuckle" not in spread


def test_candidate_times_lie_in_the_evaluate_stage(jaw_planner):
    """Each candidate's time (from the start of plan()) falls after the stages that precede its
    evaluation (one stage on the grid) and within the wall time the caller measures."""
    t0 = time.perf_counter()
    r = jaw_planner.plan(schedule="grid", progress=False, fine_tune=0)
    wall = time.perf_counter() - t0
    times = [c.time for c in r.candidates]
    before = r.timings["schedule"] + r.timings["align"] + r.timings["settle"]
    assert times and min(times) >= before
    assert max(times) <= min(wall, before + r.timings["evaluate"] + 0.05)


# ----------------------------------------------------------------------------- a jaw's antipodal alignment

@pytest.fixture(scope="module")
def antipodal_jaw():
    return pg.Planner(str(JAW), str(BOX), edge=0.008, top=3, seed=1)


def _in_antipodal_box(features, w, cone):
    """Brute force over the stored features: a pair the jaw open at w can close on (d <= w, the
    normals opposed within twice the cone, their terms along the line at least cos(cone) each)."""
    f = np.asarray(features, float)
    return (f[:, 0] <= w + 1e-5) & (f[:, 1] <= -np.cos(2 * cone) + 1e-5) & (f[:, 2] >= 2 * np.cos(cone) - 1e-5)


def test_a_parallel_jaw_is_aligned_on_antipodal_pairs(antipodal_jaw):
    """By default a jaw's two pads are aligned on the target's antipodal pairs: a sample is rejected
    early exactly when no stored pair lies in that feature box (brute force), and the samples give
    grasp lines of eight turns each, the pads' line along a box face's normal the jaw spans."""
    assert antipodal_jaw.mode == "antipodal"
    hand = antipodal_jaw.hand
    feats = antipodal_jaw.tindex.index.features
    cone = np.radians(15.0)
    lo, hi = np.asarray(antipodal_jaw.target.bounds)
    for v in pg.dof_axes(hand.dof_lower, hand.dof_upper, hand.dof_step)[0]:
        q = np.array([v])
        c = antipodal_jaw.constellation(q)
        w = float(np.linalg.norm(np.asarray(c.points)[1] - np.asarray(c.points)[0]))
        any_pair = bool(_in_antipodal_box(feats, w, cone).any()) and w > 1e-6
        assert antipodal_jaw.match_fraction(q) == (1.0 if any_pair else 0.0), w
        poses = pg.Aligner(antipodal_jaw.tindex.index).align_antipodal(c.points, c.normals)
        assert len(poses) % 8 == 0 and (any_pair or not poses)   # the box query, then the exact cone test
        g = np.asarray(c.points)[1] - np.asarray(c.points)[0]
        for p in poses:
            axis = np.asarray(p.rotation) @ (g / np.linalg.norm(g))
            assert np.max(np.abs(axis)) == pytest.approx(1.0, abs=1e-6)      # a face normal of the box
            k = int(np.argmax(np.abs(axis)))
            assert hi[k] - lo[k] <= w + 1e-6                                 # a width the jaw spans


def test_antipodal_poses_per_sample_counts_grasp_lines(antipodal_jaw):
    """poses_per_sample counts a jaw's grasp lines, each with all its turns: the grid's candidates are
    those of an aligner of its own asked for that many lines."""
    r = antipodal_jaw.plan(schedule="grid", poses_per_sample=2, fine_tune=0, progress=False)
    hand = antipodal_jaw.hand
    aligner = pg.Aligner(antipodal_jaw.tindex.index, max_poses=2)
    expect = 0
    for v in pg.dof_axes(hand.dof_lower, hand.dof_upper, hand.dof_step)[0]:
        c = antipodal_jaw.constellation(np.array([v]))
        expect += len(aligner.align_antipodal(c.points, c.normals))
    assert r.counts["aligned_poses"] == expect > 0


def _depth_in_box(points, lo, hi):
    """How deep (m) each point lies inside the axis-aligned box [lo, hi] (<= 0: outside)."""
    return np.minimum(points - lo, hi - points).min(axis=1)


def test_a_jaw_is_checked_exactly_and_its_grasps_clear_the_box(antipodal_jaw):
    """A jaw's antipodal search builds no distance field (its few candidates cost less exactly), the
    Barrett hand's per-link search does; the jaw's returned grasps penetrate the box by no more than
    the depth tolerance, measured on the link meshes' vertices against the box's own faces."""
    assert not antipodal_jaw.core.setup.distance_fields
    assert antipodal_jaw.core.checker.distance_field_bytes == 0
    barrett = pg.Planner(str(BARRETT), str(BOX), edge=0.008)
    assert barrett.core.setup.distance_fields and barrett.core.checker.distance_field_bytes > 0
    r = antipodal_jaw.plan(progress=False)
    assert r.grasps and r.grasps[0].force_closure
    lo, hi = np.asarray(antipodal_jaw.target.bounds)
    hand = antipodal_jaw.hand
    tol = antipodal_jaw.core.setup.depth_tolerance
    for g in r.grasps:
        poses = hand.link_transforms(g.dofs)
        for link in hand.links:
            if not len(link.mesh.vertices):
                continue
            T = g.wrist_pose @ np.asarray(poses[link.name])
            v = np.asarray(link.mesh.vertices) @ T[:3, :3].T + T[:3, 3]
            assert _depth_in_box(v, lo, hi).max() <= tol + 1e-9, (g.rank, link.name)


def test_antipodal_alignment_of_a_hand_that_is_no_jaw_is_refused_by_name():
    with pytest.raises(ValueError, match=r"^constellation: 'antipodal' needs a parallel jaw .* has 7 per-link samples"):
        pg.Planner(str(BARRETT), str(BOX), constellation="antipodal")


@pytest.mark.long
@pytest.mark.parametrize("target", ["flask", "box", "mug"])
def test_the_jaws_plan_force_closure_on_every_bundled_target(target):
    """The bundled jaw and pybullet_data's Franka Panda hand (its whole arm's URDF, the proposed
    spec) get force-closure grasps with a contact on each pad on every bundled target."""
    import pybullet_data

    panda = pg.propose_spec(os.path.join(pybullet_data.getDataPath(), "franka_panda", "panda.urdf"), "panda_hand")
    for hand in (pg.load_hand(str(JAW)), _hand_from_spec(panda)):
        r = pg.Planner(hand, str(MODELS / "targets" / f"{target}.stl"), top=3, seed=1).plan(progress=False)
        assert r.constellation == "antipodal"
        fc = [g for g in r.grasps if g.force_closure]
        assert fc, f"{hand.name} on {target}: no force-closure grasp"
        pads = {l.name for l in hand.links if len(l.active_faces)}
        assert set(fc[0].contact_links) == pads, (hand.name, target)


def _hand_from_spec(spec):
    import json
    import tempfile

    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump(spec, f)
    try:
        return pg.load_hand(f.name)
    finally:
        os.remove(f.name)


# ----------------------------------------------------------------------------- early rejection

def test_match_fraction_equals_brute_force(jaw_planner):
    """The early-rejection score counts the gripper pairs with at least one target pair inside the
    aligner's tolerance box: the same as scanning every stored feature."""
    feats_t = np.asarray(jaw_planner.tindex.index.features, float)
    tol = np.asarray(jaw_planner.aligner.tolerance, float)
    for q in (jaw_planner.hand.dof_lower, jaw_planner.hand.dof_upper):
        q = np.asarray(q, float)
        c = jaw_planner.constellation(q)
        pts, nrm = np.asarray(c.points), -np.asarray(c.normals)
        i, j = np.triu_indices(len(pts), 1)
        f = np.asarray(pg.pair_feature(pts[i], nrm[i], pts[j], nrm[j]))
        hit = [np.any(np.all(np.abs(feats_t - x) <= tol, axis=1)) for x in f]
        assert jaw_planner.match_fraction(q) == pytest.approx(sum(hit) / len(f), abs=1e-12)
    # The schedule scores many samples in one call (C++, on the thread pool): the same values.
    qs = np.linspace(jaw_planner.hand.dof_lower, jaw_planner.hand.dof_upper, 7)
    assert list(jaw_planner.core.match_fractions(qs)) == [jaw_planner.match_fraction(q) for q in qs]
    with pytest.raises(ValueError, match="dofs"):
        jaw_planner.core.match_fractions(np.full((2, len(jaw_planner.hand.dof_lower)), np.nan))


# ----------------------------------------------------------------------------- errors

@pytest.mark.parametrize("field, value", [
    ("schedule", "random"), ("step", -0.1), ("step", float("nan")), ("top", 0), ("min_match_fraction", 1.5),
    ("constellation", "hull"), ("poses_per_sample", 0), ("contacts_per_link", -1), ("edge", 0.0),
    ("chunk", 0), ("time_limit", 0.0), ("time_limit", -1.0), ("refine_rounds", -1),
    ("min_force_closure_rate", -0.1), ("min_force_closure_rate", True), ("max_poses_per_sample", 0),
    ("rank", "best"), ("field_cell", -0.001), ("max_field_memory", 0.0), ("max_pairs", 0), ("seed", -1),
    ("threads", -2), ("reject", "yes"), ("max_faces", 3), ("mu", float("nan")), ("depth_tolerance", -0.001),
    ("max_pairs_per_cell", -1), ("max_pairs_per_cell", 1.5),
])
def test_bad_parameters_name_the_field(field, value):
    p = dataclasses.replace(pg.PlanParams(), **{field: value})
    with pytest.raises(ValueError, match=field):
        p.validate()


# The C++ options' own checks, as Python reaches them: one ValueError naming the field (the same
# message tests/cpp/test_options.cpp checks from C++).
@pytest.mark.parametrize("field, value", [
    ("edge", 0.0), ("edge", float("nan")), ("d_max", -1.0), ("spacing", float("inf")), ("depth_tolerance", -0.001),
    ("gap", float("nan")), ("backoff", -0.01), ("field_cell", 0.0), ("max_pairs", 0), ("max_field_bytes", 0.0),
    ("max_field_bytes", float("inf")), ("max_area_samples", 2), ("threads", -1), ("threads", 2**40),
    ("edge", "5 mm"), ("max_area_samples", True),
])
def test_bad_core_planner_options_name_the_field(field, value):
    hand, mesh = pg.load_hand(str(JAW)), pg.load_mesh(str(BOX))
    with pytest.raises(ValueError, match=f"^{field}: "):
        pg.GraspPlanner(hand, mesh, **{field: value})
    with pytest.raises(ValueError, match=f"^{field}: "):
        pg.resolve_planner(hand, mesh, **{field: value})


@pytest.mark.parametrize("field, value", [
    ("poses_per_sample", 0), ("max_poses_per_sample", 0), ("chunk", 0), ("step", 0.0), ("step", float("nan")),
    ("backoff", -1.0), ("top", 0), ("fine_tune", -1), ("fine_tune_iterations", -1), ("mu", -0.5), ("mu", "high"),
    ("edges", 2), ("contacts_per_link", -1), ("max_evaluations", 0), ("hull_rank", -1), ("robust_samples", 0),
    ("seed", -1), ("seed", 1.5), ("top", 2**40),
])
def test_bad_search_options_name_the_field(jaw_planner, field, value):
    with pytest.raises(ValueError, match=f"^{field}: "):
        pg.GraspSearch(jaw_planner.core, **{field: value})
    with pytest.raises(ValueError, match="unknown plan option 'topp'"):
        pg.GraspSearch(jaw_planner.core, topp=3)


def test_bad_planner_inputs():
    with pytest.raises(ValueError, match="unknown planner parameter"):
        pg.Planner(str(JAW), str(BOX), frobnicate=1)
    mesh = pg.load_mesh(str(BOX))
    with pytest.raises(ValueError, match="paint"):
        pg.Planner(str(JAW), mesh, paint=np.zeros(len(mesh.faces), bool))
    with pytest.raises(ValueError, match="paint"):
        pg.Planner(str(JAW), mesh, paint=np.ones(3, bool))
    with pytest.raises(pg.FileError, match="nope.stl"):
        pg.Planner(str(JAW), "nope.stl")


@pytest.mark.parametrize("field,value", [
    ("edge", 0.002), ("d_max", 0.3), ("max_pairs", 1000), ("max_faces", 10), ("constellation", "per_link"),
    ("spacing", 0.01), ("max_area_samples", 5), ("depth_tolerance", 0.0001), ("gap", 0.002), ("threads", 1),
])
def test_plan_time_fields_cannot_change_what_the_constructor_built(jaw_planner, field, value):
    # What the constructor resolved (the index, the checker) is refused at plan time rather than
    # recorded in the result's parameters and silently not used.
    assert getattr(jaw_planner.params, field) != value
    with pytest.raises(ValueError, match=f"{field}: fixed when the Planner is built"):
        jaw_planner.plan(**{field: value})


@pytest.mark.long
def test_backoff_is_a_plan_time_field(jaw_planner):
    """``backoff`` given to plan() is the one the settling uses: the same grasps and counts as a
    Planner built with it, and other counts than the default's (a 2 mm back-off clears fewer poses
    than half the hand's reach)."""
    def key(r):
        return ([(g.epsilon, g.wrist_pose.round(12).tolist()) for g in r.grasps],
                {k: v for k, v in r.counts.items()}, r.params.backoff)
    at_plan = jaw_planner.plan(schedule="grid", backoff=0.002, progress=False)
    built = pg.Planner(str(JAW), str(BOX), paint=str(BOX_PAINT), params=jaw_planner.params,
                       backoff=0.002).plan(schedule="grid", progress=False)
    assert key(at_plan) == key(built)
    default = jaw_planner.plan(schedule="grid", progress=False)
    assert default.params.backoff is None and at_plan.params.backoff == 0.002
    assert default.counts["settled"] > at_plan.counts["settled"]


# ----------------------------------------------------------------------------- contact reduction

def test_reduce_contacts_keeps_extremes():
    pts = np.stack([np.linspace(0, 1, 11), np.zeros(11), np.zeros(11)], axis=1)
    keep = pg.reduce_contacts(pts, ["a"] * 11, 2)
    assert sorted(keep.tolist()) == [0, 10]
    keep = pg.reduce_contacts(pts, ["a"] * 5 + ["b"] * 6, 1)
    assert len(keep) == 2
    with pytest.raises(ValueError, match="per_link"):
        pg.reduce_contacts(pts, ["a"] * 11, 0)


@pytest.mark.long
def test_reduced_epsilon_is_a_lower_bound():
    rng = np.random.default_rng(3)
    for _ in range(20):
        n = 24
        normals = rng.normal(size=(n, 3))
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        points = normals * 0.05 + rng.normal(scale=0.002, size=(n, 3))
        links = [f"l{k % 4}" for k in range(n)]
        full = pg.grasp_quality(points, normals, np.zeros(3), 0.05)
        k = pg.reduce_contacts(points, links, 3)
        part = pg.grasp_quality(points[k], normals[k], np.zeros(3), 0.05)
        assert part.epsilon <= full.epsilon + 1e-12
        assert not part.force_closure or full.force_closure


# ----------------------------------------------------------------------------- Figure 7's projection

def test_classical_mds_preserves_planar_distances():
    rng = np.random.default_rng(0)
    plane = rng.normal(size=(30, 2))
    basis, _ = np.linalg.qr(rng.normal(size=(4, 2)))
    x = plane @ basis.T + rng.normal(size=4)
    y = classical_mds(x, 2)
    d = lambda a: np.sqrt(((a[:, None] - a[None]) ** 2).sum(-1))  # noqa: E731
    np.testing.assert_allclose(d(y), d(plane), atol=1e-8)


@pytest.mark.long
def test_same_result_on_one_thread(jaw_result):
    one = pg.Planner(str(JAW), str(BOX), paint=str(BOX_PAINT), edge=0.008, top=3, seed=1, fine_tune=2,
                     fine_tune_iterations=6, poses_per_sample=3, constellation="area", threads=1).plan(progress=False)
    a, b = jaw_result.to_dict(), one.to_dict()
    for d in (a, b):
        d.pop("timings")
    assert a == b


@pytest.mark.slow
@pytest.mark.parametrize("target", ["box", "mug", "flask"])
def test_returned_ranking_equals_scoring_every_candidate_fully(target):
    """Only the candidates that can reach the best epsilons pay for their hulls (hull_rank); the grasps
    finish() returns, and their order, are those of scoring every candidate fully (hull_rank = 0),
    by epsilon and by load (the default), with the near-duplicate key of the search (wrist rotation
    included)."""
    hand = pg.load_hand(str(MODELS / "barrett" / "barrett.json"))
    core = pg.GraspPlanner(hand, pg.load_mesh(str(MODELS / "targets" / f"{target}.stl")))
    axes = pg.dof_axes(hand.dof_lower, hand.dof_upper, [1.0] * len(hand.dof_names))
    samples = np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(axes), -1).T
    for rank in ("epsilon", "load"):
        runs = [pg.plan_samples(core, samples, top=5, fine_tune=0, seed=1, hull_rank=h, rank=rank)[0]
                for h in (None, 0)]
        assert len(runs[0]) == len(runs[1]) > 0, rank
        for a, b in zip(*runs):
            ea, eb = a.evaluation, b.evaluation
            assert np.allclose(ea.wrist_pose, eb.wrist_pose) and np.allclose(ea.dofs, eb.dofs), rank
            assert a.epsilon == pytest.approx(b.epsilon, abs=1e-12), rank
