"""Targets far larger than the hand: planned or refused, how fast, in how much memory.

    python bench/bench_large.py [-o OUT] [--hands barrett,parallel_jaw] [--compare] [--timeout S]

Each target is written as an STL into OUT and planned with
``pairgrasp plan --top 3 --seed 1 --pictures 0`` (``python -m pairgrasp`` with this interpreter), one
plan at a time:

- ``box``: 1.5 m x 0.8 m x 0.8 m (no two faces within a hand's span oppose each other);
- ``sheet``: a lone 1 m right triangle (one-sided, every normal the same);
- ``slab``: 1.5 m x 1.5 m x 0.1 m (its faces 0.1 m apart: graspable at its rim).

Per plan it prints the outcome (refused, with the first words of the error line, or the force-closure
grasps kept), the wall time of the whole command, ``timings.total`` and the stages of grasps.json when
it planned, and the command's peak resident memory (``ru_maxrss`` by wait4). ``--compare`` also plans each
with ``--mu 100`` in the same run: at that friction no surface is ruled out (the cone a point's normals
must fit in, 90 deg - atan(100) = 0.6 deg, is narrower than the binning margin), so the plan indexes and
searches the whole free surface, as the planner did before it decided where force closure can be,
and the ratio of the two wall times is printed.
"""
from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from bench_scenes import HANDS, pairgrasp_cmd, run_cmd  # noqa: E402


def targets(out):
    import trimesh

    files = {}
    for name, mesh in (("box", trimesh.creation.box(extents=(1.5, 0.8, 0.8))),
                       ("sheet", trimesh.Trimesh(vertices=np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float),
                                                 faces=np.array([[0, 1, 2]]), process=False)),
                       ("slab", trimesh.creation.box(extents=(1.5, 1.5, 0.1)))):
        path = os.path.join(out, f"{name}.stl")
        mesh.export(path)
        files[name] = path
    return files


def one(hand, path, out, timeout, extra=()):
    os.makedirs(out, exist_ok=True)
    gpath = os.path.join(out, "grasps.json")
    if os.path.exists(gpath):
        os.remove(gpath)
    cmd = pairgrasp_cmd("plan", "--hand", HANDS[hand], "--target", path, "--top", 3, "--seed", 1, "--pictures", 0,
                        "--quiet", *extra, "-o", out)
    rc, wall, err, rss = run_cmd(cmd, timeout)
    rec = {"wall": wall, "peak_mb": rss, "error": err, "fc": None, "total": None, "stages": {}}
    if err is None:
        with open(gpath) as f:
            doc = json.load(f)
        rec["fc"] = sum(1 for g in doc["grasps"] if g.get("force_closure"))
        rec["total"] = doc["timings"]["total"]
        rec["stages"] = {k: v for k, v in doc["timings"].items() if k != "total"}
    return rec


def mb(rec):
    return "–" if rec["peak_mb"] is None else f"{rec['peak_mb']:.0f}"


def outcome(rec):
    if rec["error"] is None:
        return f"planned: {rec['fc']} force-closure of 3"
    words = rec["error"].split(": ")  # pairgrasp: error: FILE: what
    return "refused: " + (words[3] if len(words) > 3 else rec["error"])[:60].replace("|", "/")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-o", "--out", default=os.path.join(ROOT, "out", "bench_large"))
    ap.add_argument("--hands", default="barrett,parallel_jaw")
    ap.add_argument("--compare", action="store_true", help="also plan each with --mu 100 (nothing ruled out)")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per plan")
    args = ap.parse_args(argv)
    hands = [h for h in args.hands.split(",") if h]
    for h in hands:
        if h not in HANDS:
            ap.error(f"--hands: unknown hand {h!r} (known: {', '.join(HANDS)})")
    os.makedirs(args.out, exist_ok=True)
    files = targets(args.out)
    rows = ["| hand | target | outcome | wall (s) | plan (s) | stages (s) | peak MB |"
            + (" with --mu 100: outcome | wall (s) | peak MB | ratio of wall times |" if args.compare else ""),
            "|---|---|---|---|---|---|---|" + ("---|---|---|---|" if args.compare else "")]
    for hand in hands:
        for name, path in files.items():
            rec = one(hand, path, os.path.join(args.out, hand, name), args.timeout)
            stages = ", ".join(f"{k} {v:.2f}" for k, v in rec["stages"].items() if v >= 0.05) or "–"
            row = (f"| {hand} | {name} | {outcome(rec)} | {rec['wall']:.2f} | "
                   f"{'–' if rec['total'] is None else format(rec['total'], '.2f')} | {stages} | {mb(rec)} |")
            if args.compare:
                old = one(hand, path, os.path.join(args.out, hand, name + "_mu100"), args.timeout, ("--mu", 100))
                row += (f" {outcome(old)} | {old['wall']:.2f} | {mb(old)} "
                        f"| {old['wall'] / rec['wall']:.1f}x |")
            print(row, flush=True)
            rows.append(row)
    print()
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
