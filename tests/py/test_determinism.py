"""Determinism: `pairgrasp plan` with the same inputs and seed writes byte-identical grasps.json files
apart from the "timings" block, run after run and whatever the thread count."""
import json
import pathlib
import re
import subprocess
import sys

import pytest

MODELS = pathlib.Path(__file__).resolve().parents[2] / "models"
TIMINGS = re.compile(r'\n "timings": \{[^{}]*\},')


def plan(out, threads, seed=3):
    cmd = [sys.executable, "-m", "pairgrasp.cli", "plan", "--hand", str(MODELS / "parallel_jaw" / "parallel_jaw.json"),
           "--target", str(MODELS / "targets" / "box.stl"), "--paint", str(MODELS / "targets" / "box.paint.json"),
           "--edge", "0.008", "--top", "4", "--seed", str(seed), "--threads", str(threads), "--pictures", "0",
           "--quiet", "-o", str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    raw = (out / "grasps.json").read_bytes()
    text = raw.decode("utf-8")
    assert len(TIMINGS.findall(text)) == 1, "no single timings block to remove"
    return TIMINGS.sub("", text).encode("utf-8"), json.loads(raw)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("determinism")
    return {name: plan(d / name, threads) for name, threads in (("a", 1), ("b", 1), ("c", 2))}


@pytest.mark.long
def test_same_seed_gives_byte_identical_grasps(runs):
    assert runs["a"][0] == runs["b"][0]


@pytest.mark.long
def test_thread_count_does_not_change_a_byte(runs):
    assert runs["a"][0] == runs["c"][0]


@pytest.mark.long
def test_the_compared_files_hold_real_grasps(runs):
    doc = runs["a"][1]
    assert doc["grasps"] and doc["counts"]["evaluated"] > 0
    assert doc["timings"]["total"] > 0  # the one part left out of the comparison
    assert "threads" not in doc["parameters"]  # how it ran is not a parameter of the result

