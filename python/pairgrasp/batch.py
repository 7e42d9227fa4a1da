"""Planning over a set of targets: ``pairgrasp batch`` and :func:`plan_batch`.

Each target is planned by a task that runs the ``plan`` command's code (``workflow.planner_from_files``
and ``workflow.write_plan``) on copies of the files it is handed: the hand's folder, the target, the
target's ``<stem>.paint.json`` when one lies beside it, and the obstacles. A task returns the files
``plan`` would write; the driver stores them in ``OUTDIR/<stem>/`` through a temporary folder and a
rename, so a target's folder appears only when complete, and a folder already there means the target
is done (``skipped``). A task that raises is recorded as ``failed`` with its one-line error; a task
whose worker process dies is tried again, ``retries`` times at most.

Engines: ``local`` runs the tasks in worker processes of this machine (the spawn start method: the
library's thread pool does not survive a fork), one task per process at a time, so a dead process
is known to be the one running its task; ``ray`` submits them as Ray tasks (``max_retries``), which
carry the file contents, so the nodes need no shared file system, only pairgrasp installed.
"""
from __future__ import annotations

import collections
import csv
import io
import math
import multiprocessing
import multiprocessing.connection
import os
import shutil
import signal
import tempfile
import time
import warnings
from typing import Dict, Iterator, List, Optional, Sequence, Tuple

from .params import PlanParams, with_overrides

__all__ = ["SUMMARY_COLUMNS", "plan_batch"]

SUMMARY_COLUMNS = ("target", "status", "error", "grasps", "force_closure", "best_epsilon", "seconds")
# The hand's folder is shipped to every task; a spec lying in a large folder is refused.
_HAND_FOLDER_LIMIT = 64 << 20
def _support_value(support):
    """``support`` as a task carries it: None, "auto", a height, or ((x, y, z), (nx, ny, nz))."""
    if support is None or support is False:
        return None
    if support is True or support == "auto":
        return "auto"
    if isinstance(support, (int, float)) and not isinstance(support, bool):
        if not math.isfinite(support):
            raise ValueError(f"support: expected a finite height (m), got {support!r}")
        return float(support)
    try:
        point, normal = support
        point, normal = tuple(float(x) for x in point), tuple(float(x) for x in normal)
    except (TypeError, ValueError):
        raise ValueError(f"support: expected True, 'auto', a height (m) or (point, normal), got {support!r}") from None
    if len(point) != 3 or len(normal) != 3 or not all(map(math.isfinite, point + normal)) or not any(normal):
        raise ValueError(f"support: expected a finite point and a non-zero normal, got {support!r}")
    return (point, normal)


def plan_batch(hand, targets: Sequence, out, engine: str = "local", *, address: Optional[str] = None,
               workers: Optional[int] = None, retries: int = 2, pictures: int = 0, viewpoints=None,
               obstacles: Sequence = (), scale: float = 1.0, support=None, occluder_distance: float = 0.005,
               progress: Optional[bool] = None, **plan_options) -> List[dict]:
    """Plans ``hand`` on every target mesh and writes ``out/<stem>/grasps.json`` (what ``pairgrasp
    plan`` writes, with ``pictures`` pictures) and ``out/summary.csv``.

    Args:
        hand: path of the hand spec; its folder (spec, URDF, meshes) is shipped to every task.
        targets: mesh paths (their file stems name the output folders, so they must differ). A
            ``<stem>.paint.json`` beside a mesh is its paint.
        out: output folder (created). Targets whose folder is already there are ``skipped``.
        engine: ``"local"`` (worker processes here) or ``"ray"`` (Ray tasks; ``pip install .[ray]``).
        address: ``engine="ray"``: the cluster to join (``ray.init(address=...)``); None starts a
            local Ray instance.
        workers: targets planned at once (default: every core, or the cluster's CPUs per task).
        retries: times a task whose worker process died is tried again.
        viewpoints, obstacles, scale, occluder_distance: as ``pairgrasp plan``'s, for every target.
        support: as :class:`pairgrasp.Planner`'s (``"auto"``: each target rests on the horizontal plane
            through its lowest point; a height (m); or (point, normal)), for every target.
        progress: a progress bar over the targets on stderr (None: when stderr is a terminal).
        plan_options: PlanParams fields (``schedule``, ``step``, ``top``, ...). ``threads`` is per
            task; by default the cores are shared out among the local workers, 1 on Ray.

    Returns:
        One dict per target, in the order given, with the keys of :data:`SUMMARY_COLUMNS`:
        ``status`` ``"ok"``, ``"failed"`` or ``"skipped"``, ``error`` (one line, "" when none), the
        number of ``grasps`` and of ``force_closure`` grasps, ``best_epsilon`` (the largest of the
        returned grasps'; rank 1 need not have it), ``seconds`` (the task's; None when skipped).

    Raises:
        ValueError: bad arguments (nothing planned); a failing target does not raise.
        ImportError: ``engine="ray"`` without Ray.
    """
    from .planner import Progress

    if engine not in ("local", "ray"):
        raise ValueError(f"engine: expected 'local' or 'ray', got {engine!r}")
    if address is not None and engine != "ray":
        raise ValueError("address: only with engine 'ray'")
    for name, value, low in (("workers", workers, 1), ("retries", retries, 0), ("pictures", pictures, 0)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < low):
            raise ValueError(f"{name}: expected an integer >= {low}, got {value!r}")
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not math.isfinite(scale) or scale <= 0:
        raise ValueError(f"scale: expected a finite number > 0, got {scale!r}")
    if not isinstance(hand, (str, os.PathLike)):
        raise ValueError(f"hand: expected the path of a hand spec, got {type(hand).__name__}")
    if isinstance(targets, (str, os.PathLike)) or not targets:
        raise ValueError("targets: expected a non-empty list of mesh paths")
    targets = [os.fspath(t) for t in targets]
    stems: Dict[str, str] = {}
    for t in targets:
        stem = os.path.splitext(os.path.basename(t))[0]
        if not stem or stem.startswith("."):
            raise ValueError(f"targets: {t}: no file name to name its output folder")
        if stem in stems:
            raise ValueError(f"targets: {stems[stem]} and {t} would both be written to {stem}/ (rename one)")
        stems[stem] = t
    out = os.fspath(out)
    if os.path.exists(out) and not os.path.isdir(out):
        raise ValueError(f"out: {out} exists and is not a directory")
    params = with_overrides(PlanParams, None, plan_options, "planner")  # every option checked before any work
    cores = os.cpu_count() or 1
    if engine == "local":
        workers = min(workers or cores, len(targets))
    threads = params.threads or (max(1, cores // workers) if engine == "local" else 1)
    options = {**plan_options, "threads": threads}
    shared = {"hand": _pack_hand(os.fspath(hand)),
              "obstacles": [_pack_file(os.fspath(o), "obstacles") for o in obstacles],
              "viewpoints": None if viewpoints is None else [[float(x) for x in v] for v in viewpoints],
              "scale": float(scale), "pictures": int(pictures), "options": options,
              "support": _support_value(support), "occluder_distance": float(occluder_distance)}

    os.makedirs(out, exist_ok=True)
    rows: Dict[str, dict] = {}
    tasks = []
    for name in os.listdir(out):  # what an interrupted run left half-written
        if name.startswith(".") and name.partition(".part-")[0][1:] in stems:
            shutil.rmtree(os.path.join(out, name), ignore_errors=True)
    for stem, target in stems.items():
        if os.path.isdir(os.path.join(out, stem)):
            rows[stem] = _done_row(target, os.path.join(out, stem, "grasps.json"))
            continue
        try:
            tasks.append(_task(stem, target))
        except (OSError, ValueError) as e:
            rows[stem] = _row(target, "failed", error=_one_line(e))
    bar = Progress(progress)
    bar.start("batch", len(targets))
    bar.advance(len(rows))
    summary = os.path.join(out, "summary.csv")
    _write_summary(summary, targets, stems, rows)
    run = _run_local(shared, tasks, workers, retries) if engine == "local" else \
        _run_ray(shared, tasks, workers, retries, address, threads)
    try:
        for task, res in run:
            stem = task["stem"]
            for w in res.pop("warnings", []):
                warnings.warn(f"{task['target']}: {w}")
            files = res.pop("files", None)
            if res["status"] == "ok":
                try:
                    _store(out, stem, files)
                except OSError as e:
                    res.update(status="failed", error=_one_line(e))
            rows[stem] = res
            _write_summary(summary, targets, stems, rows)
            bar.advance()
    finally:
        run.close()
        bar.finish()
    return [rows[stem] for stem in stems]


# ============================================================================ the driver's side

def _row(target, status, error="", grasps=None, force_closure=None, best_epsilon=None, seconds=None) -> dict:
    return dict(target=target, status=status, error=error, grasps=grasps, force_closure=force_closure,
                best_epsilon=best_epsilon, seconds=seconds)


def _one_line(e) -> str:
    msg = " ".join(str(e).split())
    return msg if isinstance(e, (ValueError, RuntimeError, OSError)) else f"{type(e).__name__}: {msg}"


def _done_row(target: str, path: str) -> dict:
    """The summary row of a target planned before (its folder exists): read from its grasps.json."""
    from .grasps_file import load_grasps

    try:
        grasps = load_grasps(path).grasps
    except RuntimeError as e:
        return _row(target, "failed", error=f"{_one_line(e)} (remove the folder to plan the target again)")
    return _row(target, "skipped", **_counts(grasps))


def _counts(grasps) -> dict:
    return dict(grasps=len(grasps), force_closure=sum(bool(g.force_closure) for g in grasps),
                best_epsilon=max(float(g.epsilon) for g in grasps) if grasps else None)


def _pack_file(path: str, what: str) -> Tuple[str, bytes]:
    if not os.path.isfile(path):
        raise ValueError(f"{what}: {'not a file' if os.path.exists(path) else 'no such file'}: {path}")
    with open(path, "rb") as fh:
        return path, fh.read()


def _pack_hand(spec: str) -> dict:
    """The hand spec's folder (every file under it but hidden ones), which holds the URDF and meshes
    the spec names (``package_paths`` such as ".." resolve against the folder's own name, kept)."""
    _pack_file(spec, "hand")
    folder = os.path.dirname(os.path.abspath(spec))
    files, size = {}, 0
    for root, dirs, names in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if not d.startswith(".") and d != "__pycache__")
        for name in sorted(names):
            if name.startswith("."):
                continue
            path = os.path.join(root, name)
            size += os.path.getsize(path)
            if size > _HAND_FOLDER_LIMIT:
                raise ValueError(f"hand: the folder {folder} holds more than {_HAND_FOLDER_LIMIT >> 20} MB; keep "
                                 f"the spec, its URDF and meshes in a folder of their own (it is sent to every task)")
            with open(path, "rb") as fh:
                files[os.path.relpath(path, folder)] = fh.read()
    return {"spec": spec, "folder": os.path.basename(folder) or "hand",
            "relpath": os.path.relpath(os.path.abspath(spec), folder), "files": files}


def _task(stem: str, target: str) -> dict:
    paint = os.path.join(os.path.dirname(target), f"{stem}.paint.json")
    return {"stem": stem, "target": target, "files": {"target": _pack_file(target, "target"),
                                                      "paint": _pack_file(paint, "paint") if os.path.isfile(paint) else None}}


def _store(out: str, stem: str, files: Dict[str, bytes]):
    """Writes a target's files into ``out/<stem>`` through a temporary folder renamed at the end."""
    tmp = os.path.join(out, f".{stem}.part-{os.getpid()}")
    shutil.rmtree(tmp, ignore_errors=True)
    os.mkdir(tmp)  # with the umask's permissions, as `plan`'s folder
    try:
        for name, data in files.items():
            with open(os.path.join(tmp, os.path.basename(name)), "wb") as fh:
                fh.write(data)
        os.rename(tmp, os.path.join(out, stem))
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _write_summary(path: str, targets: List[str], stems: Dict[str, str], rows: Dict[str, dict]):
    """summary.csv with the rows known so far, in the targets' order (replaced atomically)."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=SUMMARY_COLUMNS, lineterminator="\n")
    w.writeheader()
    for stem in stems:
        if stem in rows:
            r = rows[stem]
            w.writerow({k: "" if r[k] is None else (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k])
                        for k in SUMMARY_COLUMNS})
    with open(f"{path}.part", "w", encoding="utf-8", newline="") as fh:
        fh.write(buf.getvalue())
    os.replace(f"{path}.part", path)


# ============================================================================ a task (in a worker)

def _unpack(item: Tuple[str, bytes], folder: str, names: Dict[str, str]) -> str:
    """Writes a shipped file under ``folder`` by its base name; ``names`` maps the copy to the original."""
    original, data = item
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, os.path.basename(original))
    with open(path, "wb") as fh:
        fh.write(data)
    names[path] = original
    return path


def _run_task(shared: dict, task: dict) -> dict:
    """Plans one target on copies of its files, as ``pairgrasp plan`` would; returns its summary row
    with ``files`` (name -> contents of what ``plan`` writes) and ``warnings``. Never raises."""
    from .workflow import planner_from_files, write_plan

    t0 = time.perf_counter()
    res = _row(task["target"], "failed")
    with tempfile.TemporaryDirectory(prefix="pairgrasp-task-") as tmp, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        names: Dict[str, str] = {}
        try:
            hand = shared["hand"]
            root = os.path.join(tmp, "hand", hand["folder"])
            for rel, data in hand["files"].items():
                os.makedirs(os.path.dirname(os.path.join(root, rel)), exist_ok=True)
                with open(os.path.join(root, rel), "wb") as fh:
                    fh.write(data)
            spec = os.path.join(root, hand["relpath"])
            names[spec] = hand["spec"]
            files = task["files"]
            options = dict(shared["options"])
            planner = planner_from_files(
                spec, _unpack(files["target"], os.path.join(tmp, "target"), names),
                paint=_unpack(files["paint"], os.path.join(tmp, "paint"), names) if files["paint"] else None,
                viewpoints=shared["viewpoints"], scale=shared["scale"], support=shared["support"],
                occluder_distance=shared["occluder_distance"],
                obstacles=[_unpack(o, os.path.join(tmp, f"obstacle{k}"), names)
                           for k, o in enumerate(shared["obstacles"])],
                names=names, **options)
            result = planner.plan(progress=False)
            folder = os.path.join(tmp, "out")
            os.makedirs(folder)
            write_plan(planner, result, folder, shared["pictures"], os.path.basename(task["target"]))
            res["files"] = {}
            for name in sorted(os.listdir(folder)):
                with open(os.path.join(folder, name), "rb") as fh:
                    res["files"][name] = fh.read()
            res.update(status="ok", **_counts(result.grasps))
        except Exception as e:  # noqa: BLE001 - a target's fault is recorded, and the batch goes on
            msg = _one_line(e)
            for copy, original in sorted(names.items(), key=lambda kv: -len(kv[0])):
                msg = msg.replace(copy, original)
            res["error"] = msg.replace(tmp + os.sep, "")
        res["warnings"] = [" ".join(str(w.message).split()) for w in caught]
    res["seconds"] = round(time.perf_counter() - t0, 3)
    return res


# ============================================================================ engines

def _died(task: dict, reason: str, tries: int) -> dict:
    return _row(task["target"], "failed", error=f"{reason} (tried {tries} time{'s' * (tries > 1)})")


def _worker_loop(conn):
    """A local worker process: runs the tasks it receives one at a time until told to stop."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the driver's to handle
    while True:
        try:
            job = conn.recv()
        except EOFError:
            return
        if job is None:
            return
        conn.send(_run_task(*job))


def _run_local(shared: dict, tasks: List[dict], workers: int, retries: int) -> Iterator[Tuple[dict, dict]]:
    """Runs the tasks on ``workers`` spawned processes, one task per process at a time; yields
    (task, result) as they finish. A task whose process dies is queued again (``retries`` times)."""
    ctx = multiprocessing.get_context("spawn")
    queue = collections.deque(tasks)
    tries: Dict[str, int] = collections.Counter()
    idle: list = []
    busy: Dict[object, dict] = {}  # (process, connection) -> task

    def start():
        conn, child = ctx.Pipe()
        proc = ctx.Process(target=_worker_loop, args=(child,), daemon=True, name="pairgrasp-batch")
        proc.start()
        child.close()
        return proc, conn

    try:
        while queue or busy:
            while queue and len(busy) < workers:
                w = idle.pop() if idle else start()
                task = queue.popleft()
                tries[task["stem"]] += 1
                w[1].send((shared, task))
                busy[w] = task
            ready = set(multiprocessing.connection.wait([x for w in busy for x in (w[1], w[0].sentinel)]))
            for w in [w for w in busy if w[1] in ready or w[0].sentinel in ready]:
                proc, conn = w
                try:
                    res = conn.recv() if conn.poll() else None
                except (EOFError, OSError):
                    res = None
                task = busy.pop(w)
                if res is not None:
                    idle.append(w)
                    yield task, res
                    continue
                proc.join()
                conn.close()
                code = proc.exitcode
                reason = (f"the worker process was killed by signal {-code}" if code is not None and code < 0
                          else f"the worker process exited with status {code}")
                if tries[task["stem"]] <= retries:
                    queue.appendleft(task)
                else:
                    yield task, _died(task, reason, tries[task["stem"]])
    finally:
        for proc, conn in idle:
            try:
                conn.send(None)
            except OSError:
                pass
        for proc, conn in busy:
            proc.terminate()
        for proc, conn in idle + list(busy):
            proc.join(5)
            if proc.is_alive():
                proc.kill()
                proc.join()
            conn.close()


def _import_ray():
    try:
        import ray
    except ImportError:
        raise ImportError("engine 'ray' needs Ray: pip install 'pairgrasp[ray]' (or pip install ray)") from None
    return ray


def _run_ray(shared: dict, tasks: List[dict], workers: Optional[int], retries: int, address: Optional[str],
             threads: int) -> Iterator[Tuple[dict, dict]]:
    """Runs the tasks as Ray tasks of ``threads`` CPUs each, at most ``workers`` at once (default:
    the cluster's CPUs over ``threads``); yields (task, result) as they finish. Ray retries a task
    whose worker died ``retries`` times."""
    ray = _import_ray()
    started = not ray.is_initialized()
    if started:
        kw = dict(include_dashboard=False, logging_level="ERROR", log_to_driver=False)
        if address:
            ray.init(address=address, **kw)
        else:
            ray.init(num_cpus=max(workers or 0, threads, os.cpu_count() or 1), **kw)
    try:
        remote = ray.remote(num_cpus=threads, max_retries=retries)(_run_task)
        limit = workers or max(1, int(ray.cluster_resources().get("CPU", 1)) // threads)
        ref = ray.put(shared)
        queue, pending = collections.deque(tasks), {}
        while queue or pending:
            while queue and len(pending) < limit:
                task = queue.popleft()
                pending[remote.remote(ref, task)] = task
            done, _ = ray.wait(list(pending), num_returns=1)
            for r in done:
                task = pending.pop(r)
                try:
                    res = ray.get(r)
                except ray.exceptions.RayError as e:
                    first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
                    res = _died(task, f"{type(e).__name__}: {first}", retries + 1)
                yield task, res
    finally:
        if started:
            ray.shutdown()
