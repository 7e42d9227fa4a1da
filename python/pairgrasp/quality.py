"""Grasp quality: the wrench space of a set of contacts and its Ferrari-Canny epsilon (eq. 2-7).

Conventions (lengths in metres, angles in radians):

* ``normals`` are the target's OUTWARD surface normals at the contact points; a finger pushes along
  the inward normal ``n = -normal / |normal|``.
* Point contact with friction (the default): the Coulomb cone of friction coefficient ``mu`` is
  approximated by a pyramid of ``edges`` edges in GraspIt's convention, edge ``k`` being
  ``f_k = n + mu * t_k`` (unit normal component, not normalised), with ``t_k = cos(2 pi k / R) t1 +
  sin(2 pi k / R) t2``. The tangent basis is fixed by the normal alone: ``t1`` is the unit
  projection onto the tangent plane of the coordinate axis least aligned with ``n`` (the lowest
  index wins a tie), and ``t2 = n x t1``, so ``(t1, t2, n)`` is right-handed. Because the basis is a
  function of the normal and not of the whole grasp, the pyramid does not turn with a rigidly moved
  grasp; epsilon is invariant to rigid motion only to the pyramid's accuracy (better with more edges).
* Each edge gives the wrench ``[f; (p - c) x f / r]`` (eq. 4) with ``c`` the torque origin (the
  target's centre of mass) and ``r`` the torque scale (the target's largest vertex distance from
  ``c``), which makes forces and torques commensurate.
* Soft-finger contact (``soft=True``): the contact can also resist a moment about its normal. The
  moment bound is ``|m_n| <= torsion * f_n``, where ``torsion`` (metres) is the torsional friction
  radius (for a circular patch of radius ``a`` under uniform pressure it is ``2 mu a / 3``). The
  contact's force/moment set is the elliptic limit surface ``(f_t / mu)^2 + (m_n / torsion)^2 <=
  f_n^2``, sampled at latitudes: the equator is the pyramid above; the two poles are the pure
  torsion wrenches ``[n; ((p - c) x n +- torsion n) / r]``; ``soft_rings`` extra latitude rings
  ``phi_j = j (pi/2) / (soft_rings + 1)`` on each hemisphere add the edges
  ``[n + mu cos(phi_j) t_k; ((p - c) x f +- torsion sin(phi_j) n) / r]``. With ``soft_rings = 0``
  the model is the pyramid plus the two torsion wrenches per contact.
* Quality: the grasp wrench space is the convex hull of all contact wrenches (the L1 grasp, sum of
  the normal forces <= 1, eq. 3 and 5), computed in C++ by qhull's reentrant library (the qhull SciPy
  wraps, with SciPy's ConvexHull options; each call has its own qhull state, the GIL is released,
  so calls may run on several threads). The grasp
  is force-closure when the origin is strictly inside that hull (eq. 6), and epsilon is then the
  distance from the origin to the nearest hull facet (eq. 7); otherwise epsilon is 0.
* Cost: a 6-D hull of a few hundred wrenches has ~10^5-10^6 facets (seconds). Two reductions keep
  epsilon exact. (1) Contacts sharing a normal bit for bit (several contacts on one flat face of
  the target) have the same pyramid edges, and a contact's wrenches are affine in its point, so a
  contact inside the convex hull of the other contacts of its normal group adds only wrenches
  inside the hull: only the vertices of each group's point hull are kept (epsilon and volume
  unchanged). (2) When more than ``max_hull_wrenches`` wrenches remain, epsilon is found by an
  active set of wrenches S (every wrench of 4 spread contacts to start). Each facet f of hull(S),
  with unit normal a_f at distance d_f from the origin, bounds the whole set: its epsilon is at
  most U = min_f max_w a_f.w (a ball inside the whole hull stays within every half-space
  a_f.x <= max_w a_f.w) and at least L = min_f d_f = epsilon(S), S being a subset. When U = L
  epsilon is exact; otherwise the farthest wrench beyond each facet with d_f < U joins S and the
  hull is rebuilt. U <= 0 proves
  non-closure. The volume reported is then the hull volume of the final S, a lower bound
  (``volume_exact`` False). A full-rank hull that fails qhull's precision checks is built again
  from joggled input (qhull's ``QJ``). Patches of contacts, as fingers pressed on a surface make, need few
  of their wrenches in S (a 178-contact grasp of the flask: 58 ms against 2.1 s for the full hull);
  contacts spread evenly over a sphere need more (60 of them: 1.0 s against 1.7 s for the full hull).
* A wrench set that does not span the 6-D wrench space (two antipodal point contacts, frictionless
  or single-face contacts, fewer than 7 distinct wrenches) cannot be force-closure. It is detected
  from the singular values of the wrench set before qhull is called and is reported as an ordinary
  non-closure (``epsilon = 0`` and a ``reason``), not as an error. Only malformed input raises
  ``ValueError``, naming the argument.
* A cheap bound: :func:`epsilon_upper_bound` bounds epsilon from above without a hull (the support
  function of the wrench set along the coordinate axes and the right singular vectors, never above
  the smallest singular value), for callers that only want grasps beating a threshold.

The wrenches, the hull and epsilon are computed by the C++ library (``pairgrasp/quality.hpp``);
this module checks the arguments' Python types and returns :class:`GraspQuality`.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import asdict, dataclass, fields

import numpy as np

from . import _core

__all__ = ["GraspQuality", "grasp_quality", "wrench_matrix", "contact_frames", "epsilon_upper_bound",
           "force_resistance", "load_resistance", "LOAD_DIRECTIONS"]


@dataclass(frozen=True)
class GraspQuality:
    """Quality of a grasp: Ferrari-Canny epsilon of the L1 grasp wrench space and its volume.

    Attributes:
        epsilon: distance from the origin to the nearest facet of the wrench hull when the grasp is
            force-closure, else 0 (dimensionless: forces per unit total normal force, torques
            divided by the torque scale ``radius``).
        volume: 6-D volume of the wrench hull (0 when the wrench set does not span 6 dimensions).
        force_closure: the origin is strictly inside the wrench hull.
        n_contacts: number of contacts.
        n_wrenches: number of wrenches (rows of :func:`wrench_matrix`).
        rank: rank of the wrench set (6 when it spans the wrench space).
        reason: why the grasp is not force-closure ("" when it is).
        volume_exact: ``volume`` is the hull volume of every wrench; False when epsilon came from
            the active set (see the module notes), whose subset's volume is a lower bound.

    Also readable as a mapping (``q["epsilon"]``, ``q.as_dict()``) and by position in the field order
    above (``q[0]`` is epsilon, ``q[2]`` force_closure).
    """

    epsilon: float
    volume: float
    force_closure: bool
    n_contacts: int
    n_wrenches: int
    rank: int
    reason: str = ""
    volume_exact: bool = True

    def as_dict(self) -> dict:
        """The fields as a plain dict."""
        return asdict(self)

    def keys(self):
        """Field names, in order."""
        return [f.name for f in fields(self)]

    def __getitem__(self, key):
        if isinstance(key, str):
            if key not in self.keys():
                raise KeyError(key)
            return getattr(self, key)
        if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
            return getattr(self, self.keys()[key])
        raise TypeError(f"GraspQuality indices must be field names or integers, not {type(key).__name__}")

    def __len__(self) -> int:
        return len(fields(self))


# ---------------------------------------------------------------------------------------- inputs

def _float_array(name: str, value) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected numbers ({exc})") from None
    return arr


def _rows3(name: str, value) -> np.ndarray:
    arr = _float_array(name, value)
    if arr.size == 0 and arr.ndim <= 2 and (arr.ndim < 2 or arr.shape[1] in (0, 3)):
        return np.zeros((0, 3))
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name}: expected an (N, 3) array, got shape {arr.shape}")
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any():
        raise ValueError(f"{name}: row {int(np.flatnonzero(bad)[0])} is not finite")
    return arr


def _real(name: str, value, *, low: float, strict: bool) -> float:
    ok = isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))
    ok = ok or (isinstance(value, np.ndarray) and value.shape == () and value.dtype.kind in "iuf")
    if not ok:
        raise ValueError(f"{name}: expected a real number, got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{name}: expected a finite number, got {x}")
    if x < low or (strict and x == low):
        raise ValueError(f"{name}: expected a value {'>' if strict else '>='} {low:g}, got {x:g}")
    return x


def _count(name: str, value, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (numbers.Integral, np.integer)):
        raise ValueError(f"{name}: expected an integer >= {low}, got {value!r}")
    n = int(value)
    if n < low:
        raise ValueError(f"{name}: expected an integer >= {low}, got {n}")
    return n


def _check_inputs(points, normals, center, radius, mu, edges, soft, torsion, soft_rings):
    p = _rows3("points", points)
    n = _rows3("normals", normals)
    if len(n) != len(p):
        raise ValueError(f"normals: expected {len(p)} rows to match points, got {len(n)}")
    length = np.linalg.norm(n, axis=1)
    short = length < 1e-30
    if short.any():
        raise ValueError(f"normals: row {int(np.flatnonzero(short)[0])} has zero length")
    c = _float_array("center", center)
    if c.size != 3:
        raise ValueError(f"center: expected 3 values, got shape {c.shape}")
    c = c.reshape(3)
    if not np.isfinite(c).all():
        raise ValueError("center: not finite")
    radius = _real("radius", radius, low=0.0, strict=True)
    mu = _real("mu", mu, low=0.0, strict=False)
    edges = _count("edges", edges, 3)
    if not isinstance(soft, (bool, np.bool_)):
        raise ValueError(f"soft: expected True or False, got {soft!r}")
    soft_rings = _count("soft_rings", soft_rings, 0)
    if torsion is not None:
        torsion = _real("torsion", torsion, low=0.0, strict=False)
    elif soft:
        raise ValueError("torsion: soft=True needs the torsional friction radius in metres "
                         "(moment about the normal <= torsion * normal force)")
    return p, n, c, radius, mu, edges, bool(soft), torsion, soft_rings


# --------------------------------------------------------------------------------------- wrenches

def contact_frames(normals):
    """Contact frames used for the friction pyramids.

    Args:
        normals: (N, 3) outward normals of the target at the contacts (any non-zero length).

    Returns:
        (N, 3, 3) array; row ``i`` holds ``[t1, t2, n]`` with ``n`` the unit inward normal and
        ``t1, t2`` the tangent basis (edge ``k`` of the pyramid is ``n + mu (cos(2 pi k/R) t1 +
        sin(2 pi k/R) t2)``).
    """
    n = _rows3("normals", normals)
    short = np.linalg.norm(n, axis=1) < 1e-30
    if short.any():
        raise ValueError(f"normals: row {int(np.flatnonzero(short)[0])} has zero length")
    return _core._contact_frames(n)


def _model(args):
    """The C++ keyword arguments of the checked inputs ``args`` (points, outward normals, ...)."""
    p, n, c, radius, mu, edges, soft, torsion, soft_rings = args
    return dict(points=p, normals=n, center=c, radius=radius, mu=mu, edges=edges, soft=soft,
                torsion=torsion, soft_rings=soft_rings)


def wrench_matrix(points, normals, center, radius, mu=0.5, edges=8, soft=False, torsion=None,
                  soft_rings=0) -> np.ndarray:
    """Contact wrenches of a grasp, one row per friction-pyramid edge (eq. 4).

    Args:
        points: (N, 3) contact points on the target (m).
        normals: (N, 3) OUTWARD target normals at the contacts (any non-zero length; normalised).
        center: torque origin ``c``, usually the target's centre of mass (m).
        radius: torque scale ``r`` > 0, usually the target's largest vertex distance from ``c`` (m).
        mu: Coulomb friction coefficient >= 0.
        edges: number of pyramid edges R >= 3.
        soft: soft-finger contacts (torsional friction about each normal).
        torsion: torsional friction radius (m), the moment bound ``|m_n| <= torsion * f_n``;
            required when ``soft`` is true, ignored otherwise.
        soft_rings: latitude rings of the elliptic limit surface between the equator and each pole
            (soft contacts only; 0 means the pyramid plus the two pure-torsion wrenches).

    Returns:
        (N * D, 6) array ``[f; tau / r]``; rows ``i*D .. i*D + D - 1`` belong to contact ``i``, with
        ``D = edges`` for point contacts and ``D = edges * (1 + 2 * soft_rings) + 2`` for soft ones,
        ordered: the pyramid edges ``k = 0..R-1``, then for each ring ``j`` its edges with the
        positive and then the negative moment, then the two poles (+torsion, -torsion).

    Raises:
        ValueError: malformed input (shapes, NaN/inf, zero-length normals, radius <= 0, mu < 0,
            edges < 3, torsion < 0 or missing for soft contacts), naming the argument.
    """
    args = _check_inputs(points, normals, center, radius, mu, edges, soft, torsion, soft_rings)
    return _core.contact_wrenches(**_model(args))


def epsilon_upper_bound(points, normals, center, radius, mu=0.5, edges=8, soft=False, torsion=None,
                        soft_rings=0) -> float:
    """An upper bound of the grasp's epsilon that needs no hull (O(number of wrenches)).

    For any unit direction v, a ball of radius epsilon inside the wrench hull stays within the
    half-space ``v . x <= max_w v . w``; the bound is the smallest such support value over the 12
    directions +-e_k and the 12 directions +-v_k of the wrench matrix's right singular vectors,
    clamped to >= 0, so it never exceeds the smallest singular value. A grasp whose bound is below
    a threshold cannot reach it, and :func:`grasp_quality` need not be called. Arguments as
    :func:`wrench_matrix`; 0 for no contacts.
    """
    args = _check_inputs(points, normals, center, radius, mu, edges, soft, torsion, soft_rings)
    return float(_core._epsilon_upper_bound(_core.contact_wrenches(**_model(args))))


#: The six load directions of the physics check (+x, +y, +z, -x, -y, -z of the target frame), along
#: which gravity is turned while the hand holds the object (docs/physics.md).
LOAD_DIRECTIONS = np.asarray(_core._load_directions())


def force_resistance(points, normals, center, radius, directions=None, mu=0.5, edges=8, soft=False, torsion=None,
                     soft_rings=0) -> np.ndarray:
    """The largest pure force at ``center`` along each direction that the grasp's contacts can exert.

    For each unit direction ``d`` (rows of ``directions``, (K, 3), target frame; None:
    :data:`LOAD_DIRECTIONS`), the largest ``t`` such that the wrench ``(t d, 0)`` lies in the grasp
    wrench space of :func:`grasp_quality` (the L1 hull of every contact wrench), per unit total
    normal force. With the centre of mass as ``center`` these are the loads of gravity and of the
    hand's accelerations; epsilon asks for every wrench, this for the ones such loads make. Each
    value is at least epsilon; all are 0 when the grasp is not force-closure. Computed in C++
    without a hull (Wolfe's minimum-norm point, cutting planes along the ray), to about 1e-6
    relative. Other arguments as :func:`wrench_matrix`.

    Raises:
        ValueError: malformed input, naming the argument, or a direction that is not a finite unit
            vector.
    """
    args = _check_inputs(points, normals, center, radius, mu, edges, soft, torsion, soft_rings)
    return np.asarray(_core._force_resistance(**_model(args), directions=directions))


def load_resistance(points, normals, center, radius, mu=0.5, edges=8, soft=False, torsion=None,
                    soft_rings=0) -> float:
    """The least :func:`force_resistance` along the six :data:`LOAD_DIRECTIONS`: the load a grasp
    resists worst while the object is turned through every orientation. The ``load`` ranking leads
    with the grasp for which it is largest. 0 when not force-closure."""
    return float(force_resistance(points, normals, center, radius, None, mu, edges, soft, torsion, soft_rings).min())


# ---------------------------------------------------------------------------------------- quality

def grasp_quality(points, normals, center, radius, mu=0.5, edges=8, soft=False, torsion=None,
                  soft_rings=0, max_hull_wrenches: int = 320, open_volume: bool = True,
                  volume: bool = True) -> GraspQuality:
    """Ferrari-Canny epsilon (L1) and hull volume of a grasp given by its contacts (eq. 2-7).

    Args: as :func:`wrench_matrix` (points, OUTWARD normals, torque origin ``center``, torque scale
    ``radius``, friction ``mu``, pyramid ``edges``, ``soft`` contacts with ``torsion`` radius and
    ``soft_rings``), and ``max_hull_wrenches``: above this many wrenches (after dropping the
    contacts inside their normal group, which changes nothing), epsilon is computed exactly by the
    active set of the module notes and the volume is a lower bound. ``open_volume=False``: the
    hull volume of a grasp that is not force-closure is not wanted, so a grasp whose wrenches a
    hyperplane through the origin separates from it (Gilbert's minimum-norm iteration) is ruled
    out first, without the hull (volume 0, ``volume_exact`` False); force-closure results are
    unchanged. ``volume=False``: no hull volume at all (0, ``volume_exact`` False), epsilon and force
    closure unchanged; in 6-D the volume costs several times the hull itself.

    Returns:
        :class:`GraspQuality`. A grasp whose wrenches do not span the wrench space (e.g. two point
        contacts, frictionless or single-face contacts) is an ordinary non-closure: ``epsilon = 0``,
        ``force_closure = False`` and ``reason`` says why; it is not an error.

    Raises:
        ValueError: malformed input, naming the argument (see :func:`wrench_matrix`).
    """
    args = _check_inputs(points, normals, center, radius, mu, edges, soft, torsion, soft_rings)
    max_hull_wrenches = _count("max_hull_wrenches", max_hull_wrenches, 7)
    return GraspQuality(*_core._grasp_quality(**_model(args), max_hull_wrenches=max_hull_wrenches,
                                              open_volume=bool(open_volume), volume=bool(volume)))
