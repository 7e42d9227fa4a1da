"""Third-party meshes through the whole pipeline: plan, then simulate the top grasp.

    python bench/bench_meshes.py table  [--json meshes.json]   # plan + simulate each mesh (~1 h on 2 cores)
    python bench/bench_meshes.py standin [--holed] [--json standin.json]  # stand-ins against true solids
    python bench/bench_meshes.py large                       # a 594k-face flask, with and without max_faces

The meshes are object files of the ``pybullet`` package (``pybullet_data``: pip install pybullet),
made by others and not repaired here, each at the scale its URDF gives it (or, without one, the scale
noted in MESHES) so that it is hand-sized. ``table`` plans the Barrett hand on each (``fast``
schedule, seed 0) and simulates the top grasp (pairgrasp.Simulator); it prints one Markdown row per
mesh: triangles after loading, closed or not, plan time, force-closure candidates, and whether the top
grasp held. ``standin`` measures, on the closed meshes (bundled and third-party), how far the mass,
centre of mass and inertia of each closed stand-in an open mesh could take (its convex hull, the
union of its CoACD convex pieces, and those pieces when the mesh has a hole) are from the true
solid's: the choice of the convex hull as an open mesh's stand-in rests on it.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
import warnings

import numpy as np

import pairgrasp as pg
from pairgrasp.inertia import hull_mass_properties, pieces_mass_properties

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HAND = os.path.join(ROOT, "models", "barrett", "barrett.json")

# (file in pybullet_data, scale, where the scale comes from)
MESHES = [
    ("objects/mug.obj", 1.0, "objects/mug.urdf"),
    ("duck.obj", 0.05, "duck_vhacd.urdf"),
    ("bunny.obj", 0.1, "chosen: 0.2 m tall"),
    ("teddy2_VHACD_CHs.obj", 0.1, "teddy_vhacd.urdf"),
    ("soccerball.obj", 0.1, "chosen: 0.1 m across"),
    ("lego/lego.obj", 0.1, "lego/lego.urdf"),
    ("random_urdfs/000/000.obj", 0.015, "random_urdfs/000/000.urdf"),
    ("random_urdfs/001/001.obj", 0.015, "random_urdfs/001/001.urdf"),
    ("l_finger.stl", 1.0, "pr2_gripper.urdf"),
    ("franka_panda/meshes/visual/link6.obj", 1.0, "franka_panda/panda.urdf"),
    ("differential/diff_ring.stl", 0.001, "millimetres (the planner's scale message)"),
]
BUNDLED = ["flask", "mug", "box"]


def data_path(name):
    import pybullet_data

    return os.path.join(pybullet_data.getDataPath(), name)


def _load(name, scale):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pg.load_mesh(data_path(name), scale=scale)


def _errors(true, est, size):
    return {"mass": est.mass / true.mass - 1.0,
            "com": float(np.linalg.norm(est.center_of_mass - true.center_of_mass)) / size,
            "inertia": float(np.linalg.norm(est.inertia - true.inertia) / np.linalg.norm(true.inertia))}


STANDIN = ["bunny.obj", "teddy2_VHACD_CHs.obj", "random_urdfs/000/000.obj", "random_urdfs/001/001.obj"]


def standin(args):
    meshes = [(f"bundled {t}", pg.load_mesh(os.path.join(ROOT, "models", "targets", f"{t}.stl"))) for t in BUNDLED]
    meshes += [(f"pybullet_data {n}", _load(n, s)) for n, s, _ in MESHES if n in STANDIN]
    out = {}
    for name, mesh in meshes:
        true = pg.mass_properties(mesh, 1000.0)
        lo, hi = np.asarray(mesh.bounds)
        size = float(np.linalg.norm(hi - lo))
        # the same mesh opened as a scan often is: the plane of its largest face removed (a box's side,
        # a bottle's bottom)
        F = np.asarray(mesh.faces)
        N = np.asarray(mesh.face_normals())
        C = np.asarray(mesh.vertices)[F].mean(axis=1)
        k = int(np.argmax(np.asarray(mesh.face_areas())))
        plane = (N @ N[k] > 0.9999) & (np.abs((C - C[k]) @ N[k]) < 1e-6 * size)
        holed = pg.make_mesh(mesh.vertices, F[~plane], name + " holed")
        e = {"hull": _errors(true, hull_mass_properties(mesh.vertices, 1000.0), size),
             "pieces": _errors(true, pieces_mass_properties(pg.convex_pieces(mesh), 1000.0), size)}
        if args.holed:
            e["pieces of the holed mesh"] = _errors(true, pieces_mass_properties(pg.convex_pieces(holed), 1000.0), size)
        out[name] = dict(e, faces=len(F))
        print(f"| {name} | {len(F)} | " + " | ".join(
            f"{100 * v['mass']:+.1f}% / {100 * v['inertia']:.1f}% / {100 * v['com']:.1f}%" for v in e.values()) + " |",
            flush=True)
    for k in ("hull", "pieces", "pieces of the holed mesh"):
        m = [abs(v[k]["mass"]) for v in out.values() if k in v]
        i = [v[k]["inertia"] for v in out.values() if k in v]
        if not m:
            continue
        print(f"{k}: mass error median {100 * np.median(m):.1f}% max {100 * max(m):.1f}%; "
              f"inertia error median {100 * np.median(i):.1f}% max {100 * max(i):.1f}%")
    return out


def large(args):
    """The bundled flask subdivided into 64 times its faces (trimesh's midpoint subdivision: the same
    shape), and that with 0.2 mm of noise along the vertex normals, planned as they are and as given."""
    import trimesh

    flask = pg.load_mesh(os.path.join(ROOT, "models", "targets", "flask.stl"))
    V, F = np.asarray(flask.vertices), np.asarray(flask.faces)
    for _ in range(3):
        V, F = trimesh.remesh.subdivide(V, F)
    noise = trimesh.Trimesh(V, F, process=False).vertex_normals * np.random.default_rng(0).normal(0, 2e-4, (len(V), 1))
    out = {}
    for name, mesh in (("flask", flask), ("subdivided", pg.make_mesh(V, F, "subdivided")),
                       ("subdivided, noise", pg.make_mesh(V + noise, F, "noisy"))):
        for max_faces in (None, 100_000):
            t = time.perf_counter()
            planner = pg.Planner(HAND, mesh, schedule="fast", seed=0, max_faces=max_faces)
            result = planner.plan(progress=False)
            row = {"faces": len(mesh.faces), "max_faces": max_faces, "setup": planner.setup_time,
                   "facets": int(len(planner.tindex.facets.points)), "plan": time.perf_counter() - t,
                   "force_closure": result.counts["force_closure"], "best_epsilon": result.best_epsilon,
                   "simplified": planner.inputs.get("target_simplified")}
            out[f"{name} {max_faces}"] = row
            print(row, flush=True)
            if len(mesh.faces) <= 100_000:
                break
    return out


def table(args):
    out = {}
    for name, scale, _ in MESHES[args.first:args.last]:
        mesh = _load(name, scale)
        row = {"faces": len(mesh.faces), "closed": bool(mesh.closed)}
        t = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                planner = pg.Planner(HAND, mesh, schedule="fast", seed=0, top=5)
                result = planner.plan(progress=False)
        except ValueError as e:
            row["error"] = str(e)
            out[name] = row
            print(f"| {name} | {len(mesh.faces)} | {'yes' if mesh.closed else 'no'} | {e} |", flush=True)
            continue
        row.update(plan_seconds=time.perf_counter() - t, force_closure=result.counts["force_closure"],
                   simplified=result.to_dict().get("target_simplified"),
                   best_epsilon=result.best_epsilon if result.grasps else None)
        if result.grasps:
            t = time.perf_counter()
            sim = pg.Simulator(HAND, planner.target, convex_threshold=args.convex_threshold)
            r = sim.simulate(result.grasps[0].wrist_pose, result.grasps[0].dofs)
            row.update(held=r.success, outcome=r.outcome, mass_source=sim.target_mass_source,
                       sim_seconds=time.perf_counter() - t)
        out[name] = row
        simp = row["simplified"]
        print(f"| {name} | {row['faces']}" + (f" → {simp['faces']}" if simp else "")
              + f" | {'yes' if row['closed'] else 'no'} | {row['plan_seconds']:.1f} | {row['force_closure']} | "
              f"{row.get('outcome', '-')} ({row.get('mass_source', '-')}) |", flush=True)
    held = [r.get("held") for r in out.values() if "held" in r]
    print(f"top grasp held on {sum(held)} of {len(held)} meshes")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("what", choices=("table", "standin", "large"))
    ap.add_argument("--json", help="write the measurements here")
    ap.add_argument("--holed", action="store_true", help="standin: also the pieces of each mesh with a hole "
                    "(CoACD on an open mesh: minutes each)")
    ap.add_argument("--first", type=int, default=0, help="table: the first mesh of MESHES (for a run split "
                    "into several processes)")
    ap.add_argument("--last", type=int, default=len(MESHES), help="table: one past the last mesh")
    ap.add_argument("--convex-threshold", type=float, default=0.1,
                    help="CoACD concavity threshold of the simulated target (default 0.1: coarser and faster "
                         "than the simulator's 0.05)")
    args = ap.parse_args(argv)
    out = {"table": table, "standin": standin, "large": large}[args.what](args)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"machine": platform.platform(), "cpus": os.cpu_count(), "results": out}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
