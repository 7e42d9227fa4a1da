"""The `pairgrasp` command line: the summary of the bundled models, and one-line errors."""
import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"


def run(*args):
    env = dict(os.environ)
    return subprocess.run([sys.executable, "-m", "pairgrasp.cli", *args], capture_output=True,
                          text=True, cwd=ROOT, env=env, timeout=300)


def test_info_on_bundled_models():
    r = run("info", "--hand", str(MODELS / "barrett" / "barrett.json"),
            "--target", str(MODELS / "targets" / "flask.stl"),
            "--paint", str(MODELS / "targets" / "flask.paint.json"))
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert "4 DOF" in out
    assert "7 per-link samples" in out
    assert "closed yes" in out
    assert "faces free" in out


@pytest.mark.parametrize("args, needle", [
    (["info", "--target", "models/targets/no-such-target.stl"], "no-such-target.stl"),
    (["info", "--hand", "models/no-such-hand.json"], "no-such-hand.json"),
    (["info", "--target", "models/targets/flask.stl", "--scale", "-1"], "scale"),
    (["info"], "--hand"),
    (["frobnicate"], "invalid choice"),
])
def test_errors_are_one_line(args, needle):
    r = run(*args)
    assert r.returncode != 0
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("pairgrasp: error:")
    assert needle in lines[0]
    assert "Traceback" not in r.stderr
