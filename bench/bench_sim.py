"""Physics check benchmark: do the planner's grasps hold more often than grasps sampled at random?

    python bench/bench_sim.py                         # Barrett hand on the three bundled targets
    python bench/bench_sim.py --targets flask --random 10 --trials 2    # a quick look

For each target the Barrett hand is planned with the `fast` schedule and with the `grid` schedule
(at a coarser step than the hand's 0.25 rad, `--grid-step`, because the full grid takes many minutes
per target), and the top 5 grasps of each are simulated (pairgrasp.Simulator: close, lift,
turn gravity, shake). The baseline are grasps sampled at random around the target as GraspIt's
random-approach planners do: a uniformly random approach direction towards the centre of mass, a
random roll and spread, the wrist brought in along the approach until the open hand first touches
the target, and the fingers closed onto contact (GraspChecker.close); then the same simulation.

A second baseline (`random-fc`) keeps only the random grasps whose closed contacts are force-closure
(epsilon > 0, the planner's fast lower bound), sampling until `--random` of them are found: it asks
whether the planner's alignment adds anything to a static epsilon filter.

Every grasp, planned or random, is simulated `--trials` times: trial 0 as planned, the others with
execution and model errors drawn from one distribution (wrist offset N(0, 1 mm) per axis, wrist
rotation N(0, 1 degree) about a random axis, friction U(0.4, 0.6), density U(500, 1500) kg/m^3).
The table gives the success rate of each method with a 95% Wilson interval, the comparison being
the random baseline measured in the same run, and the simulated and CPU time per grasp.
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
from pairgrasp import render

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
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


def perturbation(rng, k):
    """Trial k's wrist offset (4x4, applied in the target frame), friction and density; k = 0: none."""
    if k == 0:
        return np.eye(4), None, None
    D = np.eye(4)
    D[:3, :3] = _rotation(_unit(rng), math.radians(rng.normal(0.0, 1.0)))
    D[:3, 3] = rng.normal(0.0, 0.001, size=3)
    return D, float(rng.uniform(0.4, 0.6)), float(rng.uniform(500.0, 1500.0))


def trials(sim, grasps, n_trials, rng):
    """Simulates each (pose, dofs, epsilon) n_trials times; returns per-trial dicts."""
    out = []
    for k_grasp, (T, q, eps) in enumerate(grasps):
        for k in range(n_trials):
            D, mu, rho = perturbation(rng, k)
            P = T.copy()
            P[:3, :3] = D[:3, :3] @ T[:3, :3]
            P[:3, 3] = T[:3, 3] + D[:3, 3]
            r = sim.simulate(P, q, friction=mu, density=rho)
            out.append({"grasp": k_grasp, "trial": k, "epsilon": eps, "success": r.success, "outcome": r.outcome,
                        "slip_translation": r.slip_translation, "slip_rotation": r.slip_rotation,
                        "time_simulated": r.time_simulated, "wall_time": r.wall_time, "result": r})
    return out


def wilson(k, n, z=1.96):
    if n == 0:
        return float("nan"), float("nan")
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return c - h, c + h


def run(target, args, rng):
    mesh_path = os.path.join(ROOT, "models", "targets", f"{target}.stl")
    paint = None if args.no_paint else os.path.join(ROOT, "models", "targets", f"{target}.paint.json")
    mesh = pg.load_mesh(mesh_path)
    planner = pg.Planner(HAND, mesh, paint=paint, seed=args.seed, top=args.top)
    t0 = time.perf_counter()
    sim = pg.Simulator(planner.hand, mesh)
    setup = time.perf_counter() - t0
    rows = {}
    for schedule, step in (("fast", None), ("grid", args.grid_step)):
        if schedule not in args.methods:
            continue
        t0 = time.perf_counter()
        res = planner.plan(schedule=schedule, step=step, progress=False)
        plan_s = time.perf_counter() - t0
        grasps = [(g.wrist_pose, g.dofs, g.epsilon) for g in res.grasps[: args.top]]
        rows[schedule] = {"plan_s": plan_s, "trials": trials(sim, grasps, args.trials, rng), "grasps": len(grasps)}
        print(f"  {target} {schedule}: planned in {plan_s:.1f} s, {_rate(rows[schedule]['trials'])}", file=sys.stderr,
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
                rand.append((T, q, e.epsilon))
        sample_s = time.perf_counter() - t0
        rows[method] = {"plan_s": sample_s, "trials": trials(sim, rand, args.trials, rng), "grasps": len(rand),
                        "sampled": tries}
        print(f"  {target} {method}: {len(rand)} of {tries} samples, {_rate(rows[method]['trials'])}",
              file=sys.stderr, flush=True)
    return {"target": target, "mass": sim.target_mass, "pieces": sim.counts["pieces"]["target"],
            "scene_s": setup, "rows": rows}


def _rate(ts):
    k = sum(t["success"] for t in ts)
    return f"{k}/{len(ts)} held"


def table(results, trials_n) -> str:
    lines = ["| target | method | grasps x trials | held | rate (95% interval) | as planned (trial 0) | "
             "kept in hand | simulated per grasp (s) | CPU per simulated s |", "|---|---|---|---|---|---|---|---|---|"]
    total = {}
    for res in results:
        for method in METHODS:
            if method not in res["rows"]:
                continue
            row = res["rows"][method]
            ts = row["trials"]
            k, n = sum(t["success"] for t in ts), len(ts)
            tot = total.setdefault(method, {"grasps": 0, "trials": []})
            tot["grasps"] += row["grasps"]
            tot["trials"] += ts
            lines.append(_row(res["target"], method, row["grasps"], ts, trials_n))
    for method, tot in total.items():
        lines.append(_row("**all**", method, tot["grasps"], tot["trials"], trials_n))
    return "\n".join(lines)


def _row(target, method, grasps, ts, trials_n) -> str:
    """One table row: held (success) with its Wilson interval, held as planned, kept in hand (not
    dropped: held or slipped), mean simulated time per grasp and CPU seconds per simulated second."""
    k, n = sum(t["success"] for t in ts), len(ts)
    k0 = sum(t["success"] for t in ts if t["trial"] == 0)
    kept = sum(t["outcome"] in ("held", "slipped") for t in ts)
    lo, hi = wilson(k, n)
    sim_t = sum(t["time_simulated"] for t in ts)
    cpu = sum(t["wall_time"] for t in ts)
    return (f"| {target} | {_label(method)} | {grasps} x {trials_n} | {k}/{n} | {100 * k / max(n, 1):.0f}% "
            f"({100 * max(lo, 0):.0f}-{100 * min(hi, 1):.0f}%) | {k0}/{grasps} | {kept}/{n} | "
            f"{sim_t / max(n, 1):.2f} | {cpu / max(sim_t, 1e-9):.2f} |")


METHODS = ("fast", "grid", "random", "random-fc")


def _label(method):
    return {"fast": "planner, fast top 5", "grid": "planner, grid top 5", "random": "random approach",
            "random-fc": "random approach, force-closure only"}[method]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--targets", nargs="+", default=["box", "mug", "flask"])
    ap.add_argument("--grid-step", type=float, default=0.5, help="DOF step of the grid schedule (rad)")
    ap.add_argument("--top", type=int, default=5)
    ap.add_argument("--random", type=int, default=20, help="random-approach grasps per target")
    ap.add_argument("--trials", type=int, default=4, help="trials per grasp (the first as planned)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--methods", nargs="+", choices=METHODS, default=["fast", "grid", "random"],
                    help="planner schedules and baselines to run")
    ap.add_argument("--no-paint", action="store_true", help="plan with every face free")
    ap.add_argument("--picture", help="write epsilon vs outcome of every trial 0 as this PNG")
    ap.add_argument("--json", help="write the measurements as JSON")
    ap.add_argument("--table-from", metavar="JSON", help="print the table of a run saved with --json and stop")
    args = ap.parse_args(argv)
    if args.table_from:
        with open(args.table_from) as fh:
            saved = json.load(fh)
        print(table(saved, max(t["trial"] for r in saved for row in r["rows"].values() for t in row["trials"]) + 1))
        return 0
    rng = np.random.default_rng(args.seed)
    t0 = time.perf_counter()
    results = [run(t, args, rng) for t in args.targets]
    print(f"Barrett hand, {args.trials} trials per grasp, grid step {args.grid_step} rad, seed {args.seed}, "
          f"{'no paint' if args.no_paint else 'bundled paint'}; pairgrasp {pg.__version__}, "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores; {time.perf_counter() - t0:.0f} s")
    print(table(results, args.trials))
    for res in results:
        times = ", ".join(f"{m} {row['plan_s']:.1f} s" + (f" ({row['sampled']} samples)" if "sampled" in row else "")
                          for m, row in res["rows"].items())
        print(f"{res['target']}: {res['mass']:.3f} kg, {res['pieces']} convex pieces, scene built in "
              f"{res['scene_s']:.1f} s; planning or sampling: {times}")
    if args.picture:
        eps, rs, groups = [], [], []
        for res in results:
            for method, row in res["rows"].items():
                for t in row["trials"]:
                    if t["trial"] == 0:
                        eps.append(t["epsilon"])
                        rs.append(t["result"])
                        groups.append(_label(method))
        render.simulation_figure(eps, rs, pg.SimParams(), args.picture, title="Barrett hand, bundled targets:",
                                 groups=groups)
        print(f"wrote {args.picture}")
    if args.json:
        for res in results:
            for row in res["rows"].values():
                for t in row["trials"]:
                    t.pop("result", None)
        with open(args.json, "w") as fh:
            json.dump(results, fh, indent=1, default=float)
    return 0


if __name__ == "__main__":
    sys.exit(main())
