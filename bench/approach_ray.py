"""The classic approach-ray grasp sampler, as OpenRAVE's grasping module does it, for comparison
with the planner (``bench/bench_peers.py planner``). It is a benchmark baseline, not part of the
library.

OpenRAVE's ``GraspingModel`` (``databases/grasping.py`` and its ``grasper`` planner) generates
grasps of a target like this:

* **Approach rays** (``computeBoxApproachRays``, ``delta`` = 0.02 m by default): the target's
  axis-aligned box is grown by 0.01 m; on each of its 6 sides a grid of points ``delta`` apart
  (centred on the side, the centre included) casts a ray inwards, perpendicular to the side. Each
  ray that hits the target gives the hit point and the surface's outward normal there; the hand
  approaches the point along the negated normal.
* **Parameters per ray**: rolls about the approach direction (default 0, pi/2, pi, 3 pi/2),
  preshapes (finger values before closing; for the Barrett hand the module's own defaults are
  flexions 0.5 rad with spread pi/3 or 0, and flexions 0 with spread pi/2), standoffs (default 0
  and 0.025 m). Every (ray, roll, preshape, standoff) is one grasp trial.
* **A trial** (the ``grasper`` planner): the hand, at its preshape, is turned so that its palm
  faces the approach direction and rolled, its palm put at the hit point, then backed up in
  0.05 m steps until it no longer collides with the target; it then moves straight along the
  approach direction until it touches, backs off by the standoff (keeping the touching pose if
  the standoff pose collides), closes its fingers until contact, and the force-closure measure
  of the contacts is computed.

Here the hand is pairgrasp's (the wrist frame's approach axis faces the palm direction), and the
checks are pairgrasp's own: :meth:`GraspChecker.check` for collision while moving (a pose
collides when any link intersects or is inside the target), and :func:`pairgrasp.evaluate_grasp`
for closing onto contact, penetration/occlusion pruning and epsilon, exactly as the planner
evaluates its candidates, so that a comparison measures only where the poses come from. The
straight move is resolved by bisection to ``resolution`` (1 mm) instead of 1 mm steps. Rays that
hit an occluded (painted) face are skipped: OpenRAVE has no notion of occlusion, and a grasp
approaching an occluded face would be pruned anyway.
"""
from __future__ import annotations

import math
import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import List, Optional, Sequence

import numpy as np

import pairgrasp as pg

__all__ = ["ApproachRays", "side_offsets", "box_approach_rays", "approach_rotation", "Trial",
           "ApproachRaySampler", "BARRETT_PRESHAPES"]

#: OpenRAVE's Barrett-hand preshapes, (flexion, flexion, flexion, spread) there, in pairgrasp's DOF
#: order (spread, f1_flex, f2_flex, f3_flex).
BARRETT_PRESHAPES = ((math.pi / 3, 0.5, 0.5, 0.5), (0.0, 0.5, 0.5, 0.5), (math.pi / 2, 0.0, 0.0, 0.0))


@dataclass(frozen=True)
class ApproachRays:
    """Rays cast from the grown box and where they hit the target.

    Attributes:
        origins: (N,3) ray origins on the grown box's sides (m).
        directions: (N,3) unit ray directions (inward, perpendicular to the side).
        hit: (N,) whether the ray hits the target.
        points: (N,3) hit points (m; zero where nothing is hit).
        normals: (N,3) unit outward surface normals at the hit points.
        faces: (N,) faces hit (-1: none).
    """

    origins: np.ndarray
    directions: np.ndarray
    hit: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    faces: np.ndarray


def side_offsets(half_extent: float, delta: float) -> np.ndarray:
    """Grid coordinates along one side of half-length ``half_extent``: ``-e, -e + delta, ...`` up to
    below ``-delta/4``, then 0, then ``delta, 2 delta, ...`` below ``e`` (OpenRAVE's
    ``r_[arange(-e, -0.25 delta, delta), 0, arange(delta, e, delta)]``)."""
    if not (half_extent >= 0 and delta > 0):
        raise ValueError(f"side_offsets: expected half_extent >= 0 and delta > 0, got {half_extent}, {delta}")
    return np.concatenate([np.arange(-half_extent, -0.25 * delta, delta), [0.0],
                           np.arange(delta, half_extent, delta)])


def box_approach_rays(query: "pg.SurfaceQuery", delta: float = 0.02, margin: float = 0.01) -> ApproachRays:
    """OpenRAVE's box approach rays on a target (its own frame): the axis-aligned box of the mesh,
    grown by ``margin`` on every side, and on each side a grid ``delta`` apart casting rays
    inwards. The hits' normals are the target's outward face normals (the rays come from
    outside, so they face the ray)."""
    lo, hi = np.asarray(query.mesh.bounds, float)
    centre = (lo + hi) / 2
    half = (hi - lo) / 2 + margin
    origins, dirs = [], []
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        uu, vv = np.meshgrid(side_offsets(half[u], delta), side_offsets(half[v], delta), indexing="ij")
        for sign in (1.0, -1.0):
            o = np.tile(centre, (uu.size, 1))
            o[:, axis] += sign * half[axis]
            o[:, u] += uu.ravel()
            o[:, v] += vv.ravel()
            d = np.zeros_like(o)
            d[:, axis] = -sign
            origins.append(o)
            dirs.append(d)
    origins = np.concatenate(origins)
    dirs = np.concatenate(dirs)
    hits = query.ray_cast(origins, dirs, max_t=float(2 * np.linalg.norm(half)) + 0.03)
    return ApproachRays(origins=origins, directions=dirs, hit=np.asarray(hits.hit, bool),
                        points=np.array(hits.points), normals=np.array(hits.normals),
                        faces=np.asarray(hits.faces, int))


def approach_rotation(approach: Sequence[float], direction: Sequence[float], roll: float) -> np.ndarray:
    """The wrist rotation that turns the hand's ``approach`` axis (wrist frame) onto ``direction``
    (target frame) by the smallest rotation, after rolling the hand by ``roll`` radians about its
    approach axis (OpenRAVE: ``quatRotateDirection(manip_dir, dir) * quatFromAxisAngle(manip_dir,
    roll)``)."""
    from scipy.spatial.transform import Rotation

    a = np.asarray(approach, float) / np.linalg.norm(approach)
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    c = float(np.clip(a @ d, -1.0, 1.0))
    axis = np.cross(a, d)
    s = float(np.linalg.norm(axis))
    if s < 1e-12:  # parallel or opposite: any axis perpendicular to a
        perp = np.eye(3)[int(np.argmin(np.abs(a)))]
        axis = np.cross(a, perp)
        axis /= np.linalg.norm(axis)
        turn = Rotation.identity() if c > 0 else Rotation.from_rotvec(math.pi * axis)
    else:
        turn = Rotation.from_rotvec(axis / s * math.atan2(s, c))
    return (turn * Rotation.from_rotvec(a * roll)).as_matrix()


@dataclass(frozen=True)
class Trial:
    """One evaluated approach-ray trial.

    Attributes:
        index: position in the trial order.
        ray: index into the sampler's rays.
        roll, standoff: radians, metres.
        preshape: (D,) DOF values before closing.
        time: seconds since :meth:`ApproachRaySampler.run` started when the trial finished.
        touched: the straight move found a touching pose (False: the hand never cleared the target
            within ``max_backup`` or never touched it along the ray).
        evaluation: the :class:`pairgrasp.GraspEvaluation` (None when not touched).
    """

    index: int
    ray: int
    roll: float
    preshape: np.ndarray
    standoff: float
    time: float
    touched: bool
    evaluation: object

    @property
    def force_closure(self) -> bool:
        return self.evaluation is not None and bool(self.evaluation.force_closure)

    @property
    def epsilon(self) -> float:
        return float(self.evaluation.epsilon) if self.evaluation is not None else 0.0


class ApproachRaySampler:
    """Approach-ray grasp trials of one hand on one target (see the module docstring).

    Args:
        checker: a :class:`pairgrasp.GraspChecker` (hand, target, free mask).
        preshapes: (P, D) DOF values before closing (default: the hand's lower limits, fingers open).
        rolls: roll angles (rad; default 0, pi/2, pi, 3 pi/2).
        standoffs: standoff distances (m; default 0, 0.025).
        delta: approach-ray grid spacing (m).
        backup_step: step of the initial back-up (m).
        max_backup: the largest back-up tried before a trial is given up (m).
        resolution: resolution of the straight move onto contact (m).
        center, radius, mu, edges, contacts_per_link: the epsilon computation
            (:func:`pairgrasp.evaluate_grasp`).
    """

    def __init__(self, checker, preshapes=None, rolls=None, standoffs=None, delta: float = 0.02,
                 backup_step: float = 0.05, max_backup: float = 0.5, resolution: float = 0.001,
                 center=None, radius=None, mu: float = 0.5, edges: int = 8, contacts_per_link: Optional[int] = 4):
        self.checker = checker
        self.hand = checker.hand
        lo = np.asarray(self.hand.dof_lower, float)
        self.preshapes = np.atleast_2d(np.asarray(preshapes if preshapes is not None else [lo], float))
        if self.preshapes.shape[1] != len(lo):
            raise ValueError(f"preshapes: expected {len(lo)} values each, got {self.preshapes.shape[1]}")
        self.rolls = np.asarray(rolls if rolls is not None else np.arange(0, 2 * math.pi, math.pi / 2), float)
        self.standoffs = np.asarray(standoffs if standoffs is not None else [0.0, 0.025], float)
        self.backup_step, self.max_backup, self.resolution = float(backup_step), float(max_backup), float(resolution)
        self.approach = np.asarray(self.hand.approach, float).reshape(3)
        if center is None or radius is None:
            c0, r0 = pg.torque_reference(checker.target)
            center = c0 if center is None else center
            radius = r0 if radius is None else radius
        self.quality = dict(center=center, radius=radius, mu=mu, edges=edges, contacts_per_link=contacts_per_link)
        self.rays = box_approach_rays(pg.SurfaceQuery(checker.target), delta=delta)
        free = np.asarray(checker.free, bool)
        ok = self.rays.hit.copy()
        ok[ok] = free[self.rays.faces[ok]]
        self.usable = np.nonzero(ok)[0]

    def trials(self, seed: Optional[int] = None) -> List[tuple]:
        """(ray, roll, preshape index, standoff) of every trial: OpenRAVE's order (rays outermost,
        then rolls, preshapes, standoffs), or shuffled by ``numpy.random.default_rng(seed)``."""
        out = [(int(r), float(roll), p, float(s)) for r in self.usable for roll in self.rolls
               for p in range(len(self.preshapes)) for s in self.standoffs]
        if seed is not None:
            order = np.random.default_rng(seed).permutation(len(out))
            out = [out[k] for k in order]
        return out

    def _pose(self, rot: np.ndarray, point: np.ndarray, back: float) -> np.ndarray:
        T = np.eye(4)
        T[:3, :3] = rot
        T[:3, 3] = point - back * (rot @ self.approach)
        return T

    def _collides(self, T, q) -> bool:
        return bool(self.checker.check(T, q).collision)

    def touching_pose(self, ray: int, roll: float, preshape: np.ndarray, standoff: float) -> Optional[np.ndarray]:
        """The wrist pose of a trial before closing: the palm at the hit point, backed up in
        ``backup_step`` steps until clear, moved along the approach until it touches (bisection to
        ``resolution``: the last clear pose), then backed off by the standoff unless that collides.
        None when the hand does not clear within ``max_backup``."""
        point = self.rays.points[ray]
        rot = approach_rotation(self.approach, -self.rays.normals[ray], roll)
        back = 0.0
        while self._collides(self._pose(rot, point, back), preshape):
            back += self.backup_step
            if back > self.max_backup:
                return None
        if back == 0.0:
            # Clear at the hit point itself (the palm is below the point): move on until contact.
            far, near = 0.0, None
            step = self.backup_step
            while near is None:
                if self._collides(self._pose(rot, point, -step), preshape):
                    near = -step
                else:
                    far = -step
                    step += self.backup_step
                    if step > self.max_backup:
                        return None
        else:
            far, near = back, back - self.backup_step  # clear at `far`, colliding at `near`
        while far - near > self.resolution:
            mid = (far + near) / 2
            if self._collides(self._pose(rot, point, mid), preshape):
                near = mid
            else:
                far = mid
        if standoff > 0 and not self._collides(self._pose(rot, point, far + standoff), preshape):
            far += standoff
        return self._pose(rot, point, far)

    def trial(self, index: int, spec: tuple, t0: float) -> Trial:
        ray, roll, p, standoff = spec
        q = self.preshapes[p]
        T = self.touching_pose(ray, roll, q, standoff)
        ev = pg.evaluate_grasp(self.checker, T, q, **self.quality) if T is not None else None
        return Trial(index=index, ray=ray, roll=roll, preshape=q.copy(), standoff=standoff,
                     time=time.perf_counter() - t0, touched=T is not None, evaluation=ev)

    def run(self, seed: Optional[int] = None, time_limit: Optional[float] = None, threads: int = 0,
            t0: Optional[float] = None) -> List[Trial]:
        """Evaluates the trials in order (or shuffled by ``seed``) on ``threads`` threads (0: every
        core) until all are done or ``time_limit`` seconds have passed since ``t0`` (default: now).
        Returns the finished trials in order; their ``time`` is measured from ``t0``."""
        t0 = time.perf_counter() if t0 is None else t0
        specs = self.trials(seed)
        workers = threads or (os.cpu_count() or 1)
        out: List[Trial] = []
        batch = 8 * workers
        with ThreadPoolExecutor(max_workers=workers) as pool:
            for b in range(0, len(specs), batch):
                if time_limit is not None and time.perf_counter() - t0 >= time_limit:
                    break
                chunk = list(range(b, min(b + batch, len(specs))))
                out.extend(pool.map(lambda k: self.trial(k, specs[k], t0), chunk))
        return out
