"""Whether a grasp's closing fingers come to rest at its planned contacts.

A hand closes by driving each closing DOF with its actuator until the fingers stall against the
object. The physics check's actuators do exactly that (each pushes with its joint's URDF ``effort``,
docs/physics.md), and so do the motors of a real hand. Before any load, the object then stays where
the plan put it only if contact forces inside the friction cones can balance those stall torques and
one another. :func:`closing_friction` asks for the least friction coefficient at which they can.
A grasp that needs more friction than the contacts have is pushed away while the fingers close,
however good its epsilon.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from . import _core
from .quality import contact_frames

__all__ = ["closing_friction"]


def _finite_rows(name: str, value, rows=None) -> np.ndarray:
    a = np.asarray(value, float)
    if a.ndim != 2 or a.shape[1] != 3 or (rows is not None and len(a) != rows):
        want = f"({rows}, 3)" if rows is not None else "(N, 3)"
        raise ValueError(f"{name}: expected an array of shape {want}, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name}: row {int(np.flatnonzero(~np.isfinite(a).all(1))[0])} is not finite")
    return a


def _closing_motions(hand, wrist: np.ndarray, q: np.ndarray, points: np.ndarray, links: Sequence[int]):
    """{closing DOF k: (C, 3) velocity of each contact point per unit closing of DOF k (m per rad or
    m per m; zero below 1e-6, for the contacts it does not move)}, for the closing DOFs that move at
    least one contact."""
    dirs = np.asarray(_core.closing_directions(hand, q)).ravel()   # validates q
    lo, hi = np.asarray(hand.dof_lower, float), np.asarray(hand.dof_upper, float)
    p0 = hand.link_poses(q)
    inv = np.linalg.inv(wrist)
    local = points @ inv[:3, :3].T + inv[:3, 3]                      # the contacts in the wrist frame
    motions = {}
    for k in range(len(q)):
        if dirs[k] == 0:
            continue
        step = 1e-6 * (hi[k] - lo[k]) * dirs[k]
        if not lo[k] <= q[k] + step <= hi[k]:
            step = -step                                              # at a limit: the same direction
        q1 = q.copy()
        q1[k] += step
        p1 = hand.link_poses(q1, True)
        v = np.zeros_like(points)
        for c, link in enumerate(links):
            move = p1[link] @ np.linalg.inv(p0[link])
            v[c] = wrist[:3, :3] @ (move[:3, :3] @ local[c] + move[:3, 3] - local[c]) / step * dirs[k]
        # A contact the DOF does not move shows only round-off (~1e-11); one it moves, its lever arm.
        v[np.linalg.norm(v, axis=1) < 1e-6] = 0.0
        if v.any():
            motions[k] = v
    return motions


def _balanced(frames, points, motions, efforts, center, radius, mu, edges) -> bool:
    """Whether forces in the friction pyramids of coefficient ``mu`` balance the stall torques."""
    from scipy.optimize import linprog

    angles = 2.0 * np.pi * np.arange(edges) / edges
    t = np.cos(angles)[None, :, None] * frames[:, None, 0] + np.sin(angles)[None, :, None] * frames[:, None, 1]
    e = (frames[:, None, 2] + mu * t).reshape(-1, 3)                 # (C * edges, 3) pyramid edges
    owner = np.repeat(np.arange(len(points)), edges)
    rows = [e.T, np.cross((points[owner] - center) / radius, e).T]   # no net force, no net torque
    rhs = [np.zeros(3), np.zeros(3)]
    for k, v in motions.items():                                      # each closing DOF at its stall torque
        rows.append((v[owner] * e).sum(1)[None, :] / radius)
        rhs.append(np.array([efforts[k]]))
    res = linprog(np.zeros(len(e)), A_eq=np.vstack(rows), b_eq=np.concatenate(rhs), bounds=(0, None),
                  method="highs")
    return res.status == 0


def closing_friction(hand, wrist_pose, dofs, points, normals, links, center, radius=None, mu_max: float = 2.0,
                     edges: int = 8, tolerance: float = 1e-3) -> float:
    """The least friction coefficient at which the closing DOFs, each pushing with its stall torque,
    are balanced by contact forces at the grasp's contacts, with no load on the object.

    Each closing DOF (:func:`pairgrasp.closing_directions`) that moves a contact pushes with the URDF
    ``effort`` of its first joint, as the physics check's actuator does (all equal when one has none): the work it does per unit of
    closing equals that of the contact forces on the contacts it moves. DOFs that do not close the
    hand (the Barrett spread) and links no DOF moves (the palm) push back with whatever force
    balance needs. The forces lie in the friction pyramids of :mod:`pairgrasp.quality` and add up to
    no net force and no net torque about ``center``.

    Args:
        hand: :class:`pairgrasp.Hand`.
        wrist_pose: (4, 4) wrist frame in the target frame (m).
        dofs: (D,) closed DOF values, within the hand's limits.
        points, normals: (C, 3) contacts and the target's OUTWARD normals there (the planner's
            ``Grasp.contact_points`` and ``contact_normals``).
        links: (C,) the hand link of each contact, by name or index.
        center: (3,) the torque origin, the target's centre of mass (m).
        radius: torque scale (m) that makes the torque rows commensurate with the forces; None: the
            contacts' largest distance from ``center``. It does not change the answer.
        mu_max: the largest coefficient tried.
        edges: edges of each friction pyramid.
        tolerance: the answer's accuracy (bisection).

    Returns:
        The coefficient in [0, mu_max] (0: the normal forces alone balance; 0.3: a finger whose
        contact needs more than 0.3 pushes the object aside while closing), ``inf`` when even
        ``mu_max`` does not balance them (a single finger pushing the object away), ``nan`` when no
        closing DOF moves a contact (nothing is pushed).

    Raises:
        ValueError: malformed input, naming the argument; DOF values outside the limits.
    """
    w = np.asarray(wrist_pose, float)
    if w.shape != (4, 4) or not np.isfinite(w).all():
        raise ValueError(f"wrist_pose: expected a finite (4, 4) matrix, got shape {w.shape}")
    if np.abs(w[:3, :3] @ w[:3, :3].T - np.eye(3)).max() > 1e-6 or np.abs(w[3] - [0, 0, 0, 1]).max() > 1e-9:
        raise ValueError("wrist_pose: not a rigid transform (its rotation is not orthonormal)")
    q = np.asarray(dofs, float).ravel()
    if len(q) != len(hand.dof_lower) or not np.isfinite(q).all():
        raise ValueError(f"dofs: expected {len(hand.dof_lower)} finite values, got {np.asarray(dofs).tolist()}")
    p = _finite_rows("points", points)
    n = _finite_rows("normals", normals, len(p))
    names = list(hand.link_names)
    if len(links) != len(p):
        raise ValueError(f"links: expected {len(p)} links, one per contact, got {len(links)}")
    idx = []
    for link in links:
        if isinstance(link, str):
            if link not in names:
                raise ValueError(f"links: '{link}' is not a link of hand {hand.name}")
            idx.append(names.index(link))
        elif isinstance(link, (int, np.integer)) and 0 <= int(link) < len(names):
            idx.append(int(link))
        else:
            raise ValueError(f"links: {link!r} is not a link of hand {hand.name}")
    c = np.asarray(center, float).ravel()
    if c.shape != (3,) or not np.isfinite(c).all():
        raise ValueError(f"center: expected 3 finite values, got {np.asarray(center).tolist()}")
    for name, v in (("mu_max", mu_max), ("tolerance", tolerance)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
            raise ValueError(f"{name}: expected a finite number > 0, got {v!r}")
    if isinstance(edges, bool) or not isinstance(edges, (int, np.integer)) or edges < 3:
        raise ValueError(f"edges: expected an integer >= 3, got {edges!r}")
    if len(p) == 0:
        return float("nan")
    frames = contact_frames(n)
    motions = _closing_motions(hand, w, q, p, idx)
    if not motions:
        return float("nan")
    r = float(radius) if radius is not None else max(float(np.linalg.norm(p - c, axis=1).max()), 1e-9)
    if not (math.isfinite(r) and r > 0):
        raise ValueError(f"radius: expected a finite length > 0 (m), got {radius!r}")
    efforts = {}
    joints = {j.name: j for j in hand.joints}
    for k in motions:                       # the actuator drives the DOF's first joint (joint = ratio * q)
        first = hand.dofs[k].joints[0]
        efforts[k] = abs(float(first.ratio)) * float(joints[first.joint].effort)
    if any(v <= 0 for v in efforts.values()):
        efforts = {k: 1.0 for k in efforts}                           # no efforts given: equal ones
    scale = max(efforts.values())
    efforts = {k: v / scale for k, v in efforts.items()}
    if not _balanced(frames, p, motions, efforts, c, r, mu_max, edges):
        return float("inf")
    low, high = 0.0, float(mu_max)
    if _balanced(frames, p, motions, efforts, c, r, 0.0, edges):
        return 0.0
    while high - low > tolerance:
        mid = 0.5 * (low + high)
        if _balanced(frames, p, motions, efforts, c, r, mid, edges):
            high = mid
        else:
            low = mid
    return high
