"""Every bad input of scripts/bad_inputs.py (the table in docs/reliability.md) fails cleanly: the command exits
non-zero with one `pairgrasp: error:` line naming the file or field and no traceback, leaving no output
folder; an API call raises the documented exception with a one-line message naming the field."""
import importlib.util
import pathlib
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("bad_inputs", ROOT / "scripts" / "bad_inputs.py")
bad_inputs = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = bad_inputs  # before it runs: its dataclasses look their module up
_spec.loader.exec_module(bad_inputs)


@pytest.fixture(scope="module")
def outcomes():
    return bad_inputs.run_all()


@pytest.mark.parametrize("k", range(len(bad_inputs.CASES)), ids=[c.input for c in bad_inputs.CASES])
def test_bad_input_fails_cleanly(outcomes, k):
    o = outcomes[k]
    assert not o.problems, f"{o.case.input}: {o.shown} -> {o.status} {o.message!r}: {'; '.join(o.problems)}"


def test_every_kind_of_input_is_covered():
    kinds = " ".join(c.input for c in bad_inputs.CASES)
    for word in ("STL", "OBJ", "PLY", "COLLADA", "paint", "hand spec", "URDF", "package://", "grasps.json",
                 "NaN", "budget", "millimetres", "watertight", "--edge", "DOF"):
        assert word in kinds, word
