"""The held-out benchmark's baselines (``bench/bench_holdout.py --hands barrett,approach_ray,random``):
grasps of the same hand that do not come from pairgrasp's planner, written to DIR/grasps.json in
pairgrasp's format so that ``pairgrasp simulate`` runs them as it runs a plan.

    python bench/baseline_peer.py approach_ray|random --hand SPEC --target MESH -o DIR
        [--support] [--top 10] [--seed 1] [--time-limit 10]

- ``approach_ray``: OpenRAVE's grasping module (``bench/approach_ray.py``: rays from the target's
  grown box, rolls, preshapes (the module's Barrett-hand ones for the Barrett hand), stand-offs,
  each trial closed onto contact and scored), its trials in shuffled order for ``--time-limit``
  seconds; the ``--top`` best by force closure then epsilon, as OpenRAVE orders its grasp table.
- ``random``: GraspIt!'s random approaches (``bench/bench_sim.py``'s ``random_grasp``: a random
  approach direction towards the centre of mass, random roll and spread, brought in until the open
  hand touches, then closed), the first ``--top``, in the order drawn.

With ``--support`` the target rests on a table at its lowest point, which the checks hold as an
obstacle (and the simulation as a table, as for a plan made with ``--support``).
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import peer_grasps  # noqa: E402

METHODS = ("approach_ray", "random")


def run(method, hand_path, target_path, out, support=False, top=10, seed=1, time_limit=10.0):
    import pairgrasp as pg

    hand, target, plane, checker = peer_grasps.scene(hand_path, target_path, support)
    t0 = time.perf_counter()
    grasps, counts = [], {}
    if method == "approach_ray":
        from approach_ray import BARRETT_PRESHAPES, ApproachRaySampler

        preshapes = BARRETT_PRESHAPES if hand.name.startswith("barrett") else None
        sampler = ApproachRaySampler(checker, preshapes=preshapes)
        trials = sampler.run(seed=seed, time_limit=time_limit)
        scored = [t for t in trials if t.evaluation is not None and not t.evaluation.pruned]
        scored.sort(key=lambda t: (t.force_closure, t.epsilon), reverse=True)
        for t in scored[:top]:
            W = np.asarray(t.evaluation.wrist_pose, float)
            e = pg.evaluate_grasp(checker, W, np.asarray(t.evaluation.dofs, float), close=False)
            grasps.append(peer_grasps.grasp_entry(hand, W, e, len(grasps) + 1))
        counts = {"trials": len(sampler.trials()), "tried": len(trials), "unpruned": len(scored)}
    elif method == "random":
        from bench_sim import random_grasp

        rng = np.random.default_rng(seed)
        tries = 0
        while len(grasps) < top and tries < 20 * top:
            tries += 1
            W, q = random_grasp(hand, checker, target, rng)
            e = pg.evaluate_grasp(checker, W, q, close=False)
            if not e.pruned:
                grasps.append(peer_grasps.grasp_entry(hand, W, e, len(grasps) + 1))
        counts = {"drawn": tries}
    else:
        raise ValueError(f"method: expected one of {', '.join(METHODS)}, got {method!r}")
    seconds = time.perf_counter() - t0
    return peer_grasps.write(out, hand, hand_path, target, target_path, plane, grasps,
                             parameters={"peer": method, "seed": seed, "time_limit": time_limit}, counts=counts,
                             timings={"total": round(seconds, 4)})


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("method", choices=METHODS)
    ap.add_argument("--hand", required=True)
    ap.add_argument("--target", required=True)
    ap.add_argument("-o", "--out", required=True)
    ap.add_argument("--support", action="store_true")
    ap.add_argument("--top", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--time-limit", type=float, default=10.0, help="approach_ray: seconds of trials")
    args = ap.parse_args(argv)
    try:
        doc = run(args.method, args.hand, args.target, args.out, args.support, args.top, args.seed, args.time_limit)
    except (ValueError, RuntimeError, OSError) as e:
        print(f"baseline_peer: error: {e}", file=sys.stderr)
        return 1
    c = doc["counts"]
    print(f"{args.method}: {c['kept']} grasps kept, {c['force_closure']} force-closure, "
          f"{doc['timings']['total']:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
