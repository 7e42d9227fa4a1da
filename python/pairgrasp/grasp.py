"""Evaluating a grasp and fine-tuning it by local search.

A *grasp* here is a wrist pose (4x4, the wrist frame in the target frame: ``p_T = R p_G + t``) and a
DOF vector of the hand held by a :class:`pairgrasp.GraspChecker`. Lengths are metres, angles
radians (the fine-tuning rotation bound is given in degrees, as ``angle_deg``).

* :func:`evaluate_grasp` closes the fingers onto contact (GraspIt's "auto grasp",
  :meth:`GraspChecker.close`), checks penetration, pruning and contacts at the closed DOFs, and
  computes the Ferrari-Canny epsilon of the contacts on free faces (:func:`pairgrasp.grasp_quality`).
  A pruned grasp (penetrating, touching an obstacle or an occluded face) is not scored: epsilon 0,
  ``force_closure`` False, and the check's reason.
* :func:`fine_tune` searches around a grasp: it perturbs the wrist pose (a translation within
  ``translation`` -- by default half a unit facet, ``facet_size / 2`` -- and a rotation of at most
  ``angle_deg`` about a random axis through the centre of the starting contacts) and the DOF values
  (within half the sampling step, clamped to the limits), closes again, re-checks, and keeps the best
  epsilon. It never returns a pruned grasp, and is deterministic for a given seed.

The torque origin and scale of epsilon default to the target's centre of mass and its largest vertex
distance from it (the checker's target).
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from typing import Optional, Tuple

import numpy as np

from .quality import grasp_quality

__all__ = ["GraspEvaluation", "FineTuneResult", "evaluate_grasp", "fine_tune", "reduce_contacts", "torque_reference"]

# Same tolerance as the C++ rigidity check (collision.cpp check_rigid): max |R^T R - I|.
_RIGID_TOL = 1e-6


@dataclass(frozen=True, eq=False)
class GraspEvaluation:
    """A grasp closed onto contact, checked, and scored.

    Attributes:
        wrist_pose: (4,4) wrist pose in the target frame.
        dofs: (D,) DOF values evaluated (the closed values when the fingers were closed).
        pruned: the grasp is discarded (penetration beyond the tolerance, an obstacle collision, or
            a link touching occluded faces).
        depth: largest penetration depth over links, target and obstacles (m).
        target_depth: largest penetration depth into the target (m).
        reason: why the grasp is pruned ("" when it is kept).
        contact_points: (C,3) contact points on the hand's active surfaces, target frame (m).
        contact_normals: (C,3) unit outward target normals at the contacts.
        contact_links: (C,) names of the hand links making each contact.
        occluded_contacts: contacts found on occluded faces (not scored).
        epsilon: Ferrari-Canny epsilon (0 when pruned or not force-closure).
        volume: 6-D volume of the grasp wrench hull (0 when pruned).
        force_closure: the contacts are force-closure (False when pruned).
        quality_reason: why the grasp is not force-closure ("" when it is; "pruned: ..." when pruned).
        closing_reasons: why each DOF stopped closing ('contact', 'limit', 'blocked', 'fixed');
            empty when the fingers were not closed.
        start_dofs: (D,) DOF values before closing.
        check: the :class:`pairgrasp.CheckResult` at (wrist_pose, dofs).
        contacts: the :class:`pairgrasp.Contacts` at (wrist_pose, dofs).
    """

    wrist_pose: np.ndarray
    dofs: np.ndarray
    pruned: bool
    depth: float
    target_depth: float
    reason: str
    contact_points: np.ndarray
    contact_normals: np.ndarray
    contact_links: Tuple[str, ...]
    occluded_contacts: int
    epsilon: float
    volume: float
    force_closure: bool
    quality_reason: str
    closing_reasons: Tuple[str, ...]
    start_dofs: np.ndarray
    check: object = field(repr=False)
    contacts: object = field(repr=False)

    @property
    def n_contacts(self) -> int:
        """Number of contacts on free faces."""
        return int(self.contact_points.shape[0])

    def __repr__(self) -> str:
        return (f"GraspEvaluation(pruned={self.pruned}, epsilon={self.epsilon:.6g}, "
                f"force_closure={self.force_closure}, contacts={self.n_contacts}, depth={self.depth:.3g}, "
                f"dofs={np.array2string(self.dofs, precision=4)}"
                + (f", reason='{self.reason}'" if self.reason else "")
                + (f", quality_reason='{self.quality_reason}'" if self.quality_reason and not self.pruned else "")
                + ")")


@dataclass(frozen=True, eq=False)
class FineTuneResult:
    """Result of :func:`fine_tune`.

    Attributes:
        best: the best grasp found (highest epsilon, never pruned), or None when the start is
            pruned and no trial gave an unpruned grasp.
        start: the evaluation of the starting grasp (closed onto contact).
        trials: perturbed grasps evaluated.
        kept: trials that were not pruned.
        improvements: trials that replaced the best grasp so far.
        improved: the best grasp is a trial, strictly better than the start.
        reason: "" when ``best`` is set, else why nothing is returned.
    """

    best: Optional[GraspEvaluation]
    start: GraspEvaluation
    trials: int
    kept: int
    improvements: int
    improved: bool
    reason: str = ""

    @property
    def found(self) -> bool:
        """A non-pruned grasp was found (``best`` is not None)."""
        return self.best is not None

    @property
    def epsilon(self) -> float:
        """Epsilon of the best grasp (0 when none)."""
        return self.best.epsilon if self.best is not None else 0.0


# ---------------------------------------------------------------------------------------- inputs

def _pose(name: str, value) -> np.ndarray:
    try:
        m = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected a 4x4 array of numbers ({exc})") from None
    if m.shape != (4, 4):
        raise ValueError(f"{name}: expected a 4x4 array, got shape {m.shape}")
    if not np.isfinite(m).all():
        raise ValueError(f"{name}: not finite")
    if not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"{name}: last row must be 0 0 0 1")
    r = m[:3, :3]
    err = float(np.abs(r.T @ r - np.eye(3)).max())
    if err > _RIGID_TOL:
        raise ValueError(f"{name}: rotation is not orthonormal (|R^T R - I| = {err:.3g})")
    if np.linalg.det(r) < 0.0:
        raise ValueError(f"{name}: rotation is a reflection (determinant -1)")
    return m


def _dofs(name: str, value, hand) -> np.ndarray:
    try:
        q = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected numbers ({exc})") from None
    d = len(hand.dofs)
    if q.ndim != 1 or q.shape[0] != d:
        raise ValueError(f"{name}: expected {d} values, got {q.size if q.ndim == 1 else q.shape}")
    if not np.isfinite(q).all():
        raise ValueError(f"{name}: not finite")
    return q


def _real(name: str, value, *, low: float, strict: bool) -> float:
    ok = isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))
    if not ok:
        raise ValueError(f"{name}: expected a real number, got {value!r}")
    x = float(value)
    if not math.isfinite(x) or x < low or (strict and x == low):
        raise ValueError(f"{name}: expected a finite value {'>' if strict else '>='} {low:g}, got {x!r}")
    return x


def torque_reference(mesh) -> Tuple[np.ndarray, float]:
    """The default torque origin and scale of epsilon for a target mesh: its centre of mass (m) and
    the largest distance (m) of its vertices from it."""
    c = np.asarray(mesh.center_of_mass, dtype=float).reshape(3)
    v = np.asarray(mesh.vertices, dtype=float)
    r = float(np.linalg.norm(v - c, axis=1).max()) if v.size else 0.0
    if not np.isfinite(c).all() or not r > 0.0:
        raise ValueError("target: cannot derive the torque reference (centre of mass / vertex distance)")
    return c, r


def _reference(checker, center, radius):
    if center is None or radius is None:
        c0, r0 = torque_reference(checker.target)
        center = c0 if center is None else center
        radius = r0 if radius is None else radius
    return center, radius


# ---------------------------------------------------------------------------------------- evaluate

def reduce_contacts(points, links, per_link: int) -> np.ndarray:
    """Indices (sorted) of at most ``per_link`` contacts per link, spread by farthest-point sampling.

    A finger pressed on a surface reports a patch of many contacts; the wrench hull of the patch is
    dominated by its extreme points. Per link, the first kept contact is the one farthest from the
    link's contact centroid, each next one the farthest from those kept (ties: the lowest index).
    The hull of the kept contacts' wrenches lies inside the hull of all of them, so epsilon computed
    from them is a lower bound of the full epsilon and force closure is never claimed wrongly.
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    names = list(links)
    if len(names) != len(pts):
        raise ValueError(f"links: expected {len(pts)} names, got {len(names)}")
    if isinstance(per_link, bool) or not isinstance(per_link, (numbers.Integral, np.integer)) or per_link < 1:
        raise ValueError(f"per_link: expected an integer >= 1, got {per_link!r}")
    keep = []
    groups = {}
    for i, name in enumerate(names):
        groups.setdefault(name, []).append(i)
    for idx in groups.values():
        idx = np.asarray(idx)
        if len(idx) <= per_link:
            keep.extend(idx.tolist())
            continue
        p = pts[idx]
        d = ((p - p.mean(axis=0)) ** 2).sum(axis=1)
        sel = []
        for _ in range(per_link):
            j = int(np.argmax(d))
            sel.append(j)
            d = np.minimum(d, ((p - p[j]) ** 2).sum(axis=1))
            d[sel] = -1.0
        keep.extend(idx[sel].tolist())
    return np.array(sorted(keep), dtype=int)


def _evaluate(checker, wrist, q, center, radius, mu, edges, close, soft, torsion,
              per_link=None) -> GraspEvaluation:
    if close:
        cr = checker.close(wrist, q)
        dofs = np.array(cr.dofs, dtype=float)
        check = cr.check
        closing = tuple(cr.reasons)
    else:
        dofs = q.copy()
        check = checker.check(wrist, q)
        closing = ()
    contacts = checker.contacts(wrist, dofs)
    points = np.array(contacts.points)
    normals = np.array(contacts.normals)
    if check.pruned:
        eps, vol, fc, qreason = 0.0, 0.0, False, f"pruned: {check.reason}"
    else:
        if per_link is not None and len(points):
            k = reduce_contacts(points, contacts.link_names, per_link)
            qp, qn = points[k], normals[k]
        else:
            qp, qn = points, normals
        # Reduced contacts: a search, which needs no hull volume of a grasp that is not force-closure.
        gq = grasp_quality(qp, qn, center, radius, mu=mu, edges=edges, soft=soft, torsion=torsion,
                           open_volume=per_link is None)
        eps, vol, fc, qreason = float(gq.epsilon), float(gq.volume), bool(gq.force_closure), gq.reason
    wrist = wrist.copy()
    for a in (wrist, dofs, points, normals):
        a.setflags(write=False)
    start = q.copy()
    start.setflags(write=False)
    return GraspEvaluation(
        wrist_pose=wrist, dofs=dofs, pruned=bool(check.pruned), depth=float(check.depth),
        target_depth=float(check.target_depth), reason=check.reason, contact_points=points,
        contact_normals=normals, contact_links=tuple(contacts.link_names),
        occluded_contacts=int(contacts.occluded_count), epsilon=eps, volume=vol, force_closure=fc,
        quality_reason=qreason, closing_reasons=closing, start_dofs=start, check=check, contacts=contacts)


def evaluate_grasp(checker, wrist_pose, dofs, center=None, radius=None, mu=0.5, edges=8, close=True,
                   soft=False, torsion=None, contacts_per_link=None) -> GraspEvaluation:
    """Close, check and score one grasp.

    Args:
        checker: a :class:`pairgrasp.GraspChecker` (hand, target, free mask, obstacles).
        wrist_pose: (4,4) rigid wrist pose in the target frame.
        dofs: (D,) DOF values (radians / metres), within the hand's limits.
        center: torque origin (m); default the target's centre of mass.
        radius: torque scale (m); default the target's largest vertex distance from its centre of mass.
        mu, edges, soft, torsion: friction model, as :func:`pairgrasp.grasp_quality`.
        close: close the closing DOFs onto contact first (else evaluate ``dofs`` as given).
        contacts_per_link: score at most this many contacts per link (:func:`reduce_contacts`): a
            lower bound of epsilon, an order of magnitude faster on contact patches of ~100
            contacts, and no hull volume for a grasp that is not force-closure (0; ``open_volume``
            of :func:`pairgrasp.grasp_quality`). None: every contact. The evaluation still lists
            every contact.

    Returns:
        GraspEvaluation. A pruned grasp has epsilon 0, force_closure False, and the reason.

    Raises:
        ValueError: a wrist pose that is not a finite rigid 4x4 transform, a DOF vector of the wrong
            size, not finite or out of the limits, or bad quality parameters.
    """
    wrist = _pose("wrist_pose", wrist_pose)
    q = _dofs("dofs", dofs, checker.hand)
    center, radius = _reference(checker, center, radius)
    _per_link(contacts_per_link)
    return _evaluate(checker, wrist, q, center, radius, mu, edges, bool(close), soft, torsion, contacts_per_link)


def _per_link(value):
    if value is not None and (isinstance(value, bool) or not isinstance(value, (numbers.Integral, np.integer))
                              or value < 1):
        raise ValueError(f"contacts_per_link: expected None or an integer >= 1, got {value!r}")


# ---------------------------------------------------------------------------------------- fine-tune

def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' rotation matrix about a unit axis."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def _unit_vector(rng: np.random.Generator) -> np.ndarray:
    while True:
        v = rng.standard_normal(3)
        n = float(np.linalg.norm(v))
        if n > 1e-12:
            return v / n


def _better(a: GraspEvaluation, b: Optional[GraspEvaluation]) -> bool:
    """a strictly better than b: unpruned first, then force-closure, then epsilon, then volume."""
    if b is None:
        return not a.pruned
    if a.pruned:
        return False
    if b.pruned:
        return True
    return (a.force_closure, a.epsilon, a.volume) > (b.force_closure, b.epsilon, b.volume)


def fine_tune(checker, wrist_pose, dofs, step=None, facet_size=None, iterations=30, seed=0, angle_deg=3.0,
              translation=None, center=None, radius=None, mu=0.5, edges=8, soft=False,
              torsion=None, contacts_per_link=None) -> FineTuneResult:
    """Local random search around a grasp for a better epsilon.

    The start is closed onto contact and scored (:func:`evaluate_grasp`). Each of ``iterations``
    trials then draws, from ``numpy.random.default_rng(seed)``:

    * a translation uniform in the ball of radius ``translation`` (default ``facet_size / 2``: half a
      unit facet, the resolution of the alignment);
    * a rotation by an angle uniform in ``[-angle_deg, angle_deg]`` degrees about a uniformly random
      axis through the pivot, the centroid of the start's contacts (the wrist origin when it has
      none), so that the fingers move by about the translation, not by the lever of the palm;
    * DOF values uniform within ``step / 2`` of the starting (unclosed) ``dofs``, clamped to the limits;

    applies them to the *starting* grasp (the search stays within that neighbourhood), closes again,
    re-checks penetration and contacts, and keeps the best grasp: unpruned first, then
    force-closure, then the higher epsilon (then the larger hull volume), strictly better only, so
    ties keep the earlier grasp. The result is deterministic for a given seed.

    Args:
        checker: a :class:`pairgrasp.GraspChecker`.
        wrist_pose: (4,4) starting wrist pose in the target frame.
        dofs: (D,) starting DOF values.
        step: (D,) per-DOF sampling step (default: the hand's ``dof_step``); each DOF moves within
            half of it. A step of 0 keeps that DOF fixed.
        facet_size: unit-facet edge ``h`` (m); needed unless ``translation`` is given.
        iterations: number of trials (>= 0).
        seed: seed of the random generator.
        angle_deg: largest rotation of a trial (degrees, >= 0).
        translation: largest translation of a trial (m); default ``facet_size / 2``.
        center, radius, mu, edges, soft, torsion, contacts_per_link: as :func:`evaluate_grasp`.

    Returns:
        FineTuneResult: ``best`` (never pruned; None when the start is pruned and no trial was
        unpruned, with ``reason`` saying so), ``start``, ``trials``, ``kept`` (unpruned trials),
        ``improvements`` and ``improved``.

    Raises:
        ValueError: bad wrist pose, DOF vector, step, facet size, iterations, angle or translation.
    """
    hand = checker.hand
    wrist = _pose("wrist_pose", wrist_pose)
    q0 = _dofs("dofs", dofs, hand)
    d = q0.shape[0]
    if step is None:
        steps = np.asarray(hand.dof_step, dtype=float).reshape(-1)
    else:
        try:
            steps = np.array(step, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"step: expected numbers ({exc})") from None
        if steps.ndim == 0:
            steps = np.full(d, float(steps))
        if steps.ndim != 1 or steps.shape[0] != d:
            raise ValueError(f"step: expected {d} values, got shape {steps.shape}")
        if not np.isfinite(steps).all() or (steps < 0).any():
            raise ValueError("step: expected finite values >= 0")
    if translation is None:
        if facet_size is None:
            raise ValueError("facet_size: needed (the unit-facet edge h, metres) unless translation is given")
        translation = _real("facet_size", facet_size, low=0.0, strict=True) / 2.0
    else:
        if facet_size is not None:
            _real("facet_size", facet_size, low=0.0, strict=True)
        translation = _real("translation", translation, low=0.0, strict=False)
    if isinstance(iterations, bool) or not isinstance(iterations, (numbers.Integral, np.integer)) or iterations < 0:
        raise ValueError(f"iterations: expected an integer >= 0, got {iterations!r}")
    angle = math.radians(_real("angle_deg", angle_deg, low=0.0, strict=False))
    lower = np.asarray(hand.dof_lower, dtype=float)
    upper = np.asarray(hand.dof_upper, dtype=float)
    center, radius = _reference(checker, center, radius)
    # Validate the quality parameters once, before any trial (grasp_quality raises ValueError).
    grasp_quality(np.zeros((0, 3)), np.zeros((0, 3)), center, radius, mu=mu, edges=edges, soft=soft,
                  torsion=torsion)

    _per_link(contacts_per_link)
    start = _evaluate(checker, wrist, q0, center, radius, mu, edges, True, soft, torsion, contacts_per_link)
    pivot = start.contact_points.mean(axis=0) if start.n_contacts else wrist[:3, 3].copy()
    rng = np.random.default_rng(seed)
    best = None if start.pruned else start
    kept = improvements = 0
    for _ in range(int(iterations)):
        t = _unit_vector(rng) * translation * float(rng.random()) ** (1.0 / 3.0)
        r = _rotation(_unit_vector(rng), float(rng.uniform(-angle, angle)))
        q = np.clip(q0 + rng.uniform(-0.5, 0.5, size=d) * steps, lower, upper)
        w = np.eye(4)
        w[:3, :3] = r @ wrist[:3, :3]
        w[:3, 3] = r @ (wrist[:3, 3] - pivot) + pivot + t
        trial = _evaluate(checker, w, q, center, radius, mu, edges, True, soft, torsion, contacts_per_link)
        if not trial.pruned:
            kept += 1
        if _better(trial, best):
            best = trial
            improvements += 1
    reason = ""
    if best is None:
        reason = (f"start pruned ({start.reason}) and none of {int(iterations)} trials was unpruned")
    return FineTuneResult(best=best, start=start, trials=int(iterations), kept=kept, improvements=improvements,
                          improved=best is not None and best is not start and (start.pruned or _better(best, start)),
                          reason=reason)
