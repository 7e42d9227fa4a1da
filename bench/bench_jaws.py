"""Parallel jaws on the bundled targets: antipodal alignment (the default for a jaw) against
area-sampled pads aligned by the pair votes (``constellation="area"``, the jaws' way before),
measured in the same run.

    python bench/bench_jaws.py [--repeat 3] [--json OUT.json]

Per jaw (the bundled one; pybullet_data's Franka Panda hand from its whole-arm URDF with the spec
pairgrasp.propose_spec proposes, unedited) and target (flask, mug, box, no paint): force-closure
grasps among the evaluated candidates, best epsilon of the top 5, and the plan's ``timings.total``
(median of --repeat runs), then the area / antipodal time ratio and the antipodal / area best-epsilon
ratio.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TARGETS = ("flask", "mug", "box")


def jaws():
    import pybullet_data

    import pairgrasp as pg

    panda = pg.propose_spec(os.path.join(pybullet_data.getDataPath(), "franka_panda", "panda.urdf"), "panda_hand",
                            name="panda")
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump(panda, f)
    try:
        return {"parallel_jaw": pg.load_hand(os.path.join(ROOT, "models", "parallel_jaw", "parallel_jaw.json")),
                "panda": pg.load_hand(f.name)}
    finally:
        os.remove(f.name)


def one(hand, target, constellation, repeat):
    import pairgrasp as pg

    times, r = [], None
    for _ in range(repeat):
        r = pg.Planner(hand, os.path.join(ROOT, "models", "targets", f"{target}.stl"), top=5, seed=1,
                       constellation=constellation).plan(progress=False)
        times.append(r.timings["total"])
    eps = [g.epsilon for g in r.grasps if g.force_closure]
    return {"force_closure": int(r.counts["force_closure"]), "evaluated": int(r.counts["evaluated"]),
            "best_epsilon": max(eps) if eps else 0.0, "total_s": statistics.median(times),
            "align_s": float(r.timings["align"])}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", help="write the rows there")
    args = ap.parse_args(argv)
    rows = []
    print("| jaw | target | antipodal: FC / evaluated | best ε | plan (s) | area: FC / evaluated | best ε | plan (s) "
          "| area / antipodal time | ε antipodal / area |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, hand in jaws().items():
        for t in TARGETS:
            a = one(hand, t, "antipodal", args.repeat)
            b = one(hand, t, "area", args.repeat)
            rows.append({"jaw": name, "target": t, "antipodal": a, "area": b})
            ratio_e = f"{a['best_epsilon'] / b['best_epsilon']:.2f}" if b["best_epsilon"] > 0 else "–"
            print(f"| {name} | {t} | {a['force_closure']} / {a['evaluated']} | {a['best_epsilon']:.4f} | "
                  f"{a['total_s']:.2f} | {b['force_closure']} / {b['evaluated']} | {b['best_epsilon']:.4f} | "
                  f"{b['total_s']:.2f} | {b['total_s'] / a['total_s']:.1f}× | {ratio_e} |", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
