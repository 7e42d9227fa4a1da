"""Planning from C++ alone gives the Python Planner's grasps.

* In process: ``pg.plan_samples`` (the C++ planning call: align -> candidate pipeline -> ranking)
  on the grid samples equals ``Planner.plan(schedule="grid")``, which schedules the same samples
  from Python.
* The example program: ``examples/plan``'s ``plan_grasps``, built against the installed library and
  run by ctest (test ``plan_grasps_example``, Barrett on the painted flask at 0.5 rad), wrote a
  grasps.json; it holds the Python Planner's grasps (read back with the json module), and
  ``pg.load_grasps`` (what ``pairgrasp simulate`` reads) accepts it.
"""
import json
import os
import pathlib

import numpy as np
import pytest

import pairgrasp as pg

ROOT = pathlib.Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
FLASK = dict(hand=str(MODELS / "barrett" / "barrett.json"), target=str(MODELS / "targets" / "flask.stl"),
             paint=str(MODELS / "targets" / "flask.paint.json"))


@pytest.fixture(scope="module")
def grid_plan():
    planner = pg.Planner(FLASK["hand"], FLASK["target"], paint=FLASK["paint"], top=5, seed=0)
    return planner, planner.plan(schedule="grid", step=0.5, rank="robust", progress=False)


@pytest.mark.long
def test_cpp_plan_samples_equals_the_python_planner(grid_plan):
    planner, result = grid_plan
    lo, hi = np.asarray(planner.hand.dof_lower), np.asarray(planner.hand.dof_upper)
    axes = pg.dof_axes(lo, hi, planner.steps(0.5))
    samples = np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(axes), -1).T  # last DOF fastest
    grasps, candidates, counts, _ = pg.plan_samples(planner.core, samples, step=0.5, top=5, seed=0,
                                                  rank="robust")
    assert counts["samples"] == result.counts["samples"] == len(samples)
    for key in ("aligned_poses", "settled", "settled_aligned", "evaluated", "force_closure"):
        assert counts[key] == result.counts[key], key
    assert [c.evaluation.epsilon for c in candidates] == [c.epsilon for c in result.candidates]
    assert len(grasps) == len(result.grasps) == 5
    for g, p in zip(grasps, result.grasps):
        assert np.array_equal(g.evaluation.wrist_pose, p.wrist_pose)
        assert np.array_equal(g.evaluation.dofs, p.dofs)
        assert g.epsilon == p.epsilon and g.force_closure == p.force_closure
        assert g.robust.force_closure_probability == p.force_closure_probability    # the same robust ranking
        assert g.robust.epsilon == p.robust_epsilon


def _example_output():
    env = os.environ.get("PAIRGRASP_PLAN_EXAMPLE_JSON")
    found = [pathlib.Path(env)] if env else sorted(ROOT.glob("build/*/plan-example/flask.grasps.json"))
    return found[0] if found and found[0].exists() else None


@pytest.mark.long
def test_the_cpp_program_writes_the_python_planners_grasps(grid_plan, tmp_path):
    if os.environ.get("PAIRGRASP_SANITIZED"):
        pytest.skip("the example program is built without sanitizers; compared with the plain build's extension")
    path = _example_output()
    if path is None:
        pytest.skip("the plan_grasps example has not run (ctest -R plan_grasps_example writes its grasps.json)")
    _, result = grid_plan
    doc = json.loads(path.read_text())
    assert doc["format"] == "pairgrasp.grasps/1" and doc["parameters"]["schedule"] == "grid"
    assert doc["parameters"]["step"] == 0.5 and doc["counts"]["samples"] == result.counts["samples"]
    assert doc["parameters"]["rank"] == "robust" and doc["parameters"]["robust_samples"] == 8
    assert doc["counts"]["force_closure"] == result.counts["force_closure"]
    assert len(doc["grasps"]) == len(result.grasps) == 5
    for d, g in zip(doc["grasps"], result.grasps):
        want = g.to_dict()
        for key in ("wrist_pose", "dof", "epsilon", "volume", "alignment_quality", "penetration_depth", "sample",
                    "aligned_pose", "backoff", "force_closure_probability", "robust_epsilon", "load_resistance"):
            np.testing.assert_allclose(d[key], want[key], rtol=0, atol=1e-9, err_msg=key)
        assert (d["force_closure"], d["votes"], d["fine_tuned"]) == (want["force_closure"], want["votes"],
                                                                    want["fine_tuned"])
        assert [c["link"] for c in d["contacts"]] == [c["link"] for c in want["contacts"]]
        np.testing.assert_allclose([c["point"] for c in d["contacts"]], [c["point"] for c in want["contacts"]],
                                   rtol=0, atol=1e-9)
        assert d["joints"].keys() == want["joints"].keys()
    # What `pairgrasp simulate` reads: the document parses, with the hand and target it names.
    copy = tmp_path / "grasps.json"
    doc["inputs"] = {**doc["inputs"], "hand_spec": str(ROOT / doc["inputs"]["hand_spec"]),
                     "target": str(ROOT / doc["inputs"]["target"])}
    copy.write_text(json.dumps(doc))
    gf = pg.load_grasps(str(copy))
    assert len(gf.grasps) == 5 and gf.grasps[0].epsilon == pytest.approx(result.grasps[0].epsilon, abs=1e-9)
