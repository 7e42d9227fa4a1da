"""Physics check benchmark: which grasps hold, ranked how, against grasps sampled at random?

    python bench/bench_sim.py --jobs 2 --json sim.json     # bundled targets and 4 pybullet_data meshes
    python bench/bench_sim.py --targets flask --random 2 --trials 2    # a quick look

For each target the Barrett hand is planned with the `fast` schedule once per ranking: by
robustness (`rank="robust"`), by epsilon (`rank="epsilon"`, the paper's), by enclosure
(`rank="enclosure"`: the epsilon ranking's grasps led by the most enclosing) and by load
(`rank="load"`, the default: led by the one that resists gravity best along its worst axis), and the top 5 of each are simulated
(pairgrasp.Simulator: close, lift, turn gravity, shake); `--methods grid` adds the `grid` schedule
(at `--grid-step`). Targets are the bundled ones (with their paint) and meshes
shipped in the pybullet wheel (pybullet_data, none made for pairgrasp; scaled to 0.1 m along their
longest side, every face free). The baseline are grasps sampled at random around the target as
GraspIt's random-approach planners do: a uniformly random approach direction towards the centre of
mass, a random roll and spread, the wrist brought in along the approach until the open hand first
touches the target, and the fingers closed onto contact (GraspChecker.close); then the same
simulation. `random-fc` keeps only the random grasps whose closed contacts are force-closure.

Every grasp is simulated `--trials` times with pairgrasp.trial_perturbations(trials, seed): trial 0
as planned, the others with execution and model errors (wrist offset N(0, 1 mm) per axis, wrist
rotation N(0, 1 degree) about a random axis, friction U(0.4, 0.6), density U(500, 1500) kg/m^3).
Trial k's errors depend only on the seed and k, so a grasp that both rankings return is simulated
once and both are judged on the same errors. `verified` is `plan --verify-top 5`: the robust top 5
simulated on trials of another seed and re-ranked by how often they held, then judged on the
trials of the others. The table gives the held rate of the rank-1 grasp (top-1) and of the top 5
with 95% Wilson intervals; a second table, over the planned grasps, how the robust ranking's
measures and simple geometric ones relate to holding.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time

import numpy as np

import pairgrasp as pg

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))   # bench_peers, also in spawned workers
HAND = os.path.join(ROOT, "models", "barrett", "barrett.json")


def _rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def _unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def random_grasp(hand, checker, mesh, rng, resolution=5e-4):
    """A random-approach grasp: wrist pose and closed DOFs (see the module documentation)."""
    centre, radius = pg.torque_reference(mesh)
    u = _unit(rng)                                        # from the centre towards the palm
    a = np.asarray(hand.approach, float)
    axis = np.cross(a, -u)
    ang = math.acos(max(-1.0, min(1.0, float(a @ -u))))
    R = _rotation(axis, ang) if np.linalg.norm(axis) > 1e-9 else (np.eye(3) if ang < 1 else -np.eye(3))
    R = _rotation(u, rng.uniform(0, 2 * math.pi)) @ R     # random roll about the approach line
    lo, hi = np.asarray(hand.dof_lower, float), np.asarray(hand.dof_upper, float)
    q = rng.uniform(lo, hi)
    dirs = np.asarray(pg.closing_directions(hand, q), float).reshape(-1)
    q = np.where(dirs > 0, lo, np.where(dirs < 0, hi, q))   # closing DOFs open, the others random

    reach = max(np.linalg.norm(np.asarray(T)[:3, 3]) for T in hand.link_transforms(q).values()) + 0.1

    def pose(s):
        T = np.eye(4)
        T[:3, :3] = R
        T[:3, 3] = centre + s * u
        return T

    far = radius + reach
    s, step = far, 0.005
    while s > 0 and not checker.check(pose(s - step), q).pruned:
        s -= step
    lo_s, hi_s = s - step, s                              # pruned at lo_s, clear at hi_s
    while hi_s - lo_s > resolution:
        mid = (lo_s + hi_s) / 2
        if checker.check(pose(mid), q).pruned:
            lo_s = mid
        else:
            hi_s = mid
    T = pose(hi_s)
    closed = checker.close(T, q)
    return T, np.asarray(closed.dofs, float)


def simulate(sim, cache, grasps, perturbations, label):
    """Simulates each (pose, dofs, epsilon, extra) under every perturbation; a grasp simulated
    before (same pose and DOFs, same target) comes from `cache`. Returns per-trial dicts."""
    out = []
    for k_grasp, (T, q, eps, extra) in enumerate(grasps):
        key = (label, np.round(np.asarray(T), 12).tobytes(), np.round(np.asarray(q), 12).tobytes())
        if key not in cache:
            cache[key] = pg.simulate_trials(sim, T, q, perturbations)
        for t, r in zip(perturbations, cache[key]):
            out.append({"grasp": k_grasp, "trial": t.index, "epsilon": eps, "success": r.success,
                        "outcome": r.outcome, "slip_translation": r.slip_translation,
                        "slip_rotation": r.slip_rotation, "time_simulated": r.time_simulated,
                        "wall_time": r.wall_time, "result": r, **extra})
    return out


def wilson(k, n, z=1.96):
    if n == 0:
        return float("nan"), float("nan")
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return c - h, c + h


PLANNED = {"robust": ("fast", "robust"), "epsilon": ("fast", "epsilon"), "enclosure": ("fast", "enclosure"),
           "load": ("fast", "load"),
           "grid": ("grid", "robust")}
METHODS = ("robust", "epsilon", "enclosure", "load", "verified", "grid", "random", "random-fc")


def _label(method):
    return {"robust": "planner, robust ranking", "epsilon": "planner, epsilon ranking",
            "enclosure": "planner, enclosure ranking", "load": "planner, load ranking",
            "verified": "planner, robust top 5 verified", "grid": "planner, grid, robust ranking",
            "random": "random approach",
            "random-fc": "random approach, force-closure only"}[method]


def load(name):
    """(label, mesh, paint path or None) of a bundled target name or a pybullet_data mesh path."""
    from bench_peers import BUNDLED, load_target

    label, mesh = load_target(name)
    paint = os.path.join(ROOT, "models", "targets", f"{name}.paint.json") if name in BUNDLED else None
    return label, mesh, paint if paint and os.path.exists(paint) else None


def features(g, centre, radius) -> dict:
    """What may predict holding, per planned grasp: the robust ranking's measures, the contact
    centroid's distance from the centre of mass (in target radii), the links in contact, and along
    how many of the target-frame axes (the simulated gravity directions) contacts lie on both sides
    of the centre of mass."""
    P = np.asarray(g.contact_points, float).reshape(-1, 3)
    d = P - np.asarray(centre, float)
    straddle = int(sum((d[:, a] > 0.002).any() and (d[:, a] < -0.002).any() for a in range(3))) if len(P) else 0
    return {"p_fc": g.force_closure_probability, "robust_epsilon": g.robust_epsilon,
            "com_offset": float(np.linalg.norm(d.mean(axis=0)) / radius) if len(P) else float("nan"),
            "links": len(set(g.contact_links)), "straddle": straddle}


def run(target, args):
    label, mesh, paint = load(target)
    rng = np.random.default_rng([args.seed, sum(map(ord, target))])
    planner = pg.Planner(HAND, mesh, paint=None if args.no_paint else paint, seed=args.seed, top=args.top)
    t0 = time.perf_counter()
    sim = pg.Simulator(planner.hand, mesh)
    setup = time.perf_counter() - t0
    perturbations = pg.trial_perturbations(args.trials, args.seed)
    centre, radius = pg.torque_reference(mesh)
    cache, rows, plans = {}, {}, {}
    for method in (m for m in args.methods if m in PLANNED or m == "verified"):
        if method == "verified":   # plan --verify-top: re-ranked on other trials than those that judge it
            t0 = time.perf_counter()
            res = plans.get("robust") or planner.plan(rank="robust", progress=False)
            top = res.grasps[: args.top]
            check = pg.trial_perturbations(args.trials, args.seed + 1000)
            rates = [sum(r.success for r in pg.simulate_trials(sim, g.wrist_pose, g.dofs, check)) for g in top]
            top = [top[i] for i in sorted(range(len(top)), key=lambda i: -rates[i])]
            grasps = [(g.wrist_pose, g.dofs, g.epsilon, features(g, centre, radius)) for g in top]
            rows[method] = {"plan_s": time.perf_counter() - t0, "trials": simulate(sim, cache, grasps, perturbations, label),
                            "grasps": len(grasps)}
            print(f"  {label} {method}: {_rate(rows[method]['trials'])}", file=sys.stderr, flush=True)
            continue
        schedule, rank = PLANNED[method]
        t0 = time.perf_counter()
        res = planner.plan(schedule=schedule, step=args.grid_step if schedule == "grid" else None, rank=rank,
                           progress=False)
        plans[method] = res
        plan_s = time.perf_counter() - t0
        grasps = [(g.wrist_pose, g.dofs, g.epsilon, features(g, centre, radius)) for g in res.grasps[: args.top]]
        stages = sum(v for k, v in res.timings.items() if k != "total")
        rows[method] = {"plan_s": plan_s, "stages_s": stages, "robust_s": res.timings.get("robust", 0.0),
                        "trials": simulate(sim, cache, grasps, perturbations, label), "grasps": len(grasps)}
        print(f"  {label} {method}: planned in {plan_s:.1f} s, {_rate(rows[method]['trials'])}", file=sys.stderr,
              flush=True)
    checker = pg.GraspChecker(planner.hand, mesh, obstacles=[])
    for method in ("random", "random-fc"):
        if method not in args.methods:
            continue
        t0 = time.perf_counter()
        rand, tries = [], 0
        while len(rand) < args.random and tries < 200 * args.random:
            tries += 1
            T, q = random_grasp(planner.hand, checker, mesh, rng)
            e = pg.evaluate_grasp(checker, T, q, close=False, contacts_per_link=6)
            if method == "random" or e.force_closure:
                rand.append((T, q, e.epsilon, {}))
        rows[method] = {"plan_s": time.perf_counter() - t0, "trials": simulate(sim, cache, rand, perturbations, label),
                        "grasps": len(rand), "sampled": tries}
        print(f"  {label} {method}: {len(rand)} of {tries} samples, {_rate(rows[method]['trials'])}",
              file=sys.stderr, flush=True)
    for row in rows.values():
        for t in row["trials"]:
            t.pop("result", None)
    return {"target": label, "mass": sim.target_mass, "pieces": sim.counts["pieces"]["target"],
            "scene_s": setup, "rows": rows}


def _rate(ts):
    k = sum(t["success"] for t in ts)
    return f"{k}/{len(ts)} held"


def _held(ts) -> str:
    k, n = sum(t["success"] for t in ts), len(ts)
    lo, hi = wilson(k, n)
    return f"{k}/{n} {100 * k / max(n, 1):.0f}% ({100 * max(lo, 0):.0f}-{100 * min(hi, 1):.0f}%)"


def table(results) -> str:
    """Top-1 and top-5 held rates per target and method, then over every target."""
    lines = ["| target | method | top-1 held (95% interval) | top-5 held (95% interval) | top-1 as planned | "
             "kept in hand (top 5) | CPU s per simulated s |", "|---|---|---|---|---|---|---|"]
    total = {}
    for res in results:
        for method in METHODS:
            if method in res["rows"]:
                ts = res["rows"][method]["trials"]
                total.setdefault(method, []).extend(ts)
                lines.append(_row(res["target"], method, ts))
    for method, ts in total.items():
        lines.append(_row("**all**", method, ts))
    return "\n".join(lines)


def _row(target, method, ts) -> str:
    """Top-1 (the rank-1 grasp, or the first random one) and top-5 held rates with Wilson intervals."""
    top1 = [t for t in ts if t["grasp"] == 0]
    t0 = [t for t in top1 if t["trial"] == 0]
    kept = sum(t["outcome"] in ("held", "slipped") for t in ts)
    sim_t = sum(t["time_simulated"] for t in ts)
    cpu = sum(t["wall_time"] for t in ts)
    return (f"| {target} | {_label(method)} | {_held(top1)} | {_held(ts)} | {sum(t['success'] for t in t0)}/{len(t0)} "
            f"| {kept}/{len(ts)} | {cpu / max(sim_t, 1e-9):.2f} |")


def predictors(results) -> str:
    """Per planned grasp (each once): its held rate over the trials against each feature, as the
    Spearman rank correlation and the feature's mean over grasps that held in every trial against
    the others."""
    from scipy.stats import spearmanr

    seen, rows = set(), []
    for res in results:
        for method in PLANNED:
            by_grasp = {}
            for t in res["rows"].get(method, {}).get("trials", []):
                by_grasp.setdefault(t["grasp"], []).append(t)
            for ts in by_grasp.values():
                key = (res["target"], round(ts[0]["epsilon"], 12), ts[0].get("com_offset"))
                if key in seen:
                    continue
                seen.add(key)
                rows.append({**{k: ts[0].get(k) for k in ("epsilon", "p_fc", "robust_epsilon", "com_offset", "links",
                                                          "straddle")},
                             "rate": sum(t["success"] for t in ts) / len(ts)})
    lines = [f"{len(rows)} distinct planned grasps", "| feature | Spearman rho with held rate (p) | mean, held in "
             "every trial | mean, the others |", "|---|---|---|---|"]
    for f in ("epsilon", "p_fc", "robust_epsilon", "com_offset", "links", "straddle"):
        pairs = [(r[f], r["rate"]) for r in rows if r[f] is not None and np.isfinite(r[f])]
        if len(pairs) < 3:
            continue
        x, y = np.array(pairs).T
        rho, pv = spearmanr(x, y)
        good, bad = x[y == 1], x[y < 1]
        lines.append(f"| {f} | {rho:+.2f} ({pv:.2g}) | {good.mean() if len(good) else float('nan'):.3f} (n={len(good)}) | "
                     f"{bad.mean() if len(bad) else float('nan'):.3f} (n={len(bad)}) |")
    return "\n".join(lines) + "\n" + reranked(results)


# Features and whether more is better, for re-ranking a ranking's top 5 by one of them.
_RERANK = (("epsilon", 1), ("p_fc", 1), ("robust_epsilon", 1), ("com_offset", -1), ("links", 1), ("straddle", 1))


def reranked(results, method="robust") -> str:
    """Top-1 held rate if `method`'s top 5 (already simulated, on the same trials) were re-ranked by
    one feature (ties: the planned order): whether the feature would help as the final criterion."""
    if not any(method in res["rows"] for res in results):
        return ""
    out = [f"top-1 held if the {_label(method)}'s top 5 were re-ranked by one feature (same trials):"]
    for f, sign in (("planned order", 0),) + _RERANK:
        held, n = 0, 0
        for res in results:
            by_grasp = {}
            for t in res["rows"].get(method, {}).get("trials", []):
                by_grasp.setdefault(t["grasp"], []).append(t)
            if not by_grasp:
                continue
            def key(k):
                v = by_grasp[k][0].get(f) if sign else None
                return (-(sign * v) if v is not None and np.isfinite(v) else 0.0, k)
            best = min(by_grasp, key=key)
            held += sum(t["success"] for t in by_grasp[best])
            n += len(by_grasp[best])
        lo, hi = wilson(held, n)
        out.append(f"  {f}: {held}/{n} {100 * held / max(n, 1):.0f}% ({100 * max(lo, 0):.0f}-{100 * min(hi, 1):.0f}%)")
    return "\n".join(out)


def _run_one(item):
    target, args = item
    return run(target, args)


def main(argv=None) -> int:
    from bench_peers import BUNDLED, PYBULLET

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--targets", nargs="+", default=list(BUNDLED) + list(PYBULLET),
                    help="bundled names and pybullet_data mesh paths")
    ap.add_argument("--grid-step", type=float, default=0.5, help="DOF step of the grid schedule (rad)")
    ap.add_argument("--top", type=int, default=5)
    ap.add_argument("--random", type=int, default=5, help="random-approach grasps per target")
    ap.add_argument("--trials", type=int, default=4, help="trials per grasp (the first as planned)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--methods", nargs="+", choices=METHODS, default=["robust", "epsilon", "enclosure", "load", "random"],
                    help="rankings, schedules and baselines to run")
    ap.add_argument("--jobs", type=int, default=1, help="targets run at once (processes)")
    ap.add_argument("--no-paint", action="store_true", help="plan with every face free")
    ap.add_argument("--picture", help="write epsilon against the slip of every trial 0 as this PNG")
    ap.add_argument("--json", help="write the measurements as JSON")
    ap.add_argument("--table-from", metavar="JSON", help="print the tables of a run saved with --json and stop")
    args = ap.parse_args(argv)
    if args.table_from:
        with open(args.table_from) as fh:
            saved = json.load(fh)
        print(table(saved["results"]))
        print(predictors(saved["results"]))
        return 0
    t0 = time.perf_counter()
    if args.jobs > 1:
        import multiprocessing as mp

        with mp.get_context("spawn").Pool(args.jobs) as pool:
            results = pool.map(_run_one, [(t, args) for t in args.targets], chunksize=1)
    else:
        results = [run(t, args) for t in args.targets]
    print(f"Barrett hand, fast schedule top {args.top}, {args.trials} trials per grasp (seed {args.seed}), "
          f"{args.random} random grasps per target, {'no paint' if args.no_paint else 'bundled paint'}; pairgrasp "
          f"{pg.__version__}, {platform.processor() or platform.machine()}, {os.cpu_count()} cores, {args.jobs} jobs; "
          f"{time.perf_counter() - t0:.0f} s")
    print(table(results))
    print(predictors(results))
    for res in results:
        parts = []
        for m, row in res["rows"].items():
            part = f"{m} {row['plan_s']:.1f} s"
            if "robust_s" in row and row["robust_s"]:
                part += f" (robust ranking {row['robust_s']:.2f} s of {row['stages_s']:.2f} s of stages, " \
                        f"{100 * row['robust_s'] / row['stages_s']:.0f}%)"
            if "sampled" in row:
                part += f" ({row['sampled']} samples)"
            parts.append(part)
        print(f"{res['target']}: {res['mass']:.3f} kg, {res['pieces']} convex pieces, scene built in "
              f"{res['scene_s']:.1f} s; planning or sampling: {', '.join(parts)}")
    if args.picture:
        from types import SimpleNamespace

        from pairgrasp import render

        trial0 = [(t, _label(m)) for res in results for m, row in res["rows"].items() for t in row["trials"]
                  if t["trial"] == 0]
        render.simulation_figure([t["epsilon"] for t, _ in trial0],
                                 [SimpleNamespace(slip_translation=t["slip_translation"], success=t["success"])
                                  for t, _ in trial0], pg.SimParams(), args.picture,
                                 title="Barrett hand:", groups=[g for _, g in trial0])
        print(f"wrote {args.picture}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"args": vars(args), "results": results}, fh, indent=1, default=float)
    return 0


if __name__ == "__main__":
    sys.exit(main())
