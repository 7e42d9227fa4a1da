"""pairgrasp against its peers, each comparison measured in one run (docs/benchmarks.md, "Against peers").

    python bench/bench_peers.py ppf        # aligner vs OpenCV's point-pair-feature detector
    python bench/bench_peers.py versor     # the versor solver vs Eigen::umeyama (runs bench_versor)
    python bench/bench_peers.py planner    # the planner vs the approach-ray baseline (bench/approach_ray.py)
    python bench/bench_peers.py scaling --png docs/scaling.png   # index build and alignment vs size
    python bench/bench_peers.py budget     # a 10^5-facet target is refused by the pair budget

Extra packages: ``pip install -r bench/requirements.txt`` (OpenCV with contrib for the detector,
pybullet for the object meshes it ships, which nobody here wrote). Every figure printed is measured
in the same run as the figure it is compared with; ``--json FILE`` keeps the raw numbers.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import re
import resource
import subprocess
import sys
import time
from dataclasses import dataclass
from typing import Dict, List, Optional

import numpy as np

import pairgrasp as pg

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
BARRETT = os.path.join(ROOT, "models", "barrett", "barrett.json")
BUNDLED = ("box", "mug", "flask")
# Object meshes shipped in the pybullet wheel (pybullet_data), none made for pairgrasp.
PYBULLET = ("duck.obj", "bunny.obj", "random_urdfs/000/000.obj", "random_urdfs/003/003.obj")


def machine() -> str:
    return f"{os.cpu_count()} cores, {platform.machine()}, Python {platform.python_version()}"


def bundled_path(name: str) -> str:
    return os.path.join(ROOT, "models", "targets", f"{name}.stl")


def load_target(name: str, size: float = 0.1):
    """A bundled target as it is (metres), or a pybullet_data mesh scaled to `size` metres along its
    longest side. Returns (label, mesh)."""
    if name in BUNDLED:
        return name, pg.load_mesh(bundled_path(name))
    import pybullet_data

    path = os.path.join(pybullet_data.getDataPath(), name)
    raw = pg.load_mesh(path)
    longest = float(np.ptp(np.asarray(raw.bounds), axis=0).max())
    label = "pybullet " + os.path.splitext(os.path.basename(name))[0]
    return label, pg.load_mesh(path, scale=size / longest)


# ============================================================================ registration vs PPF

def rotation_deg(a: np.ndarray, b: np.ndarray) -> float:
    """Angle (degrees) of the rotation a·bᵀ."""
    c = (np.trace(a @ b.T) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def random_rotation(rng) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.random(random_state=rng).as_matrix()


def farthest_points(x: np.ndarray, k: int, rng) -> np.ndarray:
    """k indices of x spread by farthest-point sampling from a random start."""
    sel = [int(rng.integers(len(x)))]
    d = ((x - x[sel[0]]) ** 2).sum(1)
    for _ in range(min(k, len(x)) - 1):
        j = int(np.argmax(d))
        sel.append(j)
        d = np.minimum(d, ((x - x[j]) ** 2).sum(1))
    return np.array(sel)


@dataclass
class Patch:
    """A surface patch cut from the target's unit facets, moved and made noisy.

    scene_points/normals: the patch as the sensor sees it (moved by (R, t), with noise);
    truth_rotation/translation: the patch -> target motion that undoes it; centroid: the patch's
    true centroid on the target (m)."""

    scene_points: np.ndarray
    scene_normals: np.ndarray
    truth_rotation: np.ndarray
    truth_translation: np.ndarray
    centroid: np.ndarray


def make_patch(points, normals, radius, sigma, normal_sigma, rng) -> Patch:
    c = points[rng.integers(len(points))]
    sel = np.nonzero(np.linalg.norm(points - c, axis=1) < radius)[0]
    R, t = random_rotation(rng), rng.normal(size=3) * 0.1
    p = points[sel] + rng.normal(size=(len(sel), 3)) * sigma
    n = normals[sel] + rng.normal(size=(len(sel), 3)) * normal_sigma
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return Patch(scene_points=p @ R.T + t, scene_normals=n @ R.T, truth_rotation=R.T,
                 truth_translation=-R.T @ t, centroid=points[sel].mean(0))


def pose_errors(patch: Patch, R: np.ndarray, t: np.ndarray, query) -> tuple:
    """(rotation error in degrees, translation error in metres: how far the estimate puts the patch
    centroid from where it was cut, mean distance of the moved patch to the target surface)."""
    moved = patch.scene_points @ R.T + t
    centroid_error = float(np.linalg.norm(moved.mean(0) - patch.centroid))
    surface = float(np.mean(np.asarray(query.distance(moved))))
    return rotation_deg(R, patch.truth_rotation), centroid_error, surface


def icp_refine(icp, R, t, patch: Patch, model: np.ndarray):
    """Refines a patch -> target pose with OpenCV's point-to-plane ICP (the patch, moved by the
    estimate, registered onto the target's cloud). Returns (R, t)."""
    moved = np.hstack([patch.scene_points @ R.T + t, patch.scene_normals @ R.T]).astype(np.float32)
    _, _, delta = icp.registerModelToScene(moved, model)
    delta = np.asarray(delta, float)
    return delta[:3, :3] @ R, delta[:3, :3] @ t + delta[:3, 3]


def run_ppf(args) -> dict:
    import cv2

    rng = np.random.default_rng(args.seed)
    rows = []
    for name in args.targets:
        label, mesh = load_target(name)
        extent = float(np.ptp(np.asarray(mesh.bounds), axis=0).max())
        h = extent / args.facets_per_extent
        f = pg.tessellate(mesh, h)
        P, N = np.array(f.points), np.array(f.normals)
        model = np.hstack([P, N]).astype(np.float32)
        query = pg.SurfaceQuery(mesh)
        radius = extent * args.patch_radius
        row = {"target": label, "facets": len(P), "edge": h, "extent": extent, "methods": {}}
        # pairgrasp: the pair index over the same points (d_max: the patch's diameter plus h).
        t0 = time.perf_counter()
        index = pg.PairIndex(P, N, d_max=2 * radius + h)
        tolerances = {}
        if args.feature_tolerance:
            d, phi, beta = args.feature_tolerance
            tolerances["tolerance"] = [d * index.spacing, phi, beta]
        if args.angle_tolerance:
            tolerances["angle_tolerance"] = math.radians(args.angle_tolerance)
        aligner = pg.Aligner(index, **tolerances)
        methods = {"pairgrasp": {"train_s": time.perf_counter() - t0, "pairs": len(index), "aligner": aligner}}
        tol = np.asarray(aligner.tolerance, float)
        row["aligner_tolerance"] = {"d_spacings": float(tol[0] / index.spacing), "phi": float(tol[1]),
                                    "beta": float(tol[2]), "angle_deg": math.degrees(aligner.angle_tolerance)}
        if args.aligner_before:
            # The same aligner with its pre-filter off (every correspondence solved): identical poses.
            methods["pairgrasp, no prefilter"] = {"train_s": methods["pairgrasp"]["train_s"], "pairs": len(index),
                                                  "aligner": pg.Aligner(index, prefilter=False, **tolerances)}
        for step in args.ppf_step:
            t0 = time.perf_counter()
            det = cv2.ppf_match_3d_PPF3DDetector(step, args.ppf_distance_step)
            det.trainModel(model)
            methods[f"ppf {step:g}"] = {"train_s": time.perf_counter() - t0, "detector": det}
        icp = cv2.ppf_match_3d_ICP(args.icp_iterations)
        for m in methods.values():
            m.update(time=[], raw=[], refined=[], icp_time=[])
        for _ in range(args.trials):
            patch = make_patch(P, N, radius, args.noise * h, args.normal_noise, rng)
            scene = np.hstack([patch.scene_points, patch.scene_normals]).astype(np.float32)
            sub = farthest_points(patch.scene_points, args.query_points, rng)
            for key, m in methods.items():
                t0 = time.perf_counter()
                if key.startswith("pairgrasp"):
                    # The aligner treats its query as a gripper: normals out of the finger, so the
                    # patch's outward normals are flipped.
                    poses, phases = m["aligner"].align(patch.scene_points[sub], -patch.scene_normals[sub],
                                                       return_times=True)
                    m.setdefault("phases", []).append(phases)
                    est = (np.array(poses[0].rotation), np.array(poses[0].translation)) if len(poses) else None
                else:
                    found = m["detector"].match(scene, args.ppf_scene_fraction, step)
                    est = None
                    if found:
                        inv = np.linalg.inv(np.asarray(found[0].pose, float))  # model -> scene, inverted
                        est = (inv[:3, :3], inv[:3, 3])
                m["time"].append(time.perf_counter() - t0)
                if est is None:
                    m["raw"].append((180.0, math.inf, math.inf))
                    m["refined"].append((180.0, math.inf, math.inf))
                    m["icp_time"].append(0.0)
                    continue
                m["raw"].append(pose_errors(patch, *est, query))
                t0 = time.perf_counter()
                ref = icp_refine(icp, *est, patch, model)
                m["icp_time"].append(time.perf_counter() - t0)
                m["refined"].append(pose_errors(patch, *ref, query))
        for key, m in methods.items():
            m.pop("detector", None)
            m.pop("aligner", None)
            out = {"train_s": m["train_s"], "median_query_s": float(np.median(m["time"])),
                   "median_icp_s": float(np.median(m["icp_time"]))}
            if "pairs" in m:
                out["pairs"] = m["pairs"]
            if "phases" in m:  # median ms of each aligner phase over the patches
                out["phases_ms"] = {k: float(np.median([p[k] for p in m["phases"]])) for k in m["phases"][0]}
            for stage in ("raw", "refined"):
                e = np.array(m[stage])
                ok = (e[:, 0] < args.max_rotation) & (e[:, 1] < args.max_translation_edges * h)
                on = e[:, 2] < args.max_surface_edges * h
                out[stage] = {"success": float(ok.mean()), "on_surface": float(on.mean()),
                              "median_rotation_deg": float(np.median(e[:, 0])),
                              "median_translation_m": float(np.median(e[:, 1]))}
            row["methods"][key] = out
        rows.append(row)
        print(f"  {label}: done", file=sys.stderr, flush=True)
    return {"rows": rows}


def ppf_table(res, args) -> str:
    t = res["rows"][0]["aligner_tolerance"]
    lines = [f"pairgrasp's aligner: feature tolerance (d, phi, beta) = ({t['d_spacings']:.3g} h, {t['phi']:.3g}, "
             f"{t['beta']:.3g}), rotation tolerance {t['angle_deg']:.3g} deg", "",
             "| target | facets | method | train / index (s) | query (ms) | success | on surface | "
             "+ICP success | +ICP on surface | median rot. error raw / +ICP (°) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for row in res["rows"]:
        for key, m in row["methods"].items():
            r, f = m["raw"], m["refined"]
            lines.append(f"| {row['target']} | {row['facets']:,} | {key} | {m['train_s']:.2f} | "
                         f"{1e3 * m['median_query_s']:.0f} | {100 * r['success']:.0f}% | {100 * r['on_surface']:.0f}% | "
                         f"{100 * f['success']:.0f}% | {100 * f['on_surface']:.0f}% | "
                         f"{r['median_rotation_deg']:.1f} / {f['median_rotation_deg']:.1f} |")
    lines.append("")
    lines.append("Totals over every target (same patches for every method):")
    lines.append("")
    lines.append("| method | success | +ICP success | median query (ms) | median ICP (ms) | train / index (s), sum |")
    lines.append("|---|---|---|---|---|---|")
    keys = list(res["rows"][0]["methods"])
    for key in keys:
        ms = [row["methods"][key] for row in res["rows"]]
        lines.append(f"| {key} | {100 * np.mean([m['raw']['success'] for m in ms]):.0f}% | "
                     f"{100 * np.mean([m['refined']['success'] for m in ms]):.0f}% | "
                     f"{1e3 * np.median([m['median_query_s'] for m in ms]):.0f} | "
                     f"{1e3 * np.median([m['median_icp_s'] for m in ms]):.0f} | "
                     f"{sum(m['train_s'] for m in ms):.1f} |")
    if any("phases_ms" in m for m in res["rows"][0]["methods"].values()):
        lines.append("")
        lines.append("Aligner phases, median ms over each target's patches (AlignResult times):")
        lines.append("")
        lines.append("| target | method | query | prefilter | solve | rotation votes | positions |")
        lines.append("|---|---|---|---|---|---|---|")
        for row in res["rows"]:
            for key, m in row["methods"].items():
                if "phases_ms" in m:
                    p = m["phases_ms"]
                    lines.append(f"| {row['target']} | {key} | {p['query']:.1f} | {p['prefilter']:.1f} | "
                                 f"{p['solve']:.1f} | {p['rotation_votes']:.1f} | {p['positions']:.1f} |")
    return "\n".join(lines)


# ============================================================================ versor vs umeyama

def run_versor(args) -> dict:
    exe = args.versor_exe or os.path.join(ROOT, "build", "bench", "bench", "bench_versor")
    if not os.path.isfile(exe):
        raise SystemExit(f"bench_peers: error: {exe} not found; build it with `make bench`")
    r = subprocess.run([exe], capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"bench_peers: error: {exe} failed: {(r.stderr or r.stdout).strip().splitlines()[-1:]}")
    return {"output": r.stdout, "stderr": r.stderr}


# ============================================================================ planner vs approach rays

def run_planner(args) -> dict:
    from approach_ray import BARRETT_PRESHAPES, ApproachRaySampler

    rows = []
    for name in args.targets:
        paint = os.path.join(ROOT, "models", "targets", f"{name}.paint.json")
        # pairgrasp plan (the CLI's defaults: fast schedule, top 10, seed 0), timed from the start.
        t0 = time.perf_counter()
        planner = pg.Planner(BARRETT, bundled_path(name), paint=paint, seed=args.seed)
        result = planner.plan(progress=False)
        wall = time.perf_counter() - t0
        fc_times = [planner.setup_time + c.time for c in result.candidates if c.force_closure]
        plan = {"wall_s": wall, "setup_s": planner.setup_time, "evaluated": len(result.candidates),
                "force_closure": len(fc_times), "first_fc_s": min(fc_times) if fc_times else math.inf,
                "best_epsilon": result.best_epsilon,
                "best_candidate_epsilon": max((c.epsilon for c in result.candidates), default=0.0)}
        print(f"  {name} plan: {wall:.1f} s, {len(fc_times)} force-closure", file=sys.stderr, flush=True)

        # The approach-ray baseline on the same hand, target, paint and checks.
        t0 = time.perf_counter()
        mesh = pg.load_mesh(bundled_path(name))
        free = pg.load_paint(paint, mesh)
        checker = pg.GraspChecker(planner.hand, mesh, free=free, depth_tolerance=planner.checker.depth_tolerance,
                                  gap=planner.params.gap)
        sampler = ApproachRaySampler(checker, preshapes=BARRETT_PRESHAPES, center=planner.center,
                                     radius=planner.radius)
        setup = time.perf_counter() - t0
        limit = args.baseline_limit if args.baseline_limit else None
        trials = sampler.run(seed=args.seed, time_limit=limit, t0=t0)
        done = time.perf_counter() - t0
        fc = [tr for tr in trials if tr.force_closure]
        in_time = [tr for tr in trials if tr.time <= wall]
        best_in_time = max(in_time, key=lambda tr: tr.epsilon, default=None)

        def full_epsilon(tr):
            if tr is None or not tr.force_closure:
                return 0.0
            ev = tr.evaluation
            return float(pg.grasp_quality(ev.contact_points, ev.contact_normals, planner.center, planner.radius,
                                          mu=planner.params.mu, edges=planner.params.edges).epsilon)

        best_all = max(trials, key=lambda tr: tr.epsilon, default=None)
        base = {"setup_s": setup, "rays": int(len(sampler.usable)), "trials": len(sampler.trials()),
                "evaluated": len(trials), "wall_s": done, "force_closure": len(fc),
                "first_fc_s": min((tr.time for tr in fc), default=math.inf),
                "evaluated_in_plan_time": len(in_time),
                "force_closure_in_plan_time": sum(tr.force_closure for tr in in_time),
                "best_epsilon_in_plan_time": full_epsilon(best_in_time),
                "best_epsilon": full_epsilon(best_all)}
        print(f"  {name} approach rays: {done:.1f} s, {len(trials)} trials, {len(fc)} force-closure",
              file=sys.stderr, flush=True)
        rows.append({"target": name, "plan": plan, "approach_rays": base})
    return {"rows": rows}


def planner_table(res) -> str:
    lines = ["| target | method | evaluated | force-closure | first force-closure (s) | force-closure / s | "
             "best ε at the plan's wall time | wall (s) | best ε at the end |",
             "|---|---|---|---|---|---|---|---|---|"]
    for row in res["rows"]:
        p, b = row["plan"], row["approach_rays"]
        lines.append(f"| {row['target']} | pairgrasp plan | {p['evaluated']:,} | {p['force_closure']:,} | "
                     f"{p['first_fc_s']:.1f} | {p['force_closure'] / p['wall_s']:.3f} | {p['best_epsilon']:.4f} | "
                     f"{p['wall_s']:.1f} | {p['best_epsilon']:.4f} |")
        lines.append(f"| {row['target']} | approach rays ({b['rays']} rays, {b['trials']:,} trials) | "
                     f"{b['evaluated']:,} | {b['force_closure']:,} | {b['first_fc_s']:.1f} | "
                     f"{b['force_closure'] / b['wall_s']:.3f} | {b['best_epsilon_in_plan_time']:.4f} | "
                     f"{b['wall_s']:.1f} | {b['best_epsilon']:.4f} |")
    lines.append("")
    lines.append("| target | first force-closure, rays / plan | force-closure per second, plan / rays | "
                 "best ε at equal time, plan / rays |")
    lines.append("|---|---|---|---|")
    for row in res["rows"]:
        p, b = row["plan"], row["approach_rays"]
        ratio = lambda a, c: a / c if c > 0 and math.isfinite(a) and math.isfinite(c) else math.nan
        lines.append(f"| {row['target']} | {ratio(b['first_fc_s'], p['first_fc_s']):.1f}× | "
                     f"{ratio(p['force_closure'] / p['wall_s'], b['force_closure'] / b['wall_s']):.1f}× | "
                     f"{ratio(p['best_epsilon'], b['best_epsilon_in_plan_time']):.2f} |")
    return "\n".join(lines)


# ============================================================================ scaling

def _measure_child(spec: dict) -> dict:
    """Runs in a fresh interpreter: builds one target index and aligns DOF samples, reporting times
    and peak resident memory (ru_maxrss) before and after each step."""
    def rss():
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # bytes (Linux: KiB)

    mesh = pg.load_mesh(spec["target"])
    hand = pg.load_hand(BARRETT)
    before = rss()
    t0 = time.perf_counter()
    tindex = pg.build_target_index(mesh, edge=spec["edge"], d_max=spec["d_max"], max_pairs=spec["max_pairs"],
                                   threads=1)
    build = time.perf_counter() - t0
    after_build = rss()
    aligner = pg.Aligner(tindex.index, max_poses=3, threads=1)
    lo, hi = np.asarray(hand.dof_lower), np.asarray(hand.dof_upper)
    rng = np.random.default_rng(0)
    times = []
    for _ in range(spec["samples"]):
        q = lo + rng.random(len(lo)) * (hi - lo)
        c = hand.constellation(q, mode="per_link")
        t0 = time.perf_counter()
        aligner.align(c.points, c.normals)
        times.append(time.perf_counter() - t0)
    return {"edge": spec["edge"], "facets": int(len(tindex.facets.points)), "pairs": int(len(tindex.index)),
            "nbytes": int(tindex.index.nbytes), "build_s": build, "build_peak_bytes": after_build - before,
            "align_s": float(np.median(times)), "align_peak_bytes": rss() - after_build}


def run_scaling(args) -> dict:
    mesh = pg.load_mesh(bundled_path(args.scaling_target))
    planner_d_max = pg.Planner(BARRETT, mesh).d_max
    # Facet count ~ area / edge^2: calibrate at one edge, then pick edges for the wanted counts.
    h0 = 0.005
    n0 = len(pg.tessellate(mesh, h0).points)
    rows = []
    for n in args.sizes:
        edge = h0 * math.sqrt(n0 / n)
        spec = {"target": bundled_path(args.scaling_target), "edge": edge, "d_max": planner_d_max,
                "max_pairs": int(args.max_pairs), "samples": args.samples}
        r = subprocess.run([sys.executable, os.path.abspath(__file__), "_child", json.dumps(spec)],
                           capture_output=True, text=True)
        if r.returncode != 0:
            raise SystemExit(f"bench_peers: error: scaling child at edge {edge:.5f} m failed: "
                             f"{(r.stderr or r.stdout).strip().splitlines()[-1:]}")
        row = json.loads(r.stdout.strip().splitlines()[-1])
        rows.append(row)
        print(f"  edge {edge * 1e3:.2f} mm: {row['facets']:,} facets, {row['pairs']:,} pairs, "
              f"build {row['build_s']:.2f} s, align {row['align_s'] * 1e3:.0f} ms", file=sys.stderr, flush=True)
    pairs = np.array([r["pairs"] for r in rows], float)
    fits = {}
    for key in ("build_s", "build_peak_bytes", "align_s"):
        y = np.array([r[key] for r in rows], float)
        ok = y > 0
        slope, intercept = np.polyfit(np.log(pairs[ok]), np.log(y[ok]), 1)
        fits[key] = {"exponent": float(slope), "intercept": float(intercept)}
    facets = np.array([r["facets"] for r in rows], float)
    fits["pairs_vs_facets"] = {"exponent": float(np.polyfit(np.log(facets), np.log(pairs), 1)[0])}
    return {"target": args.scaling_target, "d_max": planner_d_max, "rows": rows, "fits": fits}


def scaling_table(res) -> str:
    lines = [f"Target: the bundled {res['target']} at shrinking unit-facet edge, d_max = {res['d_max']:.3f} m "
             "(the planner's, for the Barrett hand); one thread; peak RSS growth from a fresh process.", "",
             "| edge (mm) | unit facets | stored pairs | build (s) | build peak RSS (MiB) | bytes / pair (index) | "
             "align one DOF sample (ms) |",
             "|---|---|---|---|---|---|---|"]
    for r in res["rows"]:
        lines.append(f"| {r['edge'] * 1e3:.2f} | {r['facets']:,} | {r['pairs']:,} | {r['build_s']:.2f} | "
                     f"{r['build_peak_bytes'] / 2 ** 20:.0f} | {r['nbytes'] / max(r['pairs'], 1):.1f} | "
                     f"{r['align_s'] * 1e3:.1f} |")
    f = res["fits"]
    lines.append("")
    lines.append(f"Fitted growth (log-log least squares against stored pairs): build time ∝ pairs^"
                 f"{f['build_s']['exponent']:.2f}, build peak memory ∝ pairs^{f['build_peak_bytes']['exponent']:.2f}, "
                 f"one DOF sample's alignment ∝ pairs^{f['align_s']['exponent']:.2f}; pairs ∝ facets^"
                 f"{f['pairs_vs_facets']['exponent']:.2f}.")
    return "\n".join(lines)


def scaling_plot(res, path: str):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = res["rows"]
    pairs = np.array([r["pairs"] for r in rows], float)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    series = [("build_s", "index build (s)", 1.0), ("build_peak_bytes", "index build peak RSS (MiB)", 2.0 ** -20),
              ("align_s", "align one DOF sample (s)", 1.0)]
    for ax, (key, label, scale) in zip(axes, series):
        y = np.array([r[key] for r in rows], float) * scale
        fit = res["fits"][key]
        xs = np.geomspace(pairs.min(), pairs.max(), 50)
        ax.loglog(pairs, y, "o", color="tab:blue", label="measured")
        ax.loglog(xs, np.exp(fit["intercept"]) * xs ** fit["exponent"] * scale, "-", color="tab:orange",
                  label=f"fit: ∝ pairs^{fit['exponent']:.2f}")
        ax.set_xlabel("stored pairs")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    fig.suptitle(f"pairgrasp index and alignment vs stored pairs ({res['target']}, "
                 f"{rows[0]['facets']:,} to {rows[-1]['facets']:,} unit facets, Barrett d_max)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ============================================================================ the pair budget

def run_budget(args) -> dict:
    mesh = pg.load_mesh(bundled_path(args.scaling_target))
    d_max = pg.Planner(BARRETT, mesh).d_max
    h0 = 0.005
    n0 = len(pg.tessellate(mesh, h0).points)
    edge = h0 * math.sqrt(n0 / args.budget_facets)
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    t0 = time.perf_counter()
    try:
        pg.build_target_index(mesh, edge=edge, d_max=d_max, max_pairs=int(args.max_pairs))
    except ValueError as exc:
        message = str(exc)
    else:
        raise SystemExit("bench_peers: error: the pair budget did not refuse the target")
    elapsed = time.perf_counter() - t0
    grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 - rss0
    return {"target": args.scaling_target, "edge": edge, "d_max": d_max, "max_pairs": int(args.max_pairs),
            "seconds": elapsed, "peak_rss_growth_bytes": grown, "message": message}


def budget_text(res) -> str:
    return (f"build_target_index({res['target']}, edge={res['edge'] * 1e3:.3f} mm, d_max={res['d_max']:.3f} m, "
            f"max_pairs={res['max_pairs']:,}) refused in {res['seconds']:.2f} s, peak RSS grew by "
            f"{res['peak_rss_growth_bytes'] / 2 ** 20:.0f} MiB:\n  ValueError: {res['message']}")


# ============================================================================ main

def main(argv=None) -> int:
    if argv is None and len(sys.argv) > 2 and sys.argv[1] == "_child":
        print(json.dumps(_measure_child(json.loads(sys.argv[2]))))
        return 0
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("ppf", "versor", "planner", "scaling", "budget"))
    ap.add_argument("--targets", nargs="+", help="ppf: bundled names and pybullet_data paths; planner: bundled names")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", help="write the measurements as JSON")
    g = ap.add_argument_group("ppf")
    g.add_argument("--trials", type=int, default=12, help="patches per target")
    g.add_argument("--facets-per-extent", type=float, default=40, help="unit-facet edge = extent / this")
    g.add_argument("--patch-radius", type=float, default=0.4, help="patch radius / target extent")
    g.add_argument("--noise", type=float, default=0.2, help="position noise sigma / edge")
    g.add_argument("--normal-noise", type=float, default=0.02, help="normal noise sigma (per component)")
    g.add_argument("--query-points", type=int, default=8, help="patch points the aligner aligns")
    g.add_argument("--aligner-before", action="store_true",
                   help="also time the aligner with its pre-filter off (same poses) in the same run")
    g.add_argument("--feature-tolerance", type=float, nargs=3, metavar=("D", "PHI", "BETA"),
                   help="the aligner's feature tolerance box: D in index spacings h, PHI and BETA in radians "
                        "(default: the aligner's, 0.5 0.1 0.1)")
    g.add_argument("--angle-tolerance", type=float, metavar="DEG",
                   help="the aligner's rotation tolerance in degrees (default: the aligner's, 4)")
    g.add_argument("--ppf-step", type=float, nargs="+", default=[0.1, 0.08],
                   help="relativeSamplingStep values of the detector")
    g.add_argument("--ppf-distance-step", type=float, default=0.05, help="relativeDistanceStep")
    g.add_argument("--ppf-scene-fraction", type=float, default=0.2, help="relativeSceneSampleStep")
    g.add_argument("--icp-iterations", type=int, default=100)
    g.add_argument("--max-rotation", type=float, default=5.0, help="success: rotation error below (degrees)")
    g.add_argument("--max-translation-edges", type=float, default=2.0,
                   help="success: centroid error below this many unit-facet edges")
    g.add_argument("--max-surface-edges", type=float, default=0.4,
                   help="on surface: mean distance of the moved patch to the target below this many edges")
    g = ap.add_argument_group("versor")
    g.add_argument("--versor-exe", help="bench_versor program (default build/bench/bench/bench_versor)")
    g = ap.add_argument_group("planner")
    g.add_argument("--baseline-limit", type=float, default=0.0,
                   help="stop the approach-ray baseline after this many seconds (0: run every trial)")
    g = ap.add_argument_group("scaling / budget")
    g.add_argument("--scaling-target", default="flask")
    g.add_argument("--sizes", type=int, nargs="+", default=[1000, 2000, 4000, 8000, 14000, 20000],
                   help="unit facet counts wanted")
    g.add_argument("--samples", type=int, default=2, help="DOF samples aligned per size (median reported)")
    g.add_argument("--max-pairs", type=float, default=4e8, help="pair budget of the scaling runs")
    g.add_argument("--budget-facets", type=int, default=100_000)
    g.add_argument("--png", help="scaling: write the plot here")
    args = ap.parse_args(argv)
    print(f"# bench_peers {args.what}: {machine()}, pairgrasp {pg.__version__}")
    if args.what == "ppf":
        args.targets = args.targets or list(BUNDLED) + list(PYBULLET)
        res = run_ppf(args)
        print(ppf_table(res, args))
    elif args.what == "versor":
        res = run_versor(args)
        print(res["output"])
    elif args.what == "planner":
        args.targets = args.targets or list(BUNDLED)
        res = run_planner(args)
        print(planner_table(res))
    elif args.what == "scaling":
        res = run_scaling(args)
        print(scaling_table(res))
        if args.png:
            scaling_plot(res, args.png)
            print(f"wrote {args.png}")
    else:
        if args.max_pairs == 4e8:
            args.max_pairs = pg.PlanParams().max_pairs
        res = run_budget(args)
        print(budget_text(res))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"machine": machine(), "args": vars(args), **res}, fh, indent=1, default=str)
    return 0


if __name__ == "__main__":
    sys.exit(main())
