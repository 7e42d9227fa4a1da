"""Memory bounds: a target over the pair budget is refused before its pairs (or its fine facets) are
allocated, naming a facet edge that fits; the aligner's fixed accumulator capacities are never
exceeded and their saturation is reported."""
import json
import math
import pathlib
import re
import subprocess
import sys

import numpy as np
import pytest

import pairgrasp as pg

MODELS = pathlib.Path(__file__).resolve().parents[2] / "models"
FLASK = MODELS / "targets" / "flask.stl"
BOX = MODELS / "targets" / "box.stl"
EDGE_RE = re.compile(r"a facet edge of ([0-9.eE+-]+) m fits")

# Run in a child process so that its peak resident memory is its own.
_CHILD = r"""
import json, resource, sys
import pairgrasp as pg
mesh = pg.load_mesh(sys.argv[1])
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
try:
    pg.build_target_index(mesh, edge=float(sys.argv[2]), d_max=0.2, max_pairs=int(sys.argv[3]))
    out = {"refused": False}
except ValueError as e:
    out = {"refused": True, "message": str(e)}
out["before_kib"] = before
out["peak_kib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps(out))
"""


def test_far_over_budget_is_refused_before_allocating_and_names_an_edge_that_fits():
    edge, budget = 0.0003, 2_000_000
    # Independent size of what was asked: the flask (0.185 m diagonal) lies within d_max = 0.2 m,
    # so every pair of its N ~ area / (0.866 edge^2) facets would be stored, ~20 bytes each.
    mesh = pg.load_mesh(str(FLASK))
    n = mesh.area / (math.sqrt(3) / 2 * edge ** 2)
    assert 0.5 * n * n * 20 > 100e9  # over 100 GB of pairs; the facets alone ~1.5 kB each: > 500 MB
    r = subprocess.run([sys.executable, "-c", _CHILD, str(FLASK), str(edge), str(budget)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["refused"], "an index of > 100 GB was built"
    message = out["message"]
    assert "\n" not in message and message.startswith("max_pairs: at a facet edge of 0.0003 m")
    assert f"budget of {budget} pairs" in message
    grown_mib = (out["peak_kib"] - out["before_kib"]) / 1024
    assert grown_mib < 100, f"refusing took {grown_mib:.0f} MiB"
    fit = float(EDGE_RE.search(message).group(1))
    target = pg.build_target_index(mesh, edge=fit, d_max=0.2, max_pairs=budget)
    facets = len(target.facets.points)
    assert len(target.index) == facets * (facets - 1) // 2 <= budget  # all pairs stored, within budget
    assert len(target.index) > budget / 2, "the named edge is needlessly coarse"


def test_just_over_budget_is_counted_exactly_and_names_an_edge_that_fits():
    mesh = pg.load_mesh(str(BOX))
    edge = 0.01
    facets = len(pg.tessellate(mesh, edge).points)
    pairs = facets * (facets - 1) // 2  # the box's diagonal (0.147 m) is within d_max
    budget = int(pairs / 1.2)  # inside the estimate's margin: the exact count decides
    with pytest.raises(ValueError) as e:
        pg.build_target_index(mesh, edge=edge, d_max=0.2, max_pairs=budget)
    message = str(e.value)
    assert f"{facets} unit facets and {pairs} pairs" in message
    fit = float(EDGE_RE.search(message).group(1))
    assert fit > edge
    target = pg.build_target_index(mesh, edge=fit, d_max=0.2, max_pairs=budget)
    n = len(target.facets.points)
    assert len(target.index) == n * (n - 1) // 2 <= budget
    # At the budget itself the same request is accepted.
    assert len(pg.build_target_index(mesh, edge=edge, d_max=0.2, max_pairs=pairs).index) == pairs


def test_cli_refuses_an_edge_over_the_budget_in_one_line(tmp_path):
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "pairgrasp.cli", "plan", "--hand",
                        str(MODELS / "barrett" / "barrett.json"), "--target", str(FLASK), "--edge", "0.0002",
                        "--quiet", "-o", str(out)], capture_output=True, text=True, timeout=600)
    assert r.returncode == 1
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pairgrasp: error: max_pairs: at a facet edge of 0.0002 m"), r.stderr
    assert EDGE_RE.search(lines[0]) and not out.exists()


@pytest.fixture(scope="module")
def aligned():
    """A mug index and a Barrett constellation that finds many correspondences."""
    hand = pg.load_hand(str(MODELS / "barrett" / "barrett.json"))
    mesh = pg.load_mesh(str(MODELS / "targets" / "mug.stl"))
    target = pg.build_target_index(mesh, edge=0.008, d_max=0.2)
    lo, hi = np.asarray(hand.dof_lower), np.asarray(hand.dof_upper)
    c = hand.constellation((lo + hi) / 2, mode="per_link")
    return target.index, c


def test_rotation_capacity_is_never_exceeded_and_saturation_is_reported(aligned):
    index, c = aligned
    _, free = pg.Aligner(index, min_agreement=1).align(c.points, c.normals, return_stats=True)
    assert not free.saturated and free.dropped_rotation_votes == 0 and free.rotation_bins > 64
    for capacity in (1, 8, 64):
        poses, st = pg.Aligner(index, capacity=capacity, min_agreement=1).align(c.points, c.normals,
                                                                               return_stats=True)
        assert st.rotation_bins == capacity  # filled, never more
        assert st.saturated and st.dropped_rotation_votes > 0
        # The same votes were cast; what did not fit was dropped and counted.
        assert st.rotation_votes == free.rotation_votes and st.dropped_rotation_votes < st.rotation_votes
        for p in poses:  # degraded gracefully: fewer poses, each still a rigid transform
            R = np.asarray(p.rotation)
            assert np.allclose(R.T @ R, np.eye(3), atol=1e-9) and np.isfinite(p.translation).all()


def test_position_capacity_is_never_exceeded_and_saturation_is_reported(aligned):
    index, c = aligned
    _, free = pg.Aligner(index, min_agreement=1).align(c.points, c.normals, return_stats=True)
    assert not free.saturated and free.position_bins > 4
    _, st = pg.Aligner(index, min_agreement=1, position_capacity=4).align(c.points, c.normals, return_stats=True)
    assert st.position_bins == 4 and st.saturated and st.dropped_position_votes > 0
    assert st.position_votes == free.position_votes
    assert st.dropped_rotation_votes == 0  # only the position accumulators were full
    assert "saturated=True" in repr(st)


def test_correspondence_cap_thins_and_is_reported(aligned):
    index, c = aligned
    _, free = pg.Aligner(index).align(c.points, c.normals, return_stats=True)
    cap = free.correspondences // 10
    _, st = pg.Aligner(index, max_correspondences=cap).align(c.points, c.normals, return_stats=True)
    assert st.correspondences == free.correspondences and st.correspondences_used <= cap and st.saturated


# ----------------------------------------------------------------------------- distance-field budget

BARRETT = MODELS / "barrett" / "barrett.json"


def _box(tmp_path, size):
    trimesh = pytest.importorskip("trimesh")
    path = tmp_path / "large_box.stl"
    trimesh.creation.box(size).export(path)
    return path


def test_field_estimate_bounds_the_built_fields_from_above():
    """The estimate is of the build's peak (temporary node ids included): at least the bytes the built
    fields hold, and within a small factor of them, on the bundled targets at two cells."""
    hand = pg.load_hand(str(BARRETT))
    for name in ("box", "mug", "flask"):
        mesh = pg.load_mesh(str(MODELS / "targets" / f"{name}.stl"))
        for cell in (0.001, 0.002):
            built = pg.GraspChecker(hand, mesh, field_cell=cell).distance_field_bytes
            estimate = pg.estimate_field_bytes(mesh, field_cell=cell)
            assert built <= estimate <= 8 * built, (name, cell, built, estimate)


def test_fields_over_the_budget_are_refused_naming_the_budget(tmp_path):
    # A 1.5 m x 1.5 m slab 10 cm thick (graspable across its thickness) at a 0.5 mm cell: its surface
    # (5.1 m^2) alone needs 5.1 / (2 mm)^2 bricks of 125 nodes in a shell about two bricks thick, over
    # 2 GB of floats: far over the default budget.
    path = _box(tmp_path, (1.5, 1.5, 0.1))
    with pytest.warns(pg.InputWarning, match="times the hand's span"):  # the early word, then the refusal
        with pytest.raises(ValueError, match=r"over the budget of 2 GB \(max_field_memory"):
            pg.Planner(str(BARRETT), str(path), edge=0.02, field_cell=0.0005)
    with pytest.warns(pg.InputWarning), pytest.raises(ValueError, match=r"over the budget of 0.001 GB"):
        pg.Planner(str(BARRETT), str(path), edge=0.02, max_field_memory=0.001)


def test_a_target_far_larger_than_the_hand_is_warned_about_before_anything_is_built(tmp_path):
    path = _box(tmp_path, (1.5, 0.8, 0.8))
    span = pg.hand_span(pg.load_hand(str(BARRETT)))
    assert 0.15 < span < 0.25  # the Barrett hand: fingertips up to ~0.2 m apart
    import warnings
    with warnings.catch_warnings():
        # As an error, the warning stops the constructor where it is given: before the index and the
        # fields, which take tens of seconds for this target.
        warnings.simplefilter("error", pg.InputWarning)
        with pytest.raises(pg.InputWarning, match=r"1.5 m across, \d+ times the hand's span"):
            pg.Planner(str(BARRETT), str(path))


def test_field_cell_follows_the_edge_and_can_be_set():
    hand = pg.load_hand(str(BARRETT))
    mesh = pg.load_mesh(str(FLASK))
    assert pg.resolve_planner(hand, mesh, edge=0.005).field_cell == pytest.approx(0.001)
    assert pg.resolve_planner(hand, mesh, edge=0.008).field_cell == pytest.approx(0.0016)
    assert pg.resolve_planner(hand, mesh, edge=0.004).field_cell == pytest.approx(0.001)   # not below 1 mm
    assert pg.resolve_planner(hand, mesh, edge=0.008, field_cell=0.002).field_cell == 0.002
    with pytest.raises(ValueError, match="field_cell"):
        pg.resolve_planner(hand, mesh, field_cell=0.0)
