"""The scenes benchmark's summary (bench/bench_scenes.py): the table modes' plan time against the same
object free-floating and in the same resting pose without the table (`rest`), from plan times written
here; and the plan command of each mode."""
import pathlib
import sys
import types

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench"))
import bench_scenes  # noqa: E402


def run(obj, mode, plan_time):
    obj = types.SimpleNamespace(name=obj, rel=f"{obj}.obj", split="test", scale=1.0)
    r = bench_scenes.blank_record(obj, "barrett", mode, 0.08, 3)
    r.update(plan_time=plan_time, fc_grasps=5)
    return r


def test_table_time_against_free_and_rest():
    times = {"a": {"support": 6.0, "free": 4.0, "rest": 5.0},     # 1.5 of free, 1.2 of rest
             "b": {"support": 3.0, "free": 3.0, "rest": 2.0},     # 1.0 and 1.5
             "c": {"support": 2.0, "free": 4.0, "rest": 4.0}}     # 0.5 and 0.5
    runs = [run(o, m, t) for o, ts in times.items() for m, t in ts.items()]
    lines, _ = bench_scenes.summarize(runs, ["barrett"], ["support", "free", "rest"])
    header = [c.strip() for c in lines[0].strip("|").split("|")]
    rows = {c[1]: c for c in ([x.strip() for x in line.strip("|").split("|")] for line in lines[2:])}
    free_col, rest_col = header.index("table / free plan time, median (max)"), header.index("table / rest plan time, median (max)")
    assert rows["support"][free_col] == "1.00 (1.50), n = 3"
    assert rows["support"][rest_col] == "1.20 (1.50), n = 3"
    assert rows["free"][free_col] == rows["rest"][rest_col] == "–"


def test_each_mode_plans_its_pose_and_scene(tmp_path):
    files = {"rest": "obj_rest.stl", "free": "obj_free.stl", "table": "obj_table.stl", "height": 0.08}
    obj = types.SimpleNamespace(name="obj")
    cmds = {m: bench_scenes.plan_command(obj, files, "barrett", m, str(tmp_path), 1, 5)[1] for m in bench_scenes.MODES}
    target = {m: c[c.index("--target") + 1] for m, c in cmds.items()}
    assert target == {"support": "obj_rest.stl", "mesh": "obj_rest.stl", "free": "obj_free.stl", "rest": "obj_rest.stl"}
    assert "--support" in cmds["support"] and "--obstacle" in cmds["mesh"]
    for m in ("free", "rest"):
        assert "--support" not in cmds[m] and "--obstacle" not in cmds[m] and "--occluder" not in cmds[m]
    assert "rest" not in bench_scenes.DEFAULT_MODES
