"""Plans shared by several test files: the Barrett hand end to end on the bundled flask and mug (with
their paint) and on a mesh nobody here made (pybullet_data's duck), each planned once per session.

The DOF step is 0.5 rad (the fast schedule's coarse grid and refinement on it) so that the plans fit
the default test run; everything else is what a user runs: the Barrett hand's per-link
constellations, settling (back-off and finger opening), deepening, closing, epsilon and fine-tuning.
"""
import os
import pathlib

import numpy as np
import pytest

import pairgrasp as pg

# The CLI tests run `python -m pairgrasp ...` in other working directories: a relative PYTHONPATH
# (`PYTHONPATH=build/cpp/python`, as `make pytest` sets it) is made absolute so that they import
# the package under test, not another installed one (or none). The sanitized run (`make
# asan-pytest`) leaves it as it is: its CLI subprocesses use the package it installs.
if os.environ.get("PYTHONPATH") and not os.environ.get("PAIRGRASP_SANITIZED"):
    os.environ["PYTHONPATH"] = os.pathsep.join(
        os.path.abspath(p) for p in os.environ["PYTHONPATH"].split(os.pathsep) if p)

MODELS = pathlib.Path(__file__).resolve().parents[2] / "models"
BARRETT = MODELS / "barrett" / "barrett.json"
TARGETS = MODELS / "targets"
# The plans' shared parameters (a coarser step than the hand's 0.25 rad; two grasps fine-tuned).
E2E = dict(step=0.5, top=5, seed=1, fine_tune=2, fine_tune_iterations=5)


def duck_mesh():
    """pybullet_data's duck (an OBJ from a third-party package), scaled to 0.1 m along its longest side."""
    import pybullet_data

    path = os.path.join(pybullet_data.getDataPath(), "duck.obj")
    raw = pg.load_mesh(path)
    return pg.load_mesh(path, scale=0.1 / float(np.ptp(np.asarray(raw.bounds), axis=0).max()))


def _plan(target, paint=None, **kw):
    planner = pg.Planner(str(BARRETT), target, paint=paint, **{**E2E, **kw})
    return planner, planner.plan(progress=False)


@pytest.fixture(scope="session")
def barrett_flask():
    return _plan(str(TARGETS / "flask.stl"), str(TARGETS / "flask.paint.json"))


@pytest.fixture(scope="session")
def barrett_mug():
    return _plan(str(TARGETS / "mug.stl"), str(TARGETS / "mug.paint.json"))


@pytest.fixture(scope="session")
def barrett_duck():
    return _plan(duck_mesh())
