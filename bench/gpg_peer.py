"""GPG, the antipodal grasp-pose generator of GPD, as a peer of the planner's parallel jaws: the same
object, the same jaw, the same physics check (``bench/bench_holdout.py --hands parallel_jaw,gpg``).

    python bench/gpg_peer.py --hand models/parallel_jaw/parallel_jaw.json --target MESH -o DIR
        [--support] [--points 3000] [--samples 500] [--top 10] [--seed 1]

Install GPG first: ``sh bench/install_gpg.sh`` (PyPI ``grasp-pose-generator`` built against Debian's
PCL). A benchmark peer only: the library does not use it.

What GPG is given, as its users give it:

- the object's surface as ``--points`` points sampled uniformly by area (no normals: GPG estimates
  them with PCL and turns them towards its camera, which its Python binding fixes at the origin; the
  cloud is placed so that the camera is 0.5 m from the object's centre, above it and 30 degrees
  off the vertical; with ``--support`` the cloud is still the object's alone, the table segmented
  out as GPG's users do, and the checker below holds the table);
- the jaw's geometry, measured from the hand's meshes at the open configuration: the opening between
  the fingers' inner faces, the fingers' thickness along the closing axis, their length along the
  approach and half their height across it;
- ``--samples`` seed points (500 in GPD's tutorials).

GPG returns candidates that are collision-free against the cloud, unranked (GPD ranks them with a
network this package does not include). Each is turned into the jaw's wrist pose (GPG's hand base,
between the fingers' roots, on the fingers' roots' plane, approach and closing axes matched) with the
jaw fully open, checked against the whole mesh (and the table) with pairgrasp's checker (a cloud
hides what it does not sample), then closed onto contact and scored as the planner scores its candidates. The first
``--top`` candidates that pass, **in GPG's order**, are written to DIR/grasps.json in pairgrasp's format,
so that ``pairgrasp simulate`` runs them as it runs a plan. ``timings.gpg`` is GPG's candidate
generation alone; ``timings.total`` adds the checks and the closing. GPG draws its seed points with a
clock-seeded generator, so two runs differ.
"""
from __future__ import annotations

import argparse
import contextlib
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

#: Where GPG's camera (its binding's origin) stands: 0.5 m from the object's centre, along this unit
#: vector of the object's frame (above it, 30 degrees off the vertical).
VIEW = np.array([0.0, -0.5, np.sqrt(3.0) / 2.0])
VIEW_DISTANCE = 0.5


def jaw_geometry(hand) -> dict:
    """The jaw's geometry in its wrist frame at the open configuration (metres): ``frame`` (4x4, the
    frame GPG's hand frame maps to: x the closing axis, z the approach, origin between the fingers'
    roots), ``opening``, ``finger_width``, ``depth`` (along the approach) and ``half_height``.
    ValueError for a hand that is not a two-finger jaw with one DOF."""
    if len(hand.dof_names) != 1:
        raise ValueError(f"{hand.name}: GPG models a parallel jaw with one DOF, this hand has {len(hand.dof_names)}")
    lo, hi = np.asarray(hand.dof_lower, float), np.asarray(hand.dof_upper, float)
    T_open, T_shut = hand.link_transforms(hi), hand.link_transforms(lo)
    fingers = [l for l in hand.links
               if not np.allclose(np.asarray(T_open[l.name]), np.asarray(T_shut[l.name])) and len(l.mesh.vertices)]
    if len(fingers) != 2:
        raise ValueError(f"{hand.name}: GPG models two fingers, the DOF moves {len(fingers)} links with meshes")
    pts = []
    for l in fingers:
        T = np.asarray(T_open[l.name])
        pts.append(np.asarray(l.mesh.vertices, float) @ T[:3, :3].T + T[:3, 3])
    a = np.asarray(hand.approach, float)
    a = a / np.linalg.norm(a)
    d = pts[1].mean(0) - pts[0].mean(0)
    c = d - (d @ a) * a
    if np.linalg.norm(c) < 1e-9:
        raise ValueError(f"{hand.name}: the fingers do not face each other across the approach")
    c /= np.linalg.norm(c)
    y = np.cross(a, c)
    inner = pts[1] @ c
    outer = pts[0] @ c
    opening = float(inner.min() - outer.max())
    if opening <= 0:
        raise ValueError(f"{hand.name}: the open fingers overlap along the closing axis")
    width = float(max(np.ptp(pts[0] @ c), np.ptp(pts[1] @ c)))
    along = np.concatenate([p @ a for p in pts])
    across = np.concatenate([p @ y for p in pts])
    mid_c = 0.5 * (inner.min() + outer.max())
    mid_y = 0.5 * (across.min() + across.max())
    frame = np.eye(4)
    frame[:3, :3] = np.column_stack([c, y, a])
    frame[:3, 3] = mid_c * c + mid_y * y + along.min() * a
    return {"frame": frame, "opening": opening, "finger_width": width, "depth": float(np.ptp(along)),
            "half_height": float(0.5 * np.ptp(across))}


def wrist_pose(hand_frame, geometry) -> np.ndarray:
    """The jaw's wrist pose (4x4) that puts its GPG frame (``geometry["frame"]``) on ``hand_frame``
    (GPG's hand frame: x the closing axis, y the hand axis, z the approach, origin the hand base)."""
    return np.asarray(hand_frame, float) @ np.linalg.inv(geometry["frame"])


@contextlib.contextmanager
def quiet_stdout():
    """GPG's C++ code prints its progress on the process's stdout: sent to stderr's null instead."""
    sys.stdout.flush()
    saved = os.dup(1)
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)
        os.close(null)


def gpg_candidates(points, geometry, samples):
    """GPG's candidates for the cloud ``points`` (N x 3, its frame; camera at the origin): a list of
    (4x4 hand frame: x closing axis, y hand axis, z approach, origin the hand base) and its seconds."""
    import grasp_pose_generator as gpg

    cfg = {"finger_width": geometry["finger_width"],
           "hand_outer_diameter": geometry["opening"] + 2.0 * geometry["finger_width"],
           "hand_depth": geometry["depth"], "hand_height": geometry["half_height"], "init_bite": 0.01,
           "max_grasp_num": 0}
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "hand.cfg")
        with open(path, "w") as f:
            f.writelines(f"{k} = {v}\n" for k, v in cfg.items())
        cloud = np.ascontiguousarray(points, dtype=np.float32)
        with quiet_stdout():
            t0 = time.perf_counter()
            found = gpg.generate_grasps(cloud, int(samples), False, path)
            seconds = time.perf_counter() - t0
    frames = []
    for g in found:
        F = np.eye(4)
        F[:3, :3] = np.column_stack([np.asarray(g.get_grasp_binormal(), float), np.asarray(g.get_grasp_axis(), float),
                                     np.asarray(g.get_grasp_approach(), float)])
        F[:3, 3] = np.asarray(g.get_grasp_bottom(), float)
        frames.append(F)
    return frames, seconds, cfg


def run(hand_path, target_path, out, support=False, n_points=3000, samples=500, top=10, seed=1):
    import trimesh

    import pairgrasp as pg
    import peer_grasps

    hand, target, plane, checker = peer_grasps.scene(hand_path, target_path, support)
    geometry = jaw_geometry(hand)
    mesh = trimesh.Trimesh(np.asarray(target.vertices), np.asarray(target.faces), process=False)
    rng = np.random.default_rng(seed)
    # On a table the cloud is the object's alone, segmented as GPG's users segment the table out
    # (its seeds would otherwise land on the table); the table is the checker's obstacle.
    points, _ = trimesh.sample.sample_surface(mesh, n_points, seed=rng)
    centre = 0.5 * (mesh.bounds[0] + mesh.bounds[1])
    shift = -(centre + VIEW_DISTANCE * VIEW)     # object frame -> GPG's cloud frame (a translation)
    frames, gpg_seconds, cfg = gpg_candidates(points + shift, geometry, samples)

    t0 = time.perf_counter()
    open_q = np.asarray(hand.dof_upper, float)
    grasps, colliding = [], 0
    for F in frames:
        if len(grasps) >= top:
            break
        F = F.copy()
        F[:3, 3] -= shift
        W = wrist_pose(F, geometry)
        if checker.check(W, open_q).pruned:
            colliding += 1
            continue
        grasps.append(peer_grasps.grasp_entry(hand, W, pg.evaluate_grasp(checker, W, open_q), len(grasps) + 1))
    check_seconds = time.perf_counter() - t0
    return peer_grasps.write(
        out, hand, hand_path, target, target_path, plane, grasps,
        parameters={"peer": "gpg", "points": n_points, "samples": samples, "seed": seed, "gpg": cfg,
                    "view": (VIEW_DISTANCE * VIEW).tolist()},
        counts={"gpg_candidates": len(frames), "colliding": colliding},
        timings={"gpg": round(gpg_seconds, 4), "check": round(check_seconds, 4),
                 "total": round(gpg_seconds + check_seconds, 4)})


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hand", required=True, help="a parallel jaw's hand spec (one DOF, two fingers)")
    ap.add_argument("--target", required=True)
    ap.add_argument("-o", "--out", required=True)
    ap.add_argument("--support", action="store_true", help="the target rests on a table at its lowest point")
    ap.add_argument("--points", type=int, default=3000)
    ap.add_argument("--samples", type=int, default=500)
    ap.add_argument("--top", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    try:
        doc = run(args.hand, args.target, args.out, args.support, args.points, args.samples, args.top, args.seed)
    except ImportError as e:
        print(f"gpg_peer: error: {e} (install GPG with: sh bench/install_gpg.sh)", file=sys.stderr)
        return 1
    except (ValueError, RuntimeError, OSError) as e:
        print(f"gpg_peer: error: {e}", file=sys.stderr)
        return 1
    c, t = doc["counts"], doc["timings"]
    print(f"gpg: {c['gpg_candidates']} candidates in {t['gpg']:.3f} s; {c['colliding']} collided with the mesh "
          f"before {c['kept']} were kept, {c['force_closure']} force-closure; total {t['total']:.3f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
