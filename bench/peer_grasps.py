"""grasps.json for the held-out benchmark's peers and baselines (bench/gpg_peer.py,
bench/baseline_peer.py): their grasps written in pairgrasp's format, so that ``pairgrasp simulate``
runs them as it runs a plan."""
from __future__ import annotations

import os

import numpy as np


def scene(hand_path, target_path, support):
    """(hand, target, support plane or None, checker): the checker holds the table (a box under the
    plane, as the simulation has it) as an obstacle when ``support``."""
    import pairgrasp as pg
    from pairgrasp.planner import support_plane

    hand = pg.load_hand(hand_path)
    target = pg.load_mesh(target_path)
    plane = support_plane(True, target) if support else None
    table = [pg.support_box(plane, target, 0.15)] if plane is not None else []
    return hand, target, plane, pg.GraspChecker(hand, target, obstacles=table, support=plane)


def grasp_entry(hand, wrist, evaluation, rank) -> dict:
    """One grasp of grasps.json: the wrist pose, the closed DOFs and what ``evaluation`` (a
    :class:`pairgrasp.GraspEvaluation` of the closed grasp) found."""
    e = evaluation
    q = np.asarray(e.dofs, float)
    contacts = [{"point": [float(v) for v in p], "normal": [float(v) for v in n / np.linalg.norm(n)], "link": str(l)}
                for p, n, l in zip(np.asarray(e.contact_points), np.asarray(e.contact_normals), e.contact_links)]
    return {"rank": rank, "wrist_pose": np.asarray(wrist, float).tolist(), "dof": q.tolist(),
            "joints": {k: float(v) for k, v in hand.joint_values(q).items()},
            "epsilon": float(max(e.epsilon, 0.0)), "volume": float(max(e.volume, 0.0)),
            "force_closure": bool(e.force_closure and not e.pruned), "alignment_quality": 0.0, "votes": 0,
            "penetration_depth": float(max(e.depth, 0.0)), "contacts": contacts}


def write(out, hand, hand_path, target, target_path, plane, grasps, parameters, counts, timings) -> dict:
    """Writes OUT/grasps.json and returns the document."""
    from pairgrasp.grasps_file import GRASPS_FORMAT, write_grasps

    inputs = {"hand": hand.name, "hand_spec": os.path.abspath(hand_path), "target": os.path.abspath(target_path),
              "target_faces": int(len(target.faces))}
    if plane is not None:
        inputs["support"] = {"point": [float(v) for v in np.asarray(plane.point)],
                             "normal": [float(v) for v in np.asarray(plane.normal)]}
    doc = {"format": GRASPS_FORMAT, "inputs": inputs, "parameters": parameters,
           "counts": {**counts, "kept": len(grasps), "force_closure": sum(g["force_closure"] for g in grasps)},
           "timings": timings, "grasps": grasps}
    os.makedirs(out, exist_ok=True)
    write_grasps(os.path.join(out, "grasps.json"), doc)
    return doc
