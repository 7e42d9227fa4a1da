"""Replays the grasps.json fuzz harness's committed inputs (tests/fuzz/corpus/grasps, named ok_* when
they must load and bad_* when they must be refused, and tests/fuzz/regressions/grasps) through the
harness's own target, so that every input that ever broke the reader stays a test."""
import importlib.util
import pathlib
import sys

import pytest

FUZZ = pathlib.Path(__file__).resolve().parents[2] / "tests" / "fuzz"
_spec = importlib.util.spec_from_file_location("fuzz_grasps", FUZZ / "fuzz_grasps.py")
fuzz_grasps = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = fuzz_grasps  # before it runs: its dataclasses look their module up
_spec.loader.exec_module(fuzz_grasps)

SEEDS = sorted((FUZZ / "corpus" / "grasps").iterdir())
REGRESSIONS = FUZZ / "regressions" / "grasps"


def test_seeds_cover_both_outcomes():
    names = [p.name for p in SEEDS]
    assert any(n.startswith("ok_") for n in names) and any(n.startswith("bad_") for n in names)
    assert all(n.startswith(("ok_", "bad_")) for n in names)


@pytest.mark.parametrize("path", SEEDS, ids=lambda p: p.name)
def test_seed_loads_or_is_refused_as_named(path):
    want = "loaded" if path.name.startswith("ok_") else "rejected"
    assert fuzz_grasps.grasps_target(path.read_bytes()) == want


@pytest.mark.parametrize("path", sorted(REGRESSIONS.glob("*")) if REGRESSIONS.is_dir() else [],
                         ids=lambda p: p.name)
def test_regression_input_is_handled_cleanly(path):
    """Each input that once broke the reader is loaded or refused, never anything else (no input yet:
    reported as skipped)."""
    assert fuzz_grasps.grasps_target(path.read_bytes()) in ("loaded", "rejected")
