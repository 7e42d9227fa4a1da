"""Grasp quality in C++ (qhull's reentrant library) against SciPy's ConvexHull, measured in one run.

    python bench/bench_quality.py                      # the flask and the box, fast schedule
    python bench/bench_quality.py --targets box --json out/bench_quality.json

The contact sets are those a real plan evaluates: the Barrett hand is planned on bundled targets
with ``pg.Planner``, and the contacts of every candidate its C++ pipeline evaluated are read back
(reduced per link as the search scores them, ``pg.reduce_contacts``), with every contact of the
returned grasps. Then, on the same contact sets and for each in turn:

* C++: ``pg.grasp_quality`` with the planner's arguments (wrenches, reductions, rank test, hull,
  epsilon; Python argument checks included);
* SciPy: the comparison, the epsilon of the same wrench set by ``scipy.spatial.ConvexHull``
  (``np.unique`` of ``pg.wrench_matrix``'s rows, the hull, the smallest facet offset; the
  wrench matrix itself is built outside the timing). Rank-deficient sets, which qhull refuses, are
  counted and left out of both timings.

Each figure is the median of ``--repeat`` runs over all sets. It prints the time per candidate of
both, their ratio, the largest relative difference of epsilon between them, and the time of the
hull-free ``pg.epsilon_upper_bound`` on the same sets.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import numpy as np
from scipy.spatial import ConvexHull, QhullError

import pairgrasp as pg
import pairgrasp.planner as pg_planner

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BARRETT = os.path.join(ROOT, "models", "barrett", "barrett.json")


def collect(target: str, seed: int, step: float):
    """The contact sets (kwargs of grasp_quality) that one plan of `target` evaluates."""
    pipes = []
    make = pg_planner._core.GraspSearch

    def recording(*args, **kw):
        pipes.append(make(*args, **kw))
        return pipes[-1]

    mesh = os.path.join(ROOT, "models", "targets", f"{target}.stl")
    paint = os.path.join(ROOT, "models", "targets", f"{target}.paint.json")
    planner = pg.Planner(BARRETT, mesh, paint=paint if os.path.exists(paint) else None, seed=seed)
    pg_planner._core.GraspSearch = recording
    try:
        t0 = time.perf_counter()
        result = planner.plan(schedule="fast", step=step, progress=None)
        plan_s = time.perf_counter() - t0
    finally:
        pg_planner._core.GraspSearch = make
    p = result.params
    common = dict(center=np.array(planner.center, float), radius=float(planner.radius), mu=p.mu, edges=p.edges)
    calls = []
    for c in pipes[-1].evaluated():
        e = c.evaluation
        if e.pruned or not e.n_contacts:
            continue
        k = pg.reduce_contacts(e.contact_points, e.contact_links, p.contacts_per_link)
        calls.append(dict(points=np.array(e.contact_points)[k], normals=np.array(e.contact_normals)[k],
                          open_volume=False, **common))
    for g in result.grasps:
        if len(g.contact_points):
            calls.append(dict(points=np.array(g.contact_points), normals=np.array(g.contact_normals), **common))
    return calls, plan_s


def scipy_epsilon(w: np.ndarray) -> float:
    hull = ConvexHull(np.unique(w, axis=0))
    return max(float(-hull.equations[:, -1].max()), 0.0)


def median_time(fn, items, repeat: int) -> float:
    runs = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for it in items:
            fn(it)
        runs.append(time.perf_counter() - t0)
    return float(np.median(runs))


def measure(calls, repeat: int):
    def cpp(c):
        return pg.grasp_quality(**c)

    def bound(c):
        return pg.epsilon_upper_bound(c["points"], c["normals"], c["center"], c["radius"], mu=c.get("mu", 0.5),
                                      edges=c.get("edges", 8))

    wrenches, hullable, refused = [], [], 0
    for c in calls:
        keys = ("points", "normals", "center", "radius", "mu", "edges", "soft", "torsion", "soft_rings")
        w = pg.wrench_matrix(**{k: c[k] for k in keys if k in c})
        try:
            scipy_epsilon(w)
        except QhullError:
            refused += 1
            continue
        wrenches.append(w)
        hullable.append(c)
    worst = 0.0
    for c, w in zip(hullable, wrenches):
        q, ref = cpp(c), scipy_epsilon(w)
        if q.force_closure or ref > 1e-9:
            worst = max(worst, abs(q.epsilon - ref) / max(ref, 1e-300))
    n = len(hullable)
    t_cpp = median_time(cpp, hullable, repeat) / n
    t_scipy = median_time(scipy_epsilon, wrenches, repeat) / n
    t_bound = median_time(bound, hullable, repeat) / n
    sizes = [len(w) for w in wrenches]
    return {"sets": n, "rank_deficient_left_out": refused,
            "wrenches_median": float(np.median(sizes)), "wrenches_max": int(max(sizes)),
            "force_closure": int(sum(cpp(c).force_closure for c in hullable)),
            "cpp_ms": 1e3 * t_cpp, "scipy_ms": 1e3 * t_scipy, "ratio": t_scipy / t_cpp,
            "bound_ms": 1e3 * t_bound, "bound_ratio": t_scipy / t_bound,
            "max_rel_epsilon_difference": worst}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--targets", nargs="+", default=["flask", "box"])
    ap.add_argument("--step", type=float, default=0.25, help="DOF step of the plan (rad)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", help="write the raw figures here")
    args = ap.parse_args(argv)
    print(f"# {os.cpu_count()} cores, {platform.machine()}, Python {platform.python_version()}, pairgrasp "
          f"{pg.__version__}; comparison: scipy.spatial.ConvexHull on the same wrench sets")
    rows = []
    for target in args.targets:
        calls, plan_s = collect(target, args.seed, args.step)
        r = measure(calls, args.repeat)
        r.update(target=target, plan_s=plan_s)
        rows.append(r)
        print(f"{target}: {r['sets']} contact sets from one plan ({r['rank_deficient_left_out']} rank-deficient "
              f"left out; wrenches median {r['wrenches_median']:.0f}, max {r['wrenches_max']}; "
              f"{r['force_closure']} force-closure)\n"
              f"  C++ grasp_quality  {r['cpp_ms']:8.3f} ms per candidate\n"
              f"  SciPy ConvexHull   {r['scipy_ms']:8.3f} ms per candidate\n"
              f"  ratio (SciPy / C++) {r['ratio']:7.1f}x   max relative epsilon difference "
              f"{r['max_rel_epsilon_difference']:.1e}\n"
              f"  C++ epsilon_upper_bound (no hull) {r['bound_ms']:.3f} ms per candidate, "
              f"{r['bound_ratio']:.0f}x quicker than SciPy", flush=True)
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
