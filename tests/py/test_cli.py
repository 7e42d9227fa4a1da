"""The `pairgrasp` command line: the summary of the bundled models, and one-line errors."""
import json
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


def test_plan_writes_grasps_and_pictures(tmp_path):
    out = tmp_path / "out"
    r = run("plan", "--hand", str(MODELS / "parallel_jaw" / "parallel_jaw.json"),
            "--target", str(MODELS / "targets" / "box.stl"), "--paint", str(MODELS / "targets" / "box.paint.json"),
            "--edge", "0.008", "--top", "2", "--seed", "1", "-o", str(out))
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""  # no progress bar when stderr is not a terminal
    assert "epsilon" in r.stdout and "time" in r.stdout
    doc = json.loads((out / "grasps.json").read_text())
    assert doc["format"] == "pairgrasp.grasps/1"
    assert set(doc["timings"]) >= {"index", "schedule", "align", "settle", "evaluate", "fine_tune", "total"}
    assert doc["parameters"]["schedule"] == "fast" and doc["parameters"]["seed"] == 1
    assert doc["inputs"]["target"].endswith("box.stl")
    g = doc["grasps"][0]
    for key in ("rank", "wrist_pose", "dof", "joints", "epsilon", "volume", "force_closure", "alignment_quality",
                "votes", "penetration_depth", "contacts"):
        assert key in g
    assert g["force_closure"] and g["epsilon"] > 0
    assert len(g["dof"]) == 1 and len(g["joints"]) >= 1
    assert {"point", "normal", "link"} <= set(g["contacts"][0])
    pictures = sorted(p.name for p in out.glob("*.png"))
    assert pictures == doc["pictures"] and pictures
    assert not list(tmp_path.glob(".pairgrasp-*")), "temporary folder left behind"


@pytest.mark.parametrize("args, needle", [
    (["--target", "models/targets/no-such.stl"], "no-such.stl"),
    (["--step", "-0.5"], "--step"),
    (["--top", "0"], "--top"),
    (["--schedule", "slow"], "--schedule"),
    (["--paint", "models/targets/mug.paint.json"], "paint"),
    (["--viewpoint", "1", "2"], "--viewpoint"),
])
def test_plan_errors_write_nothing(tmp_path, args, needle):
    out = tmp_path / "out"
    base = {"--hand": str(MODELS / "parallel_jaw" / "parallel_jaw.json"), "--target": str(MODELS / "targets" / "box.stl")}
    for k in list(base):
        if k in args:
            base.pop(k)
    argv = ["plan"] + [x for kv in base.items() for x in kv] + args + ["--edge", "0.008", "-o", str(out)]
    r = run(*argv)
    assert r.returncode != 0
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("pairgrasp: error:"), r.stderr
    assert needle in lines[0]
    assert not out.exists()
    assert not list(tmp_path.glob(".pairgrasp-*"))
