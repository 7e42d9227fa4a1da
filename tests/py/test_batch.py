"""`pairgrasp batch` and pg.plan_batch: a set of targets (the bundled box and mug with their paint
files beside them, and a mesh that cannot be read) planned on worker processes and on Ray. Each
target's grasps.json must be what `plan` writes for it, the broken mesh is recorded with its error,
a second run skips what is done, and a worker process killed during a task is tried again.

The plans use a coarse unit facet and DOF step and few evaluations so that a batch takes seconds;
the batches spawn worker processes (or Ray's), which are not run against the sanitized extension.
"""
import csv
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import threading
import time

import pytest

import pairgrasp as pg
from pairgrasp import cli
from conftest import BARRETT, TARGETS

# A small plan: 15 mm unit facets, a 1 rad DOF step, 24 evaluations per chunk, one grasp fine-tuned.
TINY = dict(edge=0.015, step=1.0, top=2, fine_tune=1, fine_tune_iterations=3, max_evaluations=24, refine=2)
SANITIZED = os.environ.get("PAIRGRASP_SANITIZED")
no_pool = pytest.mark.skipif(bool(SANITIZED), reason="spawns worker processes of the extension, which the "
                             "sanitized run's preloaded ASan runtime is not made for")
BROKEN = "solid broken\nfacet normal 0 0 1\nendsolid\n"


needs_ray = pytest.mark.skipif(bool(SANITIZED) or importlib.util.find_spec("ray") is None,
                               reason="needs Ray (pip install .[ray]), not run against the sanitized extension")


@pytest.fixture()
def targets(tmp_path):
    """box and mug with their paint beside them, and a broken STL."""
    folder = tmp_path / "meshes"
    folder.mkdir()
    for name in ("box", "mug"):
        shutil.copy(TARGETS / f"{name}.stl", folder)
        shutil.copy(TARGETS / f"{name}.paint.json", folder)
    (folder / "broken.stl").write_text(BROKEN)
    return [str(folder / f"{n}.stl") for n in ("box", "mug", "broken")]


def _summary(out):
    with open(out / "summary.csv", newline="") as fh:
        reader = csv.DictReader(fh)
        return reader.fieldnames, {os.path.basename(r["target"]): r for r in reader}


def _plan_doc(target, **params):
    """What `plan` writes for the target (its paint beside it), planned here with the same parameters."""
    paint = target[: -len(".stl")] + ".paint.json"
    return pg.Planner(str(BARRETT), target, paint=paint, **params).plan(progress=False).to_dict()


def _check_batch(rows, out, targets):
    fields, summary = _summary(out)
    assert fields == ["target", "status", "error", "grasps", "force_closure", "best_epsilon", "seconds"]
    assert [r["target"] for r in rows] == targets
    assert [r["status"] for r in rows] == ["ok", "ok", "failed"]
    assert summary["broken.stl"]["status"] == "failed"
    assert targets[2] in summary["broken.stl"]["error"] and "mesh" in summary["broken.stl"]["error"]
    assert not (out / "broken").exists()
    for target, row in zip(targets[:2], rows):
        stem = os.path.basename(target)[:-4]
        doc = json.loads((out / stem / "grasps.json").read_text())
        want = _plan_doc(target, **TINY)
        assert doc["grasps"] == want["grasps"], stem
        for key in ("format", "inputs", "parameters", "counts"):
            assert doc[key] == want[key], (stem, key)
        grasps = doc["grasps"]
        assert int(summary[os.path.basename(target)]["grasps"]) == row["grasps"] == len(grasps)
        assert row["force_closure"] == sum(g["force_closure"] for g in grasps) > 0
        assert row["best_epsilon"] == pytest.approx(max(g["epsilon"] for g in grasps), rel=1e-6)
    assert sorted(os.listdir(out)) == ["box", "mug", "summary.csv"]  # nothing half-written left


def _second_run(out, targets, **kw):
    before = {s: os.stat(out / s / "grasps.json").st_mtime_ns for s in ("box", "mug")}
    rows = pg.plan_batch(str(BARRETT), targets, out, progress=False, **kw, **TINY)
    assert [r["status"] for r in rows] == ["skipped", "skipped", "failed"]
    assert {s: os.stat(out / s / "grasps.json").st_mtime_ns for s in ("box", "mug")} == before
    assert rows[0]["grasps"] == len(pg.load_grasps(out / "box" / "grasps.json").grasps)
    assert [r["status"] for r in _summary(out)[1].values()] == ["skipped", "skipped", "failed"]


@pytest.mark.slow
@no_pool
def test_local_batch_plans_as_plan_does_records_the_broken_mesh_and_resumes(tmp_path, targets):
    out = tmp_path / "out"
    rows = pg.plan_batch(str(BARRETT), targets, out, workers=2, progress=False, **TINY)
    _check_batch(rows, out, targets)
    _second_run(out, targets, workers=2)


@pytest.mark.slow
@needs_ray
def test_ray_batch_plans_as_plan_does_records_the_broken_mesh_and_resumes(tmp_path, targets):
    out = tmp_path / "out"
    rows = pg.plan_batch(str(BARRETT), targets, out, engine="ray", workers=2, progress=False, **TINY)
    _check_batch(rows, out, targets)
    _second_run(out, targets, engine="ray", workers=2)


@pytest.mark.slow
@no_pool
def test_cli_batch_writes_what_plan_writes(tmp_path, targets):
    opts = ["--edge", "0.015", "--step", "1.0", "--top", "2"]
    box = targets[0]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    run = [sys.executable, "-m", "pairgrasp.cli"]
    plan = subprocess.run(run + ["plan", "--hand", str(BARRETT), "--target", box, "--paint", box[:-4] + ".paint.json",
                                 "--pictures", "1", "--quiet", "-o", str(tmp_path / "plan")] + opts,
                          capture_output=True, text=True, env=env)
    assert plan.returncode == 0, plan.stderr
    batch = subprocess.run(run + ["batch", "--hand", str(BARRETT), "--targets", box, targets[2], "--pictures", "1",
                                  "--quiet", "-o", str(tmp_path / "batch")] + opts, capture_output=True, text=True,
                           env=env)
    assert batch.returncode == 1, batch.stderr
    err = batch.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pairgrasp: error: ") and targets[2] in err[0]
    assert "2 targets: 1 planned, 1 failed, 0 skipped" in batch.stdout
    a = json.loads((tmp_path / "plan" / "grasps.json").read_text())
    b = json.loads((tmp_path / "batch" / "box" / "grasps.json").read_text())
    a.pop("timings"), b.pop("timings")
    assert a == b
    assert sorted(os.listdir(tmp_path / "batch" / "box")) == ["grasp_01.png", "grasps.json"]


def _descendants(marker):
    """This process's descendants whose command line contains ``marker`` (read from /proc)."""
    parent, cmdline = {}, {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/cmdline", "rb") as fh:
                cmdline[int(entry)] = fh.read()
            with open(f"/proc/{entry}/stat") as fh:
                parent[int(entry)] = int(fh.read().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue

    def below(pid):
        while pid in parent and pid > 1:
            pid = parent[pid]
            if pid == os.getpid():
                return True
        return False

    return [pid for pid, cmd in cmdline.items() if marker in cmd and pid in parent and below(pid)]


def _kill_first_task(find, tmpdir, timeout=120.0):
    """Waits until a task has unpacked its files (a pairgrasp-task-* folder in ``tmpdir``) and
    kills the process ``find()`` names with SIGKILL; returns its pid."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        pids = find()
        if pids and any(n.startswith("pairgrasp-task-") for n in os.listdir(tmpdir)):
            os.kill(pids[0], 9)
            return pids[0]
        time.sleep(0.02)
    raise AssertionError("no task started")


def _batch_in_thread(**kw):
    box = []
    thread = threading.Thread(target=lambda: box.append(pg.plan_batch(str(BARRETT), progress=False, **kw, **TINY)))
    thread.start()
    return thread, box


@pytest.mark.slow
@no_pool
def test_a_killed_local_worker_is_retried(tmp_path, targets, monkeypatch):
    tmpdir = tmp_path / "tmp"  # the workers' temporary folders: where a task shows it has started
    tmpdir.mkdir()
    monkeypatch.setenv("TMPDIR", str(tmpdir))
    out = tmp_path / "out"
    workers = lambda: _descendants(b"spawn_main")  # noqa: E731
    # Without retries the target is recorded as failed, by the signal that killed its worker.
    thread, rows = _batch_in_thread(targets=targets[:1], out=out, workers=1, retries=0)
    _kill_first_task(workers, tmpdir)
    thread.join(300)
    assert rows[0][0]["status"] == "failed"
    assert "killed by signal 9" in rows[0][0]["error"] and "tried 1 time" in rows[0][0]["error"]
    assert not (out / "box").exists()
    # With one retry the killed task runs again on a new worker and the batch completes; the killed
    # task's folder is left behind (no clean-up after SIGKILL), the retried one's is removed.
    shutil.rmtree(tmpdir)
    tmpdir.mkdir()
    thread, rows = _batch_in_thread(targets=targets[:2], out=out, workers=1, retries=1)
    _kill_first_task(workers, tmpdir)
    thread.join(300)
    assert [r["status"] for r in rows[0]] == ["ok", "ok"]
    assert len([n for n in os.listdir(tmpdir) if n.startswith("pairgrasp-task-")]) == 1
    doc = json.loads((out / "box" / "grasps.json").read_text())
    assert doc["grasps"] == _plan_doc(targets[0], **TINY)["grasps"]


@pytest.mark.slow
@needs_ray
def test_a_killed_ray_worker_is_retried(tmp_path, targets):
    out = tmp_path / "out"
    tasks = lambda: _descendants(b"ray::_run_task")  # noqa: E731
    thread, rows = _batch_in_thread(targets=targets[:1], out=out, engine="ray", workers=1, retries=1)
    end = time.monotonic() + 180
    while not tasks() and time.monotonic() < end:
        time.sleep(0.02)
    killed = tasks()
    assert killed, "no Ray task started"
    os.kill(killed[0], 9)
    thread.join(300)
    assert [r["status"] for r in rows[0]] == ["ok"]
    assert json.loads((out / "box" / "grasps.json").read_text())["grasps"] == _plan_doc(targets[0], **TINY)["grasps"]


@pytest.mark.parametrize("kw, needle", [
    (dict(engine="spark"), "engine"),
    (dict(address="auto"), "address"),
    (dict(workers=0), "workers"),
    (dict(retries=-1), "retries"),
    (dict(scale=0.0), "scale"),
    (dict(top=0), "top"),
    (dict(stride=3), "unknown planner parameter 'stride'"),
])
def test_bad_arguments_raise_before_anything_is_written(tmp_path, targets, kw, needle):
    with pytest.raises(ValueError, match=needle):
        pg.plan_batch(str(BARRETT), targets, tmp_path / "out", **kw)
    assert not (tmp_path / "out").exists()


def test_bad_inputs_are_refused(tmp_path, targets):
    other = tmp_path / "other"
    other.mkdir()
    shutil.copy(targets[0], other)
    with pytest.raises(ValueError, match="both be written to box/"):
        pg.plan_batch(str(BARRETT), [targets[0], str(other / "box.stl")], tmp_path / "out")
    with pytest.raises(ValueError, match="hand: no such file"):
        pg.plan_batch(str(tmp_path / "nohand.json"), targets, tmp_path / "out")
    with pytest.raises(ValueError, match="non-empty list"):
        pg.plan_batch(str(BARRETT), [], tmp_path / "out")
    (tmp_path / "file").write_text("")
    with pytest.raises(ValueError, match="not a directory"):
        pg.plan_batch(str(BARRETT), targets, tmp_path / "file")
    assert not (tmp_path / "out").exists()


def test_cli_batch_errors_are_one_line(tmp_path, targets, capsys):
    assert cli.main(["batch", "--hand", str(BARRETT), "--targets", targets[0], targets[0], "-o",
                     str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pairgrasp: error: targets:")
    assert cli.main(["batch", "--hand", str(BARRETT), "--targets", targets[0], "--address", "auto", "-o",
                     str(tmp_path / "out")]) == 1
    assert "--address: only with --engine ray" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        cli.main(["batch", "--hand", str(BARRETT), "--targets", targets[0], "--engine", "spark", "-o", "x"])
    assert e.value.code == 2


@no_pool
def test_done_targets_are_skipped_and_half_written_folders_removed(tmp_path, targets):
    """A folder from an earlier run is read, not planned again; what an interrupted run left
    half-written (a .<stem>.part-* folder) is removed; a missing mesh is recorded, not raised."""
    out = tmp_path / "out"
    (out / "box").mkdir(parents=True)
    doc = {"format": pg.GRASPS_FORMAT, "grasps": []}
    pg.write_grasps(out / "box" / "grasps.json", doc)
    (out / ".broken.part-123").mkdir()
    (out / ".mug.part-123").mkdir()  # not a target of this batch: left alone
    missing = str(tmp_path / "meshes" / "gone.stl")
    rows = pg.plan_batch(str(BARRETT), [targets[0], targets[2], missing], out, workers=1, progress=False, **TINY)
    assert [r["status"] for r in rows] == ["skipped", "failed", "failed"]
    assert rows[0]["grasps"] == len(doc["grasps"]) and rows[0]["seconds"] is None
    assert "no such file" in rows[2]["error"] and missing in rows[2]["error"]
    assert rows[1]["seconds"] is not None and targets[2] in rows[1]["error"]
    assert sorted(os.listdir(out)) == [".mug.part-123", "box", "summary.csv"]
    assert [r["status"] for r in _summary(out)[1].values()] == ["skipped", "failed", "failed"]


@no_pool
def test_batch_on_a_table_plans_as_the_planner_does(tmp_path, targets):
    """`support=True` stands every target on its table in the batch as in Planner: the same grasps,
    the support recorded."""
    out = tmp_path / "out"
    rows = pg.plan_batch(str(BARRETT), targets[:1], out, workers=1, progress=False, support=True, **TINY)
    assert [r["status"] for r in rows] == ["ok"]
    doc = json.loads((out / "box" / "grasps.json").read_text())
    want = pg.Planner(str(BARRETT), targets[0], paint=targets[0][:-4] + ".paint.json", support=True,
                      **TINY).plan(progress=False).to_dict()
    assert doc["inputs"]["support"] == want["inputs"]["support"]
    assert doc["inputs"]["support"]["normal"] == [0.0, 0.0, 1.0]
    assert doc["grasps"] == want["grasps"]
