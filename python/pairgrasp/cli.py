"""The `pairgrasp` command line.

Every failure prints one line `pairgrasp: error: ...` on stderr and exits with a non-zero status; a
warning (e.g. a target that is not watertight) prints one line `pairgrasp: warning: ...`.
"""
from __future__ import annotations

import argparse
import collections
import json
import math
import os
import shutil
import sys
import tempfile
import time
import warnings

import numpy as np

from . import _core
from .params import PlanParams
from .sim import VERIFY_CHECKS
from .workflow import finish_outdir, planner_from_files, write_plan


class _Parser(argparse.ArgumentParser):
    """argparse that reports a bad command line in one line (exit status 2)."""

    def error(self, message: str):  # noqa: D102
        self.exit(2, f"pairgrasp: error: {message} (see: {self.prog} --help)\n")


def _fmt_vec(v) -> str:
    return "(" + ", ".join(f"{x:.4g}" for x in np.asarray(v, float).ravel()) + ")"


def _cmd_info(args) -> int:
    import pairgrasp as pg

    lines = [f"pairgrasp {pg.__version__}"]
    if args.hand:
        hand = pg.load_hand(args.hand)
        lines.append(f"hand {hand.name}: {len(hand.dof_names)} DOF, wrist link {hand.wrist_link}, "
                      f"approach {_fmt_vec(hand.approach)}")
        for name, lo, hi, st in zip(hand.dof_names, hand.dof_lower, hand.dof_upper, hand.dof_step):
            lines.append(f"  dof {name:<12s} [{lo:.4g}, {hi:.4g}]  step {st:.4g}")
        mid = (np.asarray(hand.dof_lower) + np.asarray(hand.dof_upper)) / 2
        per_link = hand.constellation(mid, mode="per_link")
        area = hand.constellation(mid, mode="area", spacing=args.spacing)
        lines.append(f"  constellation at mid-range: {len(per_link.points)} per-link samples, "
                     f"{len(area.points)} area samples at {args.spacing:g} m")
    if args.target:
        mesh = pg.load_mesh(args.target, scale=args.scale)
        lo, hi = np.asarray(mesh.bounds)
        lines.append(f"target {args.target}: {len(mesh.vertices)} vertices, {len(mesh.faces)} faces, "
                     f"closed {'yes' if mesh.closed else 'no'}")
        lines.append(f"  extent {_fmt_vec(hi - lo)} m, area {mesh.area:.5g} m^2, "
                     f"volume {mesh.volume:.5g} m^3, centre of mass {_fmt_vec(mesh.center_of_mass)} m")
        if args.paint:
            free = np.asarray(pg.load_paint(args.paint, mesh), bool)
            lines.append(f"  paint {args.paint}: {int(free.sum())} of {len(free)} faces free "
                         f"({100.0 * free.mean():.1f}%)")
    elif args.paint:
        raise ValueError("--paint needs --target")
    print("\n".join(lines))
    return 0


# The PlanParams fields the target options (_add_target_options) set, when given.
_PLAN_PARAMS = ("schedule", "step", "top", "seed", "time_limit", "edge", "max_pairs_per_cell", "field_cell",
                "max_field_memory", "threads", "rank", "mu")


def _plan_params(args) -> dict:
    """The PlanParams fields a `plan`, `figures` or `batch` command line gives."""
    return {k: getattr(args, k) for k in _PLAN_PARAMS if getattr(args, k) is not None}


def _planner_from_args(args):
    """The Planner of a `plan` (or `figures`) command line."""
    return planner_from_files(args.hand, args.target, paint=args.paint, occluders=args.occluder or (),
                              obstacles=args.obstacle or (), viewpoints=args.viewpoint, support=args.support,
                              occluder_distance=args.occluder_distance, scale=args.scale, **_plan_params(args))


def _table(grasps, verified=None) -> str:
    """The grasps as printed by plan; ``verified``: (column name, {planned rank: text}) of verified
    grasps."""
    name, cells = verified if verified else ("", {})
    robust = any(g.force_closure_probability is not None for g in grasps)
    load = any(g.load_resistance is not None for g in grasps)
    rows = [f"{'rank':>4s}  {'epsilon':>8s}  {'fc':>3s}" + ("   load" if load else "") + ("  P(fc)  eps_q25" if robust else "") +
            f"  {'Q_A':>8s}  {'votes':>5s}  {'penetration':>11s}  contacts" + (f"  {name}" if cells else "")]
    for rank, g in enumerate(grasps, start=1):
        r = (f"  {g.force_closure_probability:5.2f}  {g.robust_epsilon:7.4f}" if g.force_closure_probability is not None
             else "      -        -") if robust else ""
        h = f"  {cells[g.rank]} (planned {g.rank})" if g.rank in cells else ""
        lr = (f"  {g.load_resistance:5.3f}" if g.load_resistance is not None else "      -") if load else ""
        rows.append(f"{rank:>4d}  {g.epsilon:>8.4f}  {'yes' if g.force_closure else 'no':>3s}{lr}{r}  "
                    f"{g.alignment_quality:>8.3f}  {g.votes:>5d}  {1000 * g.penetration_depth:>8.2f} mm  "
                    f"{len(g.contact_points):>8d}{h}")
    return "\n".join(rows)


def _cmd_plan(args) -> int:
    out = args.output
    if os.path.exists(out) and not os.path.isdir(out):
        raise ValueError(f"-o: {out} exists and is not a directory")
    if args.verify != VERIFY_CHECKS[0] and not args.verify_top:
        raise ValueError("--verify: only with --verify-top K")
    if args.verify_top:
        from .sim import import_mujoco

        import_mujoco()                          # say what is missing before planning
    t0 = time.perf_counter()
    planner = _planner_from_args(args)
    result = planner.plan(progress=None if not args.quiet else False)
    t_plan = time.perf_counter()
    parent = os.path.dirname(os.path.abspath(out))
    os.makedirs(parent, exist_ok=True)
    tmpdir = tempfile.mkdtemp(prefix=".pairgrasp-", dir=parent)
    try:
        verify = (lambda path, doc: _verify(args, planner, result, path, doc)) if args.verify_top else None
        pictures, grasps, verified = write_plan(planner, result, tmpdir, args.pictures, os.path.basename(args.target),
                                             verify)
        finish_outdir(tmpdir, out)
    finally:
        shutil.rmtree(tmpdir, ignore_errors=True)
    c = result.counts
    print(f"{planner.hand.name} on {args.target}: {c['unit_facets']} unit facets, {c['stored_pairs']} pairs, "
          f"{c['samples']} DOF samples ({c['rejected']} rejected), {c['evaluated']} candidates evaluated, "
          f"{c['force_closure']} force-closure")
    print(_table(grasps, verified))
    stages = ", ".join(f"{k} {v:.2f}" for k, v in result.timings.items() if k != "total")
    t1 = time.perf_counter()
    after = "to simulate and write" if args.verify_top else "to write"
    print(f"time {t1 - t0:.1f} s: plan {t_plan - t0:.1f} s ({stages} s), then {t1 - t_plan:.1f} s {after}; "
          f"wrote {os.path.join(out, 'grasps.json')} and {pictures} pictures")
    return 0


def _cmd_batch(args) -> int:
    from .batch import plan_batch

    if args.address is not None and args.engine != "ray":
        raise ValueError("--address: only with --engine ray")
    t0 = time.perf_counter()
    options = _plan_params(args)
    rows = plan_batch(args.hand, args.targets, args.output, engine=args.engine, address=args.address,
                      workers=args.workers, retries=args.retries, pictures=args.pictures,
                      viewpoints=args.viewpoint, obstacles=args.obstacle or (), scale=args.scale,
                      support=args.support, occluder_distance=args.occluder_distance,
                      progress=None if not args.quiet else False, **options)
    width = max(len(r["target"]) for r in rows)
    lines = [f"{'target':<{width}s}  {'status':<7s}  {'grasps':>6s}  {'fc':>3s}  {'epsilon':>8s}  {'seconds':>7s}"]
    for r in rows:
        eps = "" if r["best_epsilon"] is None else f"{r['best_epsilon']:.4f}"
        lines.append(f"{r['target']:<{width}s}  {r['status']:<7s}  {'' if r['grasps'] is None else r['grasps']:>6}  "
                     f"{'' if r['force_closure'] is None else r['force_closure']:>3}  {eps:>8s}  "
                     f"{'' if r['seconds'] is None else format(r['seconds'], '.1f'):>7s}")
    print("\n".join(lines))
    n = collections.Counter(r["status"] for r in rows)
    print(f"{len(rows)} target{'s' * (len(rows) != 1)}: {n['ok']} planned, {n['failed']} failed, {n['skipped']} skipped; "
          f"{time.perf_counter() - t0:.1f} s; wrote {os.path.join(args.output, 'summary.csv')}")
    for r in rows:
        if r["status"] == "failed":
            where = "" if r["error"].startswith(r["target"]) else f"{r['target']}: "
            print(f"pairgrasp: error: {where}{r['error']}", file=sys.stderr)
    return 1 if n["failed"] else 0


def _verify(args, planner, result, path, doc):
    """plan --verify-top: simulates the best grasps of the document (to be written to ``path``) and
    re-ranks them in it (``--verify``: by how often they held, or how far the lift check moved the
    object); returns the grasps in the new order and the table's column (name, {planned rank: text})."""
    from .sim import verify_grasps

    order = verify_grasps(path, top=args.verify_top, trials=args.trials, seed=args.seed, document=doc,
                          hand=planner.hand, target=planner.given_target, check=args.verify)
    if args.verify == "lift":
        column = ("moved", {g["planned_rank"]: f"{1000 * g['lift_check']['moved']:.1f} mm"
                            for g in doc["grasps"] if "lift_check" in g})
    else:
        column = ("held", {g["planned_rank"]: f"{g['simulation']['success_rate']:.2f}"
                           for g in doc["grasps"] if "simulation" in g})
    by_rank = {g.rank: g for g in result.grasps}
    return [by_rank[r] for r in order], column


def _cmd_figures(args) -> int:
    from . import render

    out = args.output
    if os.path.exists(out) and not os.path.isdir(out):
        raise ValueError(f"-o: {out} exists and is not a directory")
    planner = _planner_from_args(args)
    result = planner.plan(progress=None if not args.quiet else False)
    samples = render.figure7_samples(planner, result, seed=args.seed)
    parent = os.path.dirname(os.path.abspath(out))
    os.makedirs(parent, exist_ok=True)
    tmpdir = tempfile.mkdtemp(prefix=".pairgrasp-", dir=parent)
    name = os.path.splitext(os.path.basename(args.target))[0]
    try:
        f7 = render.figure7(planner, samples, os.path.join(tmpdir, f"fig7_{name}.png"), seed=args.seed)
        f8 = render.figure8(result.candidates, os.path.join(tmpdir, f"fig8_{name}.png"), title=name)
        finish_outdir(tmpdir, out)
    finally:
        shutil.rmtree(tmpdir, ignore_errors=True)
    print(f"wrote {os.path.join(out, os.path.basename(f7))} and {os.path.join(out, os.path.basename(f8))}")
    return 0


def _cmd_simulate(args) -> int:
    from .sim import SimParams, import_mujoco, simulate_grasps

    import_mujoco()
    if not os.path.isfile(args.grasps):
        raise ValueError(f"GRASPS: no such file: {args.grasps}")
    overrides = {k: getattr(args, k) for k in ("density", "friction") if getattr(args, k) is not None}
    params = SimParams(**overrides)
    params.validate()
    bar = None
    if not args.quiet and sys.stderr.isatty():
        def bar(done, total, _result):
            sys.stderr.write(f"\rsimulate [{'#' * int(30 * done / total):<30s}] {done}/{total}")
            if done == total:
                sys.stderr.write("\n")
            sys.stderr.flush()
    t0 = time.perf_counter()
    rep = simulate_grasps(args.grasps, top=args.top, hand=args.hand, target=args.target, params=params,
                          picture=not args.no_picture, progress=bar, trials=args.trials, seed=args.seed,
                          mass=args.mass)
    c = rep.counts
    print(f"{c['bodies']} bodies, {c['joints']} joints, {c['equalities']} equality constraints, "
          f"{c['actuators']} actuators, {c['geoms']} convex geoms; target {rep.params.density:g} kg/m^3, "
          f"friction {rep.params.friction:g}")
    src = rep.target_mass_source
    given = src.endswith(", mass given")
    src = src.replace(", mass given", "")
    print(f"target mass {rep.target_mass:.4g} kg: " + ("given (--mass), inertia" if given else "mass and inertia")
          + f" from its {src}" + ("" if given or src == "solid" else "; --mass KG gives the mass"))
    several = args.trials > 1
    rows = [f"{'rank':>4s}  {'epsilon':>8s}  {'outcome':>8s}  {'slip':>9s}  {'turn':>9s}  {'sim':>6s}  {'cpu':>6s}" +
            (f"  held of {args.trials} trials" if several else "")]
    for rank, eps, r, rate in zip(rep.ranks, rep.epsilons, rep.results, rep.success_rates):
        slip = f"{1000 * r.slip_translation:6.2f} mm" if np.isfinite(r.slip_translation) else "     inf"
        turn = f"{math.degrees(r.slip_rotation):5.1f} deg" if np.isfinite(r.slip_rotation) else "    inf"
        rows.append(f"{rank:>4d}  {eps:>8.4f}  {r.outcome:>8s}  {slip:>9s}  {turn:>9s}  {r.time_simulated:5.2f}s  "
                    f"{r.wall_time:5.2f}s" + (f"  {rate:.2f}" if several else ""))
    print("\n".join(rows))
    held = sum(r.success for r in rep.results)
    n = len(rep.results)
    if several:
        k = sum(r.success for rs in rep.trials for r in rs)
        print(f"perturbed trials (wrist N(0, 1 mm) and N(0, 1 deg), friction U(0.4, 0.6), density U(500, 1500) "
              f"kg/m^3; seed {args.seed}): held {k}/{n * args.trials}")
    print(f"held {held}/{n}; {time.perf_counter() - t0:.1f} s, {sum(r.wall_time for r in rep.results) / max(n, 1):.2f} s "
          f"per grasp on the CPU; wrote {rep.path}" + (f" and {rep.picture}" if rep.picture else ""))
    return 0


def _cmd_hand(args) -> int:
    import pairgrasp as pg

    if args.hand_command == "import":
        spec = pg.import_hand(args.model, args.wrist, args.output, name=args.name, force=args.force)
        print(f"wrote {args.output}: hand.urdf, meshes/, hand.json with {len(spec['dofs'])} DOFs "
              f"({', '.join(d['name'] for d in spec['dofs'])}), approach {_fmt_vec(spec['approach'])}, active links "
              f"{', '.join(a['link'] for a in spec['active_surfaces'])}; check it with: pairgrasp hand show "
              f"{os.path.join(args.output, 'hand.json')} -o hand.png")
        return 0
    if args.hand_command == "init":
        spec = pg.propose_spec(args.urdf, args.wrist, package_paths=args.package_path or (), name=args.name)
        text = json.dumps(spec, indent=2) + "\n"
        if args.output is None:
            sys.stdout.write(text)
            return 0
        if os.path.exists(args.output) and not args.force:
            raise ValueError(f"-o: {args.output} exists (--force replaces it)")
        tmp = f"{args.output}.part"
        with open(tmp, "w") as f:
            f.write(text)
        os.replace(tmp, args.output)
        print(f"wrote {args.output}: {len(spec['dofs'])} DOFs ({', '.join(d['name'] for d in spec['dofs'])}), "
              f"approach {_fmt_vec(spec['approach'])}, active links "
              f"{', '.join(a['link'] for a in spec['active_surfaces'])}; check it with: pairgrasp hand show "
              f"{args.output} -o hand.png")
        return 0
    hand = pg.load_hand(args.spec)
    if not args.output.lower().endswith(".png"):
        raise ValueError(f"-o: expected a .png file, got {args.output}")
    print(pg.draw_hand(hand, args.output))
    return 0


def _cmd_view(args) -> int:
    from . import view

    if args.export is None:
        view.import_viser()                      # before loading anything: say what is missing first
    scene = view.load_scene(args.grasps, hand=args.hand, target=args.target)
    if args.export is not None:
        print(view.export_glb(scene, args.export, args.rank))
        for note in scene.notes:
            warnings.warn(f"{args.grasps}: {note}")
        return 0
    if isinstance(args.rank, int):
        scene.grasp(args.rank)                   # an unknown rank is an error before serving
    return view.run(scene, host=args.host, port=args.port, rank=args.rank)


def _rank(text: str):
    if text == "all":
        return text
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1 or 'all', got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1 or 'all', got {text!r}")
    return v


def _port(text: str) -> int:
    v = _count(0)(text)
    if v > 65535:
        raise argparse.ArgumentTypeError(f"expected a port number 0-65535, got {text!r}")
    return v


def _positive_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not np.isfinite(v) or v <= 0:
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text!r}")
    return v


def _nonnegative_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not np.isfinite(v) or v < 0:
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}")
    return v


def _support(text: str):
    """--support's value: "auto", a height (m), or (point, normal) from six comma-separated numbers."""
    if text == "auto":
        return text
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected Z or X,Y,Z,NX,NY,NZ (numbers), got {text!r}") from None
    if len(v) not in (1, 6):
        raise argparse.ArgumentTypeError(f"expected Z or X,Y,Z,NX,NY,NZ (1 or 6 numbers), got {len(v)}")
    if not all(math.isfinite(x) for x in v):
        raise argparse.ArgumentTypeError(f"expected finite numbers, got {text!r}")
    if len(v) == 1:
        return v[0]
    if not any(v[3:]):
        raise argparse.ArgumentTypeError("the normal NX,NY,NZ is zero")
    return (tuple(v[:3]), tuple(v[3:]))


def _count(low: int):
    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if v < low:
            raise argparse.ArgumentTypeError(f"expected an integer >= {low}, got {text!r}")
        return v
    return parse


def _add_plan_arguments(p, output_help: str):
    p.add_argument("--hand", required=True, help="hand spec (JSON)")
    p.add_argument("--target", required=True, help="target mesh (STL, OBJ, PLY, DAE), metres")
    p.add_argument("--paint", help="paint file marking the target's free faces")
    p.add_argument("--occluder", action="append", metavar="MESH",
                   help="mesh in the target frame occluding the faces near it (repeatable)")
    _add_target_options(p)
    p.add_argument("-o", "--output", required=True, metavar="OUTDIR", help=output_help)


def _add_target_options(p, threads_help="worker threads (default 0: every core)"):
    """The `plan` options that apply to any target (shared by `plan`, `figures` and `batch`)."""
    p.add_argument("--viewpoint", action="append", nargs=3, type=float, metavar=("X", "Y", "Z"),
                   help="point (m) from which free faces must be visible (repeatable)")
    p.add_argument("--obstacle", action="append", metavar="MESH", help="mesh the hand must not touch (repeatable)")
    p.add_argument("--support", nargs="?", const="auto", type=_support, metavar="Z|X,Y,Z,NX,NY,NZ",
                   help="the target rests on a plane (a table), an obstacle and an occluder at once: alone, the "
                   "horizontal plane through its lowest point; Z: the plane z = Z (m); six numbers: a point and "
                   "the upward normal")
    p.add_argument("--occluder-distance", type=_nonnegative_float, default=0.005, metavar="M",
                   help="the surface within M metres of an occluder or the support is occluded (default 0.005)")
    p.add_argument("--schedule", choices=("grid", "fast"), default="fast", help="DOF schedule (default fast)")
    p.add_argument("--step", type=_positive_float, help="DOF sampling step (rad; default the hand's)")
    p.add_argument("--edge", type=_positive_float, help="unit-facet edge h (m; default automatic)")
    p.add_argument("--max-pairs-per-cell", type=_count(0), metavar="N",
                   help="about N target pairs kept per cell of the feature space, the rest of a dense cell (a flat "
                   f"face's, a sphere's) dropped (default {PlanParams.max_pairs_per_cell}; 0: every pair)")
    p.add_argument("--field-cell", type=_positive_float, metavar="M",
                   help="cell of the collision checker's distance fields (m; default h/5 but at least 1 mm)")
    p.add_argument("--max-field-memory", type=_positive_float, metavar="GB",
                   help="refuse a target whose distance fields would take more (default 2 GB)")
    p.add_argument("--mu", type=_nonnegative_float, metavar="MU",
                   help="friction coefficient of the contacts (default 0.5); surface that cannot hold a "
                   "force-closure grasp at it within the hand's span is not searched")
    p.add_argument("--time-limit", type=_positive_float, metavar="S",
                   help="stop searching after S seconds and return the best grasps so far (default: no limit)")
    p.add_argument("--top", type=_count(1), default=10, help="grasps kept (default 10)")
    p.add_argument("--seed", type=_count(0), default=0, help="seed of the fine-tuning (default 0)")
    p.add_argument("--threads", type=_count(0), default=0, help=threads_help)
    p.add_argument("--rank", choices=_core.RANKINGS, default=_core.DEFAULT_RANK,
                   help="order of the grasps: load (default: rank 1 is the force-closure grasp of the ten "
                   "best by epsilon that resists gravity along its worst axis best, among those whose fingers close into "
                   "the surface and are pushed back, the rest follow by "
                   "epsilon), enclosure (as load, rank 1 the one with the most hand links in contact), "
                   "epsilon (the paper's: force closure, then epsilon) or robust (probability of force "
                   "closure under pose and friction error, then its lower-quartile epsilon)")
    p.add_argument("--scale", type=_positive_float, default=1.0,
                   help="scale of the target, occluder and obstacle files (0.001: mm to m)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="pairgrasp", description="Grasp planning by pairwise-feature alignment.")
    sub = p.add_subparsers(dest="command", parser_class=_Parser)
    sub.required = True
    info = sub.add_parser("info", help="load a hand and/or a target and print their summary")
    info.add_argument("--hand", help="hand spec (JSON)")
    info.add_argument("--target", help="target mesh (STL, OBJ, PLY, DAE)")
    info.add_argument("--paint", help="paint file marking the target's free faces")
    info.add_argument("--scale", type=float, default=1.0, help="scale applied to the target (0.001: mm to m)")
    info.add_argument("--spacing", type=float, default=0.01, help="area-sample spacing (m) for the summary")
    info.set_defaults(func=_cmd_info)
    plan = sub.add_parser("plan", help="plan grasps; write OUTDIR/grasps.json and pictures of the top grasps")
    _add_plan_arguments(plan, "output folder (created; grasps.json and grasp_NN.png are replaced)")
    plan.add_argument("--pictures", type=_count(0), default=5, help="pictures of the best grasps (default 5)")
    plan.add_argument("--verify-top", type=_count(1), metavar="K",
                      help="simulate the K best grasps in MuJoCo (needs .[sim]) and re-rank them by how often they "
                      "held over --trials perturbed trials (--verify lift: how little the closing and the lift "
                      "move the object, as planned)")
    plan.add_argument("--verify", choices=VERIFY_CHECKS, default=VERIFY_CHECKS[0],
                      help="what --verify-top simulates: every trial of the whole procedure (default), or the "
                      "closing and the lift alone, 0.85 s of simulated time, a seventh of one trial")
    plan.add_argument("--trials", type=_count(1), default=4, help="trials per verified grasp (default 4)")
    plan.set_defaults(func=_cmd_plan)
    figs = sub.add_parser("figures", help="plan, then draw the paper's Figures 7 and 8 as PNG files")
    _add_plan_arguments(figs, "output folder for fig7_<target>.png and fig8_<target>.png")
    figs.set_defaults(func=_cmd_figures)
    batch = sub.add_parser("batch", help="plan grasps on many targets (worker processes or a Ray cluster); "
                           "write OUTDIR/<target>/grasps.json and OUTDIR/summary.csv")
    batch.add_argument("--hand", required=True, help="hand spec (JSON); its folder is sent to every task")
    batch.add_argument("--targets", required=True, nargs="+", metavar="MESH",
                       help="target meshes (file stems must differ); <stem>.paint.json beside one is its paint")
    batch.add_argument("-o", "--output", required=True, metavar="OUTDIR",
                       help="output folder; targets whose folder is there already are skipped")
    batch.add_argument("--engine", choices=("local", "ray"), default="local",
                       help="local: worker processes on this machine (default); ray: Ray tasks")
    batch.add_argument("--address", help="--engine ray: the Ray cluster to join (default: a local Ray instance)")
    batch.add_argument("--workers", type=_count(1), help="targets planned at once (default: every core)")
    batch.add_argument("--retries", type=_count(0), default=2,
                       help="times a target whose worker process died is tried again (default 2)")
    batch.add_argument("--pictures", type=_count(0), default=0, help="pictures of the best grasps per target "
                       "(default 0)")
    _add_target_options(batch, "threads per target (default 0: the cores shared out among the local workers; "
                        "1 per Ray task)")
    batch.set_defaults(func=_cmd_batch)
    simu = sub.add_parser("simulate", help="close, lift and shake planned grasps in MuJoCo; write the outcomes "
                          "into the grasps file")
    simu.add_argument("grasps", metavar="GRASPS", help="grasps.json written by plan (updated in place)")
    simu.add_argument("--top", type=_count(1), help="simulate the first K grasps (default all)")
    simu.add_argument("--hand", help="hand spec (default: the one recorded in the grasps file)")
    simu.add_argument("--target", help="target mesh (default: the one recorded in the grasps file)")
    simu.add_argument("--density", type=_positive_float, help="target density, kg/m^3 (default 1000)")
    simu.add_argument("--friction", type=_positive_float, help="friction coefficient (default 0.5)")
    simu.add_argument("--trials", type=_count(1), default=1,
                      help="simulations per grasp: the first as planned, the others with the wrist, friction and "
                      "density perturbed (default 1)")
    simu.add_argument("--seed", type=_count(0), default=0, help="seed of the perturbed trials (default 0)")
    simu.add_argument("--mass", type=_positive_float, metavar="KG",
                      help="target mass, kg (default: volume x density; an open mesh's volume is its convex hull's)")
    simu.add_argument("--no-picture", action="store_true", help="do not draw simulation.png")
    simu.add_argument("--quiet", action="store_true", help="no progress bar")
    simu.set_defaults(func=_cmd_simulate)
    hand = sub.add_parser("hand", help="propose a hand spec from a URDF (init), import a MuJoCo hand (import), "
                          "draw a spec's hand (show)")
    hand_sub = hand.add_subparsers(dest="hand_command", parser_class=_Parser)
    hand_sub.required = True
    init = hand_sub.add_parser("init", help="propose a hand spec for the hand below a link of a URDF (a robot's "
                               "whole URDF will do): DOFs, approach, active surfaces")
    init.add_argument("urdf", metavar="URDF", help="the URDF file")
    init.add_argument("--wrist", required=True, metavar="LINK", help="the wrist link: the hand is its subtree")
    init.add_argument("--package-path", action="append", metavar="DIR",
                      help="a folder for package:// mesh URIs (repeatable; the URDF's folder and its parent are tried "
                      "after them)")
    init.add_argument("--name", help="the hand's name (default: the URDF's robot name)")
    init.add_argument("-o", "--output", metavar="SPEC.json", help="write the spec there (default: print it)")
    init.add_argument("--force", action="store_true", help="replace -o if it exists")
    imp = hand_sub.add_parser("import", help="write a hand folder (URDF, meshes, proposed spec) for the hand below a "
                              "body of a MuJoCo model (MJCF, or a URDF MuJoCo reads); needs the sim extra")
    imp.add_argument("model", metavar="MODEL", help="the model: MODEL.xml (MJCF) or MODEL.urdf")
    imp.add_argument("--wrist", required=True, metavar="BODY", help="the wrist body: the hand is its subtree")
    imp.add_argument("-o", "--output", required=True, metavar="DIR", help="the hand folder to write")
    imp.add_argument("--name", help="the hand's name (default: the model file's name)")
    imp.add_argument("--force", action="store_true", help="replace -o if it exists")
    show = hand_sub.add_parser("show", help="draw a hand open, at mid-range and closed with its active faces coloured")
    show.add_argument("spec", metavar="SPEC", help="hand spec (JSON)")
    show.add_argument("-o", "--output", required=True, metavar="FILE.png", help="the picture to write")
    hand.set_defaults(func=_cmd_hand)
    view = sub.add_parser("view", help="turn planned grasps around in the browser (viser), or write the scene "
                          "as a glTF file")
    view.add_argument("grasps", metavar="GRASPS", help="grasps.json written by plan")
    view.add_argument("--export", metavar="FILE.glb",
                      help="write the scene as binary glTF instead of serving it (needs trimesh, not viser)")
    view.add_argument("--rank", type=_rank, metavar="K|all",
                      help="the grasp to export or show first (default: rank 1); 'all': every grasp")
    view.add_argument("--port", type=_port, default=8080, help="port to serve on (default 8080; 0: any free port)")
    view.add_argument("--host", default="127.0.0.1",
                      help="address to serve on (default 127.0.0.1; 0.0.0.0 to let other machines connect)")
    view.add_argument("--hand", help="hand spec (default: the one recorded in the grasps file)")
    view.add_argument("--target", help="target mesh (default: the one recorded in the grasps file)")
    view.set_defaults(func=_cmd_view)
    return p


def _show_warning(message, category, filename, lineno, file=None, line=None):
    print(f"pairgrasp: warning: {' '.join(str(message).split())}", file=sys.stderr)


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command == "info" and not (args.hand or args.target):
        parser.error("info needs --hand and/or --target")
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            return args.func(args)
    except KeyboardInterrupt:
        print("pairgrasp: error: interrupted", file=sys.stderr)
        return 130
    except (ValueError, RuntimeError, OSError, ImportError) as e:
        msg = " ".join(str(e).split())
        print(f"pairgrasp: error: {msg}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
