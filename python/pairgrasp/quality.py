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
  the normal forces <= 1, eq. 3 and 5), computed by qhull (``scipy.spatial.ConvexHull``). The grasp
  is force-closure when the origin is strictly inside that hull (eq. 6), and epsilon is then the
  distance from the origin to the nearest hull facet (eq. 7); otherwise epsilon is 0.
* Cost: a 6-D hull of a few hundred wrenches has ~10^5-10^6 facets (seconds). Two reductions keep
  epsilon exact. (1) Contacts sharing a normal bit for bit (several contacts on one flat face of
  the target) have the same pyramid edges, and a contact's wrenches are affine in its point, so a
  contact inside the convex hull of the other contacts of its normal group adds only wrenches
  inside the hull: only the vertices of each group's point hull are kept (epsilon and volume
  unchanged). (2) When more than ``max_hull_wrenches`` wrenches remain, epsilon is found by an
  active set of contacts S. Each facet f of hull(S), with unit normal a_f at distance d_f from the
  origin, bounds the whole set: its epsilon is at most U = min_f max_w a_f.w (a ball inside the
  whole hull stays within every half-space a_f.x <= max_w a_f.w) and at least L = min_f d_f =
  epsilon(S), S being a subset. When U = L epsilon is exact; otherwise the contact of the farthest
  wrench beyond each facet with d_f < U joins S and the hull is rebuilt. U <= 0 proves
  non-closure. The volume reported is then the hull volume of the final S, a lower bound
  (``volume_exact`` False). Patches of contacts, as fingers pressed on a surface make, need few
  of their contacts in S (the flask's 80-contact grasp: 16 contacts, 6x faster than the full hull);
  contacts spread evenly over a sphere need most of them, at up to twice the full hull's cost.
* A wrench set that does not span the 6-D wrench space (two antipodal point contacts, frictionless
  or single-face contacts, fewer than 7 distinct wrenches) cannot be force-closure. It is detected
  from the singular values of the wrench set before qhull is called and is reported as an ordinary
  non-closure (``epsilon = 0`` and a ``reason``), not as an error. Only malformed input raises
  ``ValueError``, naming the argument.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import asdict, dataclass, fields

import numpy as np
from scipy.spatial import ConvexHull, QhullError

__all__ = ["GraspQuality", "grasp_quality", "wrench_matrix", "contact_frames"]

# Relative tolerance on singular values and on the origin's facet distance: a wrench set whose
# smallest singular value is below _RTOL times its largest is rank-deficient, and an origin closer
# than _RTOL times the largest wrench norm to a facet counts as on the boundary. (For a unit
# direction v, max_i |v . w_i| <= |W v|, so epsilon never exceeds the smallest singular value:
# both tests declare the same near-degenerate grasps non-closure.)
_RTOL = 1e-9


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
    return p, -n / length[:, None], c, radius, mu, edges, bool(soft), torsion, soft_rings


# --------------------------------------------------------------------------------------- wrenches

def _frames(n_in: np.ndarray):
    """Tangent basis (t1, t2) of unit inward normals n_in (N, 3); see the module docstring."""
    axis = np.argmin(np.abs(n_in), axis=1)             # lowest index wins a tie
    e = np.zeros_like(n_in)
    e[np.arange(len(n_in)), axis] = 1.0
    t1 = e - np.sum(e * n_in, axis=1, keepdims=True) * n_in
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)    # |t1| >= sqrt(2/3) before normalising
    t2 = np.cross(n_in, t1)
    return t1, t2


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
    length = np.linalg.norm(n, axis=1)
    if (length < 1e-30).any():
        raise ValueError(f"normals: row {int(np.flatnonzero(length < 1e-30)[0])} has zero length")
    n_in = -n / length[:, None]
    t1, t2 = _frames(n_in)
    return np.stack([t1, t2, n_in], axis=1)


def _local_directions(mu, edges, soft, torsion, soft_rings):
    """(D, 3) coefficients (along t1, along t2, moment about n) of each contact's wrench directions."""
    theta = 2.0 * np.pi * np.arange(edges) / edges
    ring = np.stack([np.cos(theta), np.sin(theta), np.zeros(edges)], axis=1)
    rows = [mu * ring]
    if soft:
        for j in range(1, soft_rings + 1):
            phi = 0.5 * np.pi * j / (soft_rings + 1)
            for sign in (1.0, -1.0):
                r = mu * math.cos(phi) * ring
                r[:, 2] = sign * torsion * math.sin(phi)
                rows.append(r)
        rows.append(np.array([[0.0, 0.0, torsion], [0.0, 0.0, -torsion]]))
    return np.concatenate(rows, axis=0)


def _wrenches(p, n_in, c, radius, mu, edges, soft, torsion, soft_rings):
    if len(p) == 0:
        return np.zeros((0, 6))
    t1, t2 = _frames(n_in)
    d = _local_directions(mu, edges, soft, torsion, soft_rings)            # (D, 3)
    f = (n_in[:, None, :] + d[None, :, 0:1] * t1[:, None, :]
         + d[None, :, 1:2] * t2[:, None, :])                                # (N, D, 3)
    arm = (p - c)[:, None, :]
    tau = np.cross(arm, f) + d[None, :, 2:3] * n_in[:, None, :]
    return np.concatenate([f, tau / radius], axis=2).reshape(-1, 6)


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
    return _wrenches(*args)


# ---------------------------------------------------------------------------------------- quality

def _not_closure(n_contacts, n_wrenches, rank, reason, volume=0.0):
    return GraspQuality(epsilon=0.0, volume=float(volume), force_closure=False,
                        n_contacts=int(n_contacts), n_wrenches=int(n_wrenches), rank=int(rank),
                        reason=reason)


def grasp_quality(points, normals, center, radius, mu=0.5, edges=8, soft=False, torsion=None,
                  soft_rings=0, max_hull_wrenches: int = 320, open_volume: bool = True) -> GraspQuality:
    """Ferrari-Canny epsilon (L1) and hull volume of a grasp given by its contacts (eq. 2-7).

    Args: as :func:`wrench_matrix` (points, OUTWARD normals, torque origin ``center``, torque scale
    ``radius``, friction ``mu``, pyramid ``edges``, ``soft`` contacts with ``torsion`` radius and
    ``soft_rings``), and ``max_hull_wrenches``: above this many wrenches (after dropping the
    contacts inside their normal group, which changes nothing), epsilon is computed exactly by the
    active set of the module notes and the volume is a lower bound. ``open_volume=False``: the
    hull volume of a grasp that is not force-closure is not wanted, so a linear program (is the
    origin a convex combination of the wrenches?) rules such grasps out first, without the hull
    (volume 0, ``volume_exact`` False); force-closure results are unchanged.

    Returns:
        :class:`GraspQuality`. A grasp whose wrenches do not span the wrench space (e.g. two point
        contacts, frictionless or single-face contacts) is an ordinary non-closure: ``epsilon = 0``,
        ``force_closure = False`` and ``reason`` says why; it is not an error.

    Raises:
        ValueError: malformed input, naming the argument (see :func:`wrench_matrix`).
    """
    args = _check_inputs(points, normals, center, radius, mu, edges, soft, torsion, soft_rings)
    _count("max_hull_wrenches", max_hull_wrenches, 7)
    p, n_in = args[0], args[1]
    n_contacts = len(p)
    if n_contacts == 0:
        return _not_closure(0, 0, 0, "no contacts")
    per_contact = len(_local_directions(*args[4:]))
    n_wrenches = n_contacts * per_contact
    keep = _group_hull_vertices(p, n_in)
    w = _wrenches(p[keep], n_in[keep], *args[2:]).reshape(len(keep), per_contact, 6)
    flat = w.reshape(-1, 6)
    s = np.linalg.svd(np.unique(flat, axis=0), compute_uv=False)
    tol = _RTOL * s[0]
    rank = int(np.count_nonzero(s > tol))
    if rank < 6:
        return _not_closure(n_contacts, n_wrenches, rank,
                            f"rank-deficient wrench set (rank {rank} < 6): the contacts cannot "
                            f"resist every wrench")
    boundary_tol = _RTOL * float(np.linalg.norm(flat, axis=1).max())
    if not open_volume and not _origin_in_hull(flat):
        return GraspQuality(epsilon=0.0, volume=0.0, force_closure=False, n_contacts=n_contacts,
                            n_wrenches=n_wrenches, rank=rank, reason="the origin is outside the wrench hull",
                            volume_exact=False)
    if len(flat) <= max_hull_wrenches:
        out = _hull_quality(flat, tol, boundary_tol)[:3] + (True,)
    else:
        out = _active_set_quality(w, p[keep], n_in[keep], float(args[3]), tol, boundary_tol)
    eps, volume, reason, exact = out
    if reason:
        return GraspQuality(epsilon=0.0, volume=float(volume), force_closure=False, n_contacts=n_contacts,
                            n_wrenches=n_wrenches, rank=rank, reason=reason, volume_exact=exact)
    return GraspQuality(epsilon=eps, volume=float(volume), force_closure=True, n_contacts=n_contacts,
                        n_wrenches=n_wrenches, rank=rank, reason="", volume_exact=exact)


def _origin_in_hull(w: np.ndarray) -> bool:
    """Whether the origin is a convex combination of the rows of ``w`` (an LP feasibility problem:
    lambda >= 0, sum lambda = 1, w^T lambda = 0). Only an infeasible answer is used, to skip the
    hull; on the boundary or when the solver is unsure it answers True and the hull decides."""
    from scipy.optimize import linprog

    n = len(w)
    a_eq = np.vstack([w.T, np.ones((1, n))])
    b_eq = np.zeros(7)
    b_eq[6] = 1.0
    res = linprog(np.zeros(n), A_eq=a_eq, b_eq=b_eq, bounds=(0, None), method="highs")
    return res.status != 2                        # 2: infeasible


def _group_hull_vertices(p: np.ndarray, n_in: np.ndarray) -> np.ndarray:
    """Indices of the contacts to keep: for each group of contacts whose normals are equal bit for
    bit, the vertices of the convex hull of the group's points (in the group's affine span); the
    others' wrenches are convex combinations of the kept ones' (module notes)."""
    _, group = np.unique(np.ascontiguousarray(n_in).view(np.dtype((np.void, 24))).ravel(), return_inverse=True)
    keep = []
    for g in range(int(group.max()) + 1):
        idx = np.flatnonzero(group == g)
        if len(idx) <= 2:
            keep.extend(idx.tolist())
            continue
        q = p[idx] - p[idx].mean(axis=0)
        _, sv, vt = np.linalg.svd(q, full_matrices=False)
        dim = int(np.count_nonzero(sv > 1e-9 * max(sv[0], 1e-300)))
        if dim == 0:
            keep.append(int(idx[0]))                  # every point the same
            continue
        y = q @ vt[:dim].T
        if dim == 1:
            keep.extend(idx[[int(np.argmin(y[:, 0])), int(np.argmax(y[:, 0]))]].tolist())
            continue
        try:
            keep.extend(idx[ConvexHull(y).vertices].tolist())
        except QhullError:                            # numerically flatter than the SVD said: keep all
            keep.extend(idx.tolist())
    return np.array(sorted(set(keep)), dtype=int)


def _hull_quality(u: np.ndarray, tol: float, boundary_tol: float):
    """(epsilon, volume, reason, equations) of the hull of the wrenches ``u`` (rank 6); ``equations``
    are qhull's facet planes (F, 7): unit outward normal a and offset b, a . x + b <= 0 inside; None
    when there is no 6-D hull."""
    u = np.unique(u, axis=0)                      # frictionless edges coincide exactly
    if len(u) < 7:
        return 0.0, 0.0, (f"only {len(u)} distinct wrenches: the origin cannot be inside a 6-D hull "
                          f"of fewer than 7 points"), None
    sa = np.linalg.svd(u - u.mean(axis=0), compute_uv=False)
    affine_rank = int(np.count_nonzero(sa > tol))
    if affine_rank < 6:
        return 0.0, 0.0, f"the wrenches lie in a {affine_rank}-D affine subspace that misses the origin", None
    try:
        hull = ConvexHull(u)
    except QhullError:
        # Nearly coplanar wrenches (contacts a rounding error off a pad's edge) can make qhull's
        # final precision check fail on a full-rank hull; joggled input (random moves of about
        # 1e-11 of the coordinates) has no such facets and changes epsilon by as little.
        try:
            hull = ConvexHull(u, qhull_options="QJ")
        except QhullError as exc:                 # numerically flat despite the rank tests
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else "QhullError"
            return 0.0, 0.0, f"degenerate wrench hull (qhull: {first})", None
    # equations: unit outward normal a and offset b with a . x + b <= 0 inside; the origin's
    # distance to facet j is -b_j when it lies inside every facet.
    distance = float(-hull.equations[:, -1].max())
    if distance > boundary_tol:
        return distance, float(hull.volume), "", hull.equations
    where = "outside" if distance < -boundary_tol else "on the boundary of"
    return 0.0, float(hull.volume), f"the origin is {where} the wrench hull", hull.equations


def _active_set_quality(w: np.ndarray, p: np.ndarray, n_in: np.ndarray, radius: float, tol: float,
                        boundary_tol: float, start: int = 12, chunk: int = 4096):
    """Exact epsilon of the hull of every wrench ``w`` (N, D, 6) from hulls of growing subsets S of
    the contacts (module notes). S starts with ``start`` contacts spread by farthest-point sampling
    over (point / radius, normal). Each facet f of hull(S) (unit normal a_f, offset d_f from the
    origin) bounds the whole set's epsilon: epsilon <= U = min_f max_w a_f . w, while epsilon(S) =
    L = min_f d_f is a lower bound. When U <= L the two meet; otherwise every facet with d_f < U is
    one the whole hull reaches beyond, and the contact of its farthest wrench joins S."""
    n = len(w)
    flat = w.reshape(-1, 6)
    per = w.shape[1]
    coords = np.concatenate([p / radius, n_in], axis=1)
    dist = np.linalg.norm(coords - coords[0], axis=1)
    in_set = np.zeros(n, bool)
    in_set[0] = True
    while in_set.sum() < min(start, n):
        k = int(np.argmax(dist))
        in_set[k] = True
        dist = np.minimum(dist, np.linalg.norm(coords - coords[k], axis=1))
    while True:
        sub = w[in_set].reshape(-1, 6)
        eps, volume, reason, facet = _hull_quality(sub, tol, boundary_tol)
        if in_set.all():
            return eps, volume, reason, True
        if facet is None:                         # the subset does not span 6-D: widen it
            far = np.linalg.norm(coords[:, None, :] - coords[in_set][None, :, :], axis=2).min(axis=1)
            far[in_set] = -1.0
            in_set[np.argsort(-far, kind="stable")[:start]] = True
            continue
        eq = facet                                # every facet: (F, 7), a . x + b <= 0 inside
        d = -eq[:, -1]
        order = np.argsort(d, kind="stable")
        lower = float(d[order[0]])
        upper = np.inf
        add = set()
        for c0 in range(0, len(order), chunk):
            idx = order[c0:c0 + chunk]
            if d[idx[0]] >= upper - boundary_tol:
                break
            proj = flat @ eq[idx, :6].T           # (N*D, k)
            best = proj.argmax(axis=0)
            reach = proj[best, np.arange(len(idx))]
            upper = min(upper, float(reach.min()))
            relevant = d[idx] < upper - boundary_tol
            add.update((best[relevant] // per).tolist())
        if upper <= boundary_tol:                 # a direction no wrench reaches beyond the origin
            where = "outside" if upper < -boundary_tol else "on the boundary of"
            return 0.0, volume, reason or f"the origin is {where} the wrench hull", False
        if upper <= lower + boundary_tol:         # the bounds meet: epsilon(S) is the whole set's
            return eps, volume, reason, False
        new = [k for k in add if not in_set[k]]
        if not new:                               # cannot happen in exact arithmetic; be safe
            in_set[:] = True
            continue
        in_set[new] = True
