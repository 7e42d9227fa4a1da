"""Parallel jaws on the bundled targets: antipodal alignment (the default for a jaw) against
area-sampled pads aligned by the pair votes (``constellation="area"``, the jaws' way before),
measured in the same run.

    python bench/bench_jaws.py [--repeat 3] [--json OUT.json]

Per jaw (the bundled one; pybullet_data's Franka Panda hand from its whole-arm URDF with the spec
pairgrasp.propose_spec proposes, unedited) and target (flask, mug, box, no paint): force-closure
grasps among the evaluated candidates, best epsilon of the top 5, and the plan's ``timings.total``
(median of --repeat runs), then the area / antipodal time ratio and the antipodal / area best-epsilon
ratio.

With GPG installed (``sh bench/install_gpg.sh``), GPG's candidate generation on the same target and
jaw (``bench/gpg_peer.py``: 3,000 surface points, 500 seeds; median of --repeat runs) and the
antipodal plan's time over it are printed too: the realtime issue's "within 3x GPG".
"""
from __future__ import annotations

import argparse
import atexit
import json
import os
import shutil
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
    folder = tempfile.mkdtemp(prefix="pgjaws-")
    atexit.register(shutil.rmtree, folder, True)
    path = os.path.join(folder, "panda.json")
    with open(path, "w") as f:
        json.dump(panda, f)
    jaw = os.path.join(ROOT, "models", "parallel_jaw", "parallel_jaw.json")
    return {"parallel_jaw": (pg.load_hand(jaw), jaw), "panda": (pg.load_hand(path), path)}


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


def gpg(hand_path, target, repeat):
    """GPG's candidates and generation seconds (median of ``repeat``) on the target, or None when
    GPG is not installed."""
    try:
        import grasp_pose_generator  # noqa: F401
    except ImportError:
        return None
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import gpg_peer

    times, doc = [], None
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeat):
            doc = gpg_peer.run(hand_path, os.path.join(ROOT, "models", "targets", f"{target}.stl"), tmp, top=10)
            times.append(doc["timings"]["gpg"])
    return {"candidates": doc["counts"]["gpg_candidates"], "gpg_s": statistics.median(times),
            "force_closure_of_first_10": doc["counts"]["force_closure"]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", help="write the rows there")
    args = ap.parse_args(argv)
    rows = []
    print("| jaw | target | antipodal: FC / evaluated | best ε | plan (s) | area: FC / evaluated | best ε | plan (s) "
          "| area / antipodal time | ε antipodal / area | GPG: candidates (FC of its first 10) | GPG (s) "
          "| antipodal plan / GPG |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, (hand, path) in jaws().items():
        for t in TARGETS:
            a = one(hand, t, "antipodal", args.repeat)
            b = one(hand, t, "area", args.repeat)
            g = gpg(path, t, args.repeat)
            rows.append({"jaw": name, "target": t, "antipodal": a, "area": b, "gpg": g})
            ratio_e = f"{a['best_epsilon'] / b['best_epsilon']:.2f}" if b["best_epsilon"] > 0 else "–"
            peer = ("not installed | – | –" if g is None else
                    f"{g['candidates']} ({g['force_closure_of_first_10']}) | {g['gpg_s']:.3f} | "
                    f"{a['total_s'] / g['gpg_s']:.1f}×")
            print(f"| {name} | {t} | {a['force_closure']} / {a['evaluated']} | {a['best_epsilon']:.4f} | "
                  f"{a['total_s']:.2f} | {b['force_closure']} / {b['evaluated']} | {b['best_epsilon']:.4f} | "
                  f"{b['total_s']:.2f} | {b['total_s'] / a['total_s']:.1f}× | {ratio_e} | {peer} |", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
