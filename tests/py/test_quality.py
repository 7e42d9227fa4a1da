"""Grasp quality (Ferrari-Canny epsilon, eq. 2-7) against independent computations.

The library computes epsilon in C++ with qhull's reentrant library. The independent references
here are wrenches built one by one in NumPy from the documented convention, a brute-force
enumeration of the supporting hyperplanes through every 6 wrenches, the support function
h(u) = max_w u.w of the wrench set (whose minimum over unit directions u is epsilon when the origin
is inside the hull), a linear program for "the wrenches positively span R^6" (force closure), a
closed form derived on paper for two antipodal soft-finger contacts, and SciPy's ConvexHull of the
NumPy wrenches (the oracle for larger sets).
"""
import itertools
import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from scipy.optimize import linprog, minimize
from scipy.spatial import ConvexHull

import pairgrasp as pg
import independent
from independent import reference_wrenches, tangent_basis

ORIGIN = np.zeros(3)


# ------------------------------------------------------------------------ independent references

def brute_force_hull(W, tol=1e-9):
    """(epsilon, volume) of conv(W) by enumerating every 6 wrenches: a hyperplane {x: u.x = 1}
    through 6 of them that keeps all the others on the origin's side is a facet at distance 1/|u|,
    and (for simplicial facets) the hull is the union of the cones from the origin over them.
    Valid only when the origin is strictly inside."""
    W = np.unique(W, axis=0)
    subsets = np.array(list(itertools.combinations(range(len(W)), 6)))
    A = W[subsets]                                                # (S, 6, 6)
    det = np.linalg.det(A)
    ok = np.abs(det) > 1e-12
    u = np.linalg.solve(A[ok], np.ones((int(ok.sum()), 6, 1)))[..., 0]
    supporting = (u @ W.T).max(axis=1) <= 1 + tol
    eps = 1.0 / np.linalg.norm(u[supporting], axis=1).max()
    volume = np.abs(det[ok][supporting]).sum() / math.factorial(6)
    return eps, volume


def support_min(W, rng, n_dirs=4000, n_polish=16):
    """Smallest support value h(u) = max_w u.w found over random unit directions, each of the best
    ones polished by SLSQP on min t s.t. u.w <= t, |u| = 1. Every value is an upper bound of
    epsilon; the polished minimum reaches it when a start lies in the nearest facet's basin."""
    U = rng.normal(size=(n_dirs, 6))
    U /= np.linalg.norm(U, axis=1, keepdims=True)
    H = (U @ W.T).max(axis=1)
    values = [H.min()]
    cons = [dict(type="ineq", fun=lambda x: x[6] - W @ x[:6],
                 jac=lambda x: np.c_[-W, np.ones(len(W))]),
            dict(type="eq", fun=lambda x: x[:6] @ x[:6] - 1.0, jac=lambda x: np.r_[2 * x[:6], 0.0])]
    for j in np.argsort(H)[:n_polish]:
        res = minimize(lambda x: x[6], np.r_[U[j], H[j]], jac=lambda x: np.r_[np.zeros(6), 1.0],
                       constraints=cons, method="SLSQP", options=dict(ftol=1e-14, maxiter=300))
        u = res.x[:6] / np.linalg.norm(res.x[:6])
        values.append((W @ u).max())
    return min(values), H.min()


def lp_force_closure(W):
    """Force closure iff the wrenches span R^6 and some strictly positive combination of them is
    zero: maximise s subject to sum a_i w_i = 0, sum a_i = 1, a_i >= s."""
    if np.linalg.matrix_rank(W, tol=1e-9 * np.linalg.norm(W, 2)) < 6:
        return False
    m = len(W)
    c = np.zeros(m + 1)
    c[-1] = -1.0                                            # maximise s
    A_eq = np.zeros((7, m + 1))
    A_eq[:6, :m] = W.T
    A_eq[6, :m] = 1.0
    b_eq = np.r_[np.zeros(6), 1.0]
    A_ub = np.c_[-np.eye(m), np.ones(m)]                    # s - a_i <= 0
    res = linprog(c, A_ub=A_ub, b_ub=np.zeros(m), A_eq=A_eq, b_eq=b_eq,
                  bounds=[(0, None)] * m + [(None, None)], method="highs")
    if res.status == 2:                                      # 0 is not even in the hull
        return False
    assert res.status == 0, res.message
    return -res.fun > 1e-9 / m


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def sphere_grasp(rng, m, radius=0.03, scatter=0.0):
    """m contacts on a sphere, normals radial (optionally tilted) and of random length."""
    d = rng.normal(size=(m, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    n = d + scatter * rng.normal(size=(m, 3))
    return radius * d, n * rng.uniform(0.3, 3.0, size=(m, 1))


def box_grasp(rng, m, half=(0.05, 0.03, 0.02)):
    """m contacts on random faces of a box centred at the origin, outward face normals."""
    half = np.asarray(half)
    P, N = [], []
    for _ in range(m):
        axis, sign = int(rng.integers(3)), float(rng.choice([-1.0, 1.0]))
        p = rng.uniform(-half, half)
        p[axis] = sign * half[axis]
        n = np.zeros(3)
        n[axis] = sign
        P.append(p)
        N.append(n)
    return np.array(P), np.array(N), float(np.linalg.norm(half))


# ---------------------------------------------------------------------------------- wrench matrix

def test_wrench_matrix_follows_the_pyramid_convention():
    rng = np.random.default_rng(1)
    P, N = sphere_grasp(rng, 5, scatter=0.4)
    c, r, mu, R = np.array([0.001, -0.002, 0.003]), 0.04, 0.7, 7
    W = pg.wrench_matrix(P, N, c, r, mu=mu, edges=R)
    assert W.shape == (5 * R, 6)
    for i in range(5):
        n_in = -N[i] / np.linalg.norm(N[i])
        rows = W[i * R:(i + 1) * R]
        f = rows[:, :3]
        assert np.allclose(f @ n_in, 1.0)                          # unit normal component
        tang = f - n_in
        assert np.allclose(np.linalg.norm(tang, axis=1), mu)       # friction mu, not normalised
        # first edge leans toward the coordinate axis least aligned with the normal
        axis = np.eye(3)[np.argmin(np.abs(n_in))]
        assert tang[0] @ axis > 0 and np.allclose(np.cross(tang[0], axis - (axis @ n_in) * n_in), 0)
        for k in range(R):                                         # evenly spaced, counter-clockwise
            cos = tang[k] @ tang[0] / mu ** 2
            sin = np.cross(tang[0], tang[k]) @ n_in / mu ** 2
            assert math.isclose(math.atan2(sin, cos) % (2 * math.pi), 2 * math.pi * k / R % (2 * math.pi),
                                abs_tol=1e-12)
        assert np.allclose(rows[:, 3:], np.cross(P[i] - c, f) / r)
    assert np.allclose(W, reference_wrenches(P, N, c, r, mu, R), atol=1e-14)


def test_contact_frames_are_right_handed_with_the_inward_normal():
    rng = np.random.default_rng(13)
    N = np.vstack([rng.normal(size=(20, 3)) * rng.uniform(0.01, 10, size=(20, 1)),
                   np.eye(3), -np.eye(3), [[1.0, 1.0, 0.0], [0.0, -2.0, 2.0]]])   # ties included
    F = pg.contact_frames(N)
    assert F.shape == (len(N), 3, 3)
    for n, frame in zip(N, F):
        assert np.allclose(frame @ frame.T, np.eye(3)) and np.isclose(np.linalg.det(frame), 1.0)
        assert np.allclose(frame[2], -n / np.linalg.norm(n))
        assert np.allclose(frame[:2], tangent_basis(frame[2]))


def test_soft_wrench_matrix_samples_the_elliptic_limit_surface():
    rng = np.random.default_rng(2)
    P, N = sphere_grasp(rng, 3)
    c, r, mu, R, gamma, rings = ORIGIN, 0.03, 0.5, 6, 0.004, 2
    W = pg.wrench_matrix(P, N, c, r, mu=mu, edges=R, soft=True, torsion=gamma, soft_rings=rings)
    D = R * (1 + 2 * rings) + 2
    assert W.shape == (3 * D, 6)
    for i in range(3):
        n_in = -N[i] / np.linalg.norm(N[i])
        rows = W[i * D:(i + 1) * D]
        f = rows[:, :3]
        assert np.allclose(f @ n_in, 1.0)
        moment = (rows[:, 3:] * r - np.cross(P[i] - c, f)) @ n_in      # torsion about the normal
        ft = np.linalg.norm(f - np.outer(f @ n_in, n_in), axis=1)
        assert np.allclose((ft / mu) ** 2 + (moment / gamma) ** 2, 1.0)  # on the ellipse
        assert np.allclose(moment[:R], 0.0) and np.allclose(moment[-2:], [gamma, -gamma])
        assert np.allclose(ft[-2:], 0.0)
    assert np.allclose(W, reference_wrenches(P, N, c, r, mu, R, gamma, rings), atol=1e-14)
    # point contacts ignore the torsion radius
    assert np.array_equal(pg.wrench_matrix(P, N, c, r, mu=mu, edges=R, torsion=gamma),
                          pg.wrench_matrix(P, N, c, r, mu=mu, edges=R))


# ------------------------------------------------------------------ epsilon vs independent values

def test_epsilon_and_volume_match_brute_force_facet_enumeration():
    rng = np.random.default_rng(3)
    worst_eps = worst_vol = 0.0
    checked = 0
    while checked < 6:
        P, N = sphere_grasp(rng, int(rng.integers(4, 6)), scatter=0.2)
        mu = float(rng.uniform(0.3, 1.2))
        W = reference_wrenches(P, N, ORIGIN, 0.03, mu, 3)
        q = pg.grasp_quality(P, N, ORIGIN, 0.03, mu=mu, edges=3)
        assert q.force_closure == lp_force_closure(W)
        if not q.force_closure:
            continue
        eps, vol = brute_force_hull(W)
        worst_eps = max(worst_eps, abs(q.epsilon - eps) / eps)
        worst_vol = max(worst_vol, abs(q.volume - vol) / vol)
        checked += 1
    assert worst_eps < 1e-9, worst_eps
    assert worst_vol < 1e-9, worst_vol


def test_epsilon_matches_the_support_function_minimum():
    rng = np.random.default_rng(4)
    worst, n_fc = 0.0, 0
    for trial in range(8):
        if trial % 2:
            P, N = sphere_grasp(rng, int(rng.integers(3, 7)), scatter=0.3)
            r = 0.03
        else:
            P, N, r = box_grasp(rng, int(rng.integers(3, 7)))
        mu, R = float(rng.uniform(0.2, 1.0)), 8
        soft = trial % 3 == 0
        gamma = 0.004 if soft else None
        q = pg.grasp_quality(P, N, ORIGIN, r, mu=mu, edges=R, soft=soft, torsion=gamma)
        W = reference_wrenches(P, N, ORIGIN, r, mu, R, gamma)
        best, sampled = support_min(W, rng)
        if q.force_closure:
            n_fc += 1
            assert q.epsilon <= best + 1e-12              # every direction bounds epsilon above
            worst = max(worst, (best - q.epsilon) / q.epsilon)
        else:
            assert q.epsilon == 0.0
            assert best <= 1e-9                           # a direction the grasp cannot push along
            assert not lp_force_closure(W)
    assert n_fc >= 3
    assert worst < 0.01, worst


def test_two_antipodal_soft_contacts_match_the_closed_form():
    # Contacts at c +- r x with inward normals -+x, 4 pyramid edges, torsion radius g. The 12
    # wrenches are (-1, c e_A), (-1, c e_B), (-1, +-g/r e_5) and (1, c e_C), (1, c e_D),
    # (1, +-g/r e_5) (each +-) in an orthonormal frame (f_x, A, B, C, D, tau_x), with c = mu sqrt(2)
    # for any pyramid phase. The facets with u_fx = 0 touch one point of each pair, so
    # epsilon = 1 / sqrt(4/c^2 + r^2/g^2) = 1 / sqrt(2/mu^2 + r^2/g^2); a direction with u_fx != 0
    # cannot do better when (g/r)^2 (1 + 2/mu^2) <= 1 (shown by bounding each group's maximum).
    rng = np.random.default_rng(5)
    for mu, r, g in [(0.5, 0.05, 0.01), (1.0, 0.02, 0.01), (0.3, 0.1, 0.02)]:
        assert (g / r) ** 2 * (1 + 2 / mu ** 2) <= 1
        expected = 1.0 / math.sqrt(2 / mu ** 2 + r ** 2 / g ** 2)
        for _ in range(3):
            Rot, t = random_rotation(rng), rng.normal(size=3)
            x = Rot[:, 0]
            P = np.array([r * x, -r * x]) + t
            q = pg.grasp_quality(P, np.array([x, -x]), t, r, mu=mu, edges=4, soft=True, torsion=g)
            assert q.force_closure and q.rank == 6
            assert q.epsilon == pytest.approx(expected, rel=1e-9)
            # point contacts: the moment about the contact line is zero, never force closure
            p = pg.grasp_quality(P, np.array([x, -x]), t, r, mu=mu, edges=64)
            assert not p.force_closure and p.epsilon == 0.0 and p.rank == 5
            assert "rank" in p.reason
    # more edges contain the 4-edge pyramid, extra rings add points: epsilon cannot drop
    P, N = np.array([[0.05, 0, 0], [-0.05, 0, 0]]), np.array([[1.0, 0, 0], [-1, 0, 0]])
    e4 = pg.grasp_quality(P, N, ORIGIN, 0.05, mu=0.5, edges=4, soft=True, torsion=0.01).epsilon
    e8 = pg.grasp_quality(P, N, ORIGIN, 0.05, mu=0.5, edges=8, soft=True, torsion=0.01).epsilon
    e8r = pg.grasp_quality(P, N, ORIGIN, 0.05, mu=0.5, edges=8, soft=True, torsion=0.01,
                           soft_rings=3).epsilon
    assert e4 <= e8 + 1e-12 <= e8r + 2e-12 and e8r > e4


def test_cube_face_centres_bounded_by_the_pure_torque_direction():
    # Six contacts at the face centres of a cube of half side a, r = sqrt(3) a. For the pure-torque
    # direction u = (0, d), d = (1,1,1)/sqrt(3), every wrench gives u.w = mu (a/r) d.(e_i x t)
    # <= mu (a/r) |d x e_i| = mu (a/r) sqrt(2/3), so epsilon <= mu sqrt(2)/3 for every pyramid.
    a = 0.02
    P = np.vstack([a * np.eye(3), -a * np.eye(3)])
    N = P / a
    r = math.sqrt(3) * a
    for mu in (0.2, 0.5, 1.0):
        bound = mu * math.sqrt(2) / 3
        for R in (4, 8, 16):
            q = pg.grasp_quality(P, N, ORIGIN, r, mu=mu, edges=R)
            assert q.force_closure
            assert 0 < q.epsilon <= bound * (1 + 1e-12)
    q = pg.grasp_quality(P, N, ORIGIN, r, mu=0.0)           # frictionless: no torque at all
    assert not q.force_closure and q.epsilon == 0.0 and q.rank == 3


# ----------------------------------------------------------------------------- textbook grasps

def test_opposite_box_faces_in_opposite_pairs():
    # box 0.1 x 0.06 x 0.04; two directly opposite pairs across the x faces, spread apart
    r = float(np.linalg.norm([0.05, 0.03, 0.02]))
    P = np.array([[0.05, 0.02, 0.01], [-0.05, 0.02, 0.01], [0.05, -0.02, -0.01], [-0.05, -0.02, -0.01]])
    N = np.array([[1.0, 0, 0], [-1, 0, 0], [1, 0, 0], [-1, 0, 0]])
    for mu in (0.05, 0.3, 1.0):
        q = pg.grasp_quality(P, N, ORIGIN, r, mu=mu)
        assert q.force_closure and q.epsilon > 0 and q.volume > 0 and q.reason == ""
        assert lp_force_closure(reference_wrenches(P, N, ORIGIN, r, mu, 8))
    q = pg.grasp_quality(P, N, ORIGIN, r, mu=0.0)
    assert not q.force_closure and q.epsilon == 0.0 and "rank" in q.reason
    # one pair only: the line through it is a free rotation axis
    q = pg.grasp_quality(P[:2], N[:2], ORIGIN, r, mu=1.0, edges=32)
    assert not q.force_closure and q.rank == 5


def test_two_point_contacts_are_never_force_closure():
    rng = np.random.default_rng(6)
    for _ in range(10):
        P, N = sphere_grasp(rng, 2, scatter=0.5)
        q = pg.grasp_quality(P, N, ORIGIN, 0.03, mu=float(rng.uniform(0, 3)), edges=int(rng.integers(3, 40)))
        assert not q.force_closure and q.epsilon == 0.0 and q.rank <= 5 and "rank" in q.reason


def test_contacts_on_one_face_are_never_force_closure():
    rng = np.random.default_rng(7)
    for soft in (False, True):
        for _ in range(5):
            m = int(rng.integers(1, 9))
            P = np.c_[np.full(m, 0.05), rng.uniform(-0.03, 0.03, size=(m, 2))]
            N = np.tile([1.0, 0, 0], (m, 1))
            q = pg.grasp_quality(P, N, ORIGIN, 0.07, mu=float(rng.uniform(0, 2)), edges=12,
                                 soft=soft, torsion=0.01)
            assert not q.force_closure and q.epsilon == 0.0 and q.reason
            # every wrench pushes along -x: the direction (1, 0, ..., 0) has negative support
            W = pg.wrench_matrix(P, N, ORIGIN, 0.07, mu=0.5, edges=12)
            assert W[:, 0].max() < 0


def test_frictionless_contacts_on_a_sphere_cannot_resist_torque():
    rng = np.random.default_rng(8)
    P, N = sphere_grasp(rng, 40)
    q = pg.grasp_quality(P, N, ORIGIN, 0.03, mu=0.0)
    assert not q.force_closure and q.rank == 3 and q.n_wrenches == 40 * 8


def test_force_closure_flag_agrees_with_the_linear_program():
    rng = np.random.default_rng(9)
    agree = fc = 0
    for trial in range(24):
        m = int(rng.integers(2, 12))
        P, N, r = box_grasp(rng, m)
        mu = 0.0 if trial % 3 == 0 else float(rng.uniform(0.05, 0.8))
        q = pg.grasp_quality(P, N, ORIGIN, r, mu=mu, edges=6)
        ref = lp_force_closure(reference_wrenches(P, N, ORIGIN, r, mu, 6))
        assert q.force_closure == ref, (trial, q)
        assert (q.epsilon > 0) == q.force_closure and (q.reason == "") == q.force_closure
        agree += 1
        fc += ref
    assert 4 <= fc <= 20        # both outcomes exercised


# ---------------------------------------------------------------------------------- invariances

def test_epsilon_is_invariant_to_rigid_motion():
    # A pyramid of R edges lies between the friction cones of mu cos(pi/R) and mu, and those cones turn
    # with the grasp, so for any pose epsilon lies in [eps_pyr(mu cos(pi/R)), eps_pyr(mu / cos(pi/R))]
    # of the original pose (epsilon grows with the wrench set).
    rng = np.random.default_rng(10)
    P, N = sphere_grasp(rng, 5, scatter=0.2)
    c, r, mu, R = np.array([0.002, 0.001, -0.003]), 0.03, 0.6, 16
    shrink = math.cos(math.pi / R)
    e0 = pg.grasp_quality(P, N, c, r, mu=mu, edges=R).epsilon
    lo = pg.grasp_quality(P, N, c, r, mu=mu * shrink, edges=R).epsilon
    hi = pg.grasp_quality(P, N, c, r, mu=mu / shrink, edges=R).epsilon
    assert 0 < lo <= e0 <= hi < 1.1 * lo
    t = rng.normal(size=3)
    assert pg.grasp_quality(P + t, N, c + t, r, mu=mu, edges=R).epsilon == pytest.approx(e0, rel=1e-9)
    for _ in range(3):
        Rot, t = random_rotation(rng), rng.normal(size=3)
        e1 = pg.grasp_quality(P @ Rot.T + t, N @ Rot.T, c @ Rot.T + t, r, mu=mu, edges=R).epsilon
        assert lo - 1e-12 <= e1 <= hi + 1e-12


def test_more_friction_never_lowers_epsilon():
    rng = np.random.default_rng(11)
    P, N = sphere_grasp(rng, 4, scatter=0.3)
    for soft in (False, True):
        eps = [pg.grasp_quality(P, N, ORIGIN, 0.03, mu=mu, edges=8, soft=soft, torsion=0.003).epsilon
               for mu in np.linspace(0.0, 1.5, 13)]
        assert all(b >= a - 1e-12 for a, b in zip(eps, eps[1:])), eps
        assert eps[-1] > 0
    # the torsion radius plays the same role for soft contacts
    P2, N2 = np.array([[0.03, 0, 0], [-0.03, 0, 0]]), np.array([[1.0, 0, 0], [-1, 0, 0]])
    eps = [pg.grasp_quality(P2, N2, ORIGIN, 0.03, mu=0.5, soft=True, torsion=g).epsilon
           for g in (0.0, 0.001, 0.003, 0.01)]
    assert eps[0] == 0.0 and 0 < eps[1] < eps[2] < eps[3]


def test_epsilon_is_finite_and_nonnegative_on_degenerate_grasps():
    rng = np.random.default_rng(12)
    base = np.array([[0.01, 0, 0], [-0.01, 0, 0], [0, 0.01, 0]])
    cases = [
        (np.repeat(base[:1], 5, axis=0), np.repeat([[1.0, 0, 0]], 5, axis=0)),     # one point x5
        (np.c_[np.linspace(-1, 1, 6), np.zeros((6, 2))] * 0.01, rng.normal(size=(6, 3))),
        (base, -base),                                                            # inward-facing
        (base, base * 1e-9),                                                      # tiny normals
        sphere_grasp(rng, 12, scatter=1.0),
    ]
    for P, N in cases:
        for mu in (0.0, 1e-9, 0.5, 50.0):
            for soft in (False, True):
                q = pg.grasp_quality(P, N, ORIGIN, 0.01, mu=mu, edges=5, soft=soft, torsion=0.002)
                assert math.isfinite(q.epsilon) and q.epsilon >= 0.0
                assert math.isfinite(q.volume) and q.volume >= 0.0
                assert q.force_closure == (q.epsilon > 0)
    q = pg.grasp_quality(np.zeros((0, 3)), np.zeros((0, 3)), ORIGIN, 0.01)
    assert not q.force_closure and q.epsilon == 0.0 and q.n_contacts == 0 and "no contacts" in q.reason


# ------------------------------------------------------------------------------- exact reductions

def _full_hull_epsilon(P, N, radius, mu=0.5, edges=8, torsion=None, rings=0, center=ORIGIN):
    """Epsilon and volume of the hull of every wrench (built in NumPy by reference_wrenches), by
    SciPy's ConvexHull directly (no reduction): epsilon is the smallest facet offset."""
    hull = ConvexHull(np.unique(reference_wrenches(P, N, center, radius, mu, edges, torsion, rings), axis=0))
    d = float(-hull.equations[:, -1].max())
    return max(d, 0.0), float(hull.volume)


def test_contacts_inside_a_flat_patch_change_nothing():
    """Three faces of a cube, each pressed by a 4x4 grid of contacts: the 12 interior contacts of
    each face are dropped, and epsilon and volume equal those of the hull of all 48 contacts'
    wrenches."""
    g = np.linspace(-0.02, 0.02, 4)
    u, v = [a.ravel() for a in np.meshgrid(g, g)]
    P, N = [], []
    for axis, sign in ((0, 1.0), (0, -1.0), (1, 1.0)):
        pts = np.zeros((16, 3))
        pts[:, axis] = sign * 0.03
        others = [k for k in range(3) if k != axis]
        pts[:, others[0]], pts[:, others[1]] = u, v
        n = np.zeros((16, 3))
        n[:, axis] = sign
        P.append(pts)
        N.append(n)
    P, N = np.concatenate(P), np.concatenate(N)
    eps, vol = _full_hull_epsilon(P, N, 0.05)
    q = pg.grasp_quality(P, N, ORIGIN, 0.05, max_hull_wrenches=10_000)
    assert q.force_closure and q.volume_exact and q.n_contacts == 48 and q.n_wrenches == 384
    assert q.epsilon == pytest.approx(eps, rel=1e-9)
    assert q.volume == pytest.approx(vol, rel=1e-9)


@pytest.mark.long
def test_pads_rounded_to_a_nanometre_keep_their_epsilon():
    """Two opposite 6x6 pads in random orientations, their points rounded to 1e-9 m as
    grasps.json writes them: nearly coplanar wrenches once made qhull's precision check fail and
    epsilon read 0. Rounding moves every wrench by ~1e-9, so epsilon may move by about as much."""
    from scipy.spatial.transform import Rotation

    g = np.linspace(-0.01, 0.01, 6)
    u, v = [a.ravel() for a in np.meshgrid(g, g)]
    P, N = [], []
    for sign in (1.0, -1.0):
        P.append(np.column_stack([np.full(36, sign * 0.03), u, v + 0.004]))
        N.append(np.tile([sign, 0.0, 0.0], (36, 1)))
    P, N = np.concatenate(P), np.concatenate(N)
    for seed in range(16):
        rot = Rotation.random(random_state=seed).as_matrix()
        exact = pg.grasp_quality(P @ rot.T, N @ rot.T, ORIGIN, 0.05)
        rounded = pg.grasp_quality(np.round(P @ rot.T, 9), N @ rot.T, ORIGIN, 0.05)
        assert exact.force_closure and rounded.force_closure, (seed, rounded.reason)
        assert rounded.epsilon == pytest.approx(exact.epsilon, rel=1e-6)


@pytest.mark.parametrize("seed", range(6))
def test_active_set_epsilon_equals_the_full_hull(seed):
    """Random contacts with distinct normals: the active set's epsilon (forced by a tiny
    max_hull_wrenches) equals the full hull's, force-closure or not (seeds 3-5 keep the normals
    in a cone, which is often not force-closure)."""
    rng = np.random.default_rng(seed)
    n = 28
    N = rng.normal(size=(n, 3))
    if seed >= 3:
        N[:, 2] = np.abs(N[:, 2]) + 1.5
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    P = N * 0.04 + rng.normal(scale=0.004, size=(n, 3))
    eps, vol = _full_hull_epsilon(P, N, 0.05)
    q = pg.grasp_quality(P, N, ORIGIN, 0.05, max_hull_wrenches=7)
    assert q.epsilon == pytest.approx(eps, rel=1e-9, abs=1e-12)
    assert q.force_closure == (eps > 1e-9)
    assert q.volume <= vol * (1 + 1e-9)
    if not q.volume_exact:
        assert q.volume < vol  # a subset's hull


@pytest.mark.parametrize("seed", range(8))
def test_without_open_volume_only_non_closure_changes(seed):
    """open_volume=False rules non-closure out by a separating hyperplane: the classification and every
    force-closure result are those of the hull; a non-closure grasp just has no volume."""
    rng = np.random.default_rng(100 + seed)
    n = 10
    N = rng.normal(size=(n, 3))
    if seed % 2:
        N[:, 2] = np.abs(N[:, 2]) + 1.0  # normals in a cone: often not force-closure
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    P = N * 0.04 + rng.normal(scale=0.004, size=(n, 3))
    full = pg.grasp_quality(P, N, ORIGIN, 0.05)
    fast = pg.grasp_quality(P, N, ORIGIN, 0.05, open_volume=False)
    assert fast.force_closure == full.force_closure
    assert fast.epsilon == full.epsilon
    if full.force_closure:
        assert fast.volume == full.volume and fast.volume_exact
    else:
        assert fast.epsilon == 0.0


# ------------------------------------------------------------------------------- API and errors

@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.long
def test_force_resistance_matches_the_scipy_hull(seed):
    # The ray from the origin along a pure force leaves SciPy's hull of independently built wrenches
    # (tests/py/independent.py) where pairgrasp's hull-free computation says, along the six load
    # directions and random ones; never below epsilon, and 0 without force closure.
    rng = np.random.default_rng(seed)
    checked = 0
    for trial in range(40):
        P, N, r = (*sphere_grasp(rng, 4 + trial % 6, scatter=0.3), 0.03) if trial % 2 else box_grasp(rng, 5 + trial % 5)
        center = 0.003 * rng.normal(size=3)
        dirs = np.vstack([pg.LOAD_DIRECTIONS, rng.normal(size=(4, 3))])
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        got = pg.force_resistance(P, N, center, r, dirs)
        want = independent.force_resistance(P, N, center, r, dirs)
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-12)
        assert pg.load_resistance(P, N, center, r) == pytest.approx(want[:6].min(), rel=1e-6, abs=1e-12)
        q = pg.grasp_quality(P, N, center, r, volume=False)
        assert (got >= q.epsilon * (1 - 1e-9)).all()
        checked += bool(q.force_closure)
    assert checked >= 10


def test_force_resistance_refuses_bad_directions():
    P, N, _ = box_grasp(np.random.default_rng(4), 6)
    with pytest.raises(ValueError, match="directions"):
        pg.force_resistance(P, N, ORIGIN, 0.05, [[1.0, 0.0]])
    with pytest.raises(ValueError, match="directions: row 1"):
        pg.force_resistance(P, N, ORIGIN, 0.05, [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    with pytest.raises(ValueError, match="directions: row 0"):
        pg.force_resistance(P, N, ORIGIN, 0.05, [[np.nan, 0.0, 0.0]])


def test_result_reads_as_object_mapping_and_sequence():
    P = np.array([[0.05, 0.02, 0.01], [-0.05, 0.02, 0.01], [0.05, -0.02, -0.01], [-0.05, -0.02, -0.01]])
    N = np.sign(P[:, :1]) * np.array([[1.0, 0, 0]])
    q = pg.grasp_quality(P.tolist(), N.tolist(), [0, 0, 0], 0.06, mu=0.5, edges=8)
    assert isinstance(q, pg.GraspQuality)
    d = q.as_dict()
    assert set(d) == {"epsilon", "volume", "force_closure", "n_contacts", "n_wrenches", "rank", "reason",
                      "volume_exact"}
    assert q["epsilon"] == q[0] == d["epsilon"] == q.epsilon
    assert q[2] is q.force_closure is True and q["n_contacts"] == 4 and q.n_wrenches == 32
    assert dict(q) == d and len(q) == 8 and q.volume_exact
    assert isinstance(q.epsilon, float) and isinstance(q.volume, float)
    with pytest.raises(KeyError):
        q["nope"]


GOOD = dict(points=np.array([[0.01, 0, 0], [-0.01, 0, 0]]), normals=np.array([[1.0, 0, 0], [-1, 0, 0]]),
            center=np.zeros(3), radius=0.01)


@pytest.mark.parametrize("change, name", [
    (dict(points=[[np.nan, 0, 0], [0, 0, 0]]), "points"),
    (dict(points=[[0, 0, 0, 0], [1, 1, 1, 1]]), "points"),
    (dict(points=[0.01, 0, 0]), "points"),
    (dict(points="abc"), "points"),
    (dict(normals=[[1.0, 0, 0]]), "normals"),
    (dict(normals=[[1.0, 0, 0], [0, 0, 0]]), "normals"),
    (dict(normals=[[np.inf, 0, 0], [1, 0, 0]]), "normals"),
    (dict(center=[0, 0]), "center"),
    (dict(center=[0, np.nan, 0]), "center"),
    (dict(radius=0.0), "radius"),
    (dict(radius=-1.0), "radius"),
    (dict(radius=np.nan), "radius"),
    (dict(radius=[0.1, 0.2]), "radius"),
    (dict(mu=-0.1), "mu"),
    (dict(mu=np.inf), "mu"),
    (dict(mu="0.5"), "mu"),
    (dict(edges=2), "edges"),
    (dict(edges=8.0), "edges"),
    (dict(edges=True), "edges"),
    (dict(soft=True), "torsion"),
    (dict(soft=True, torsion=-0.01), "torsion"),
    (dict(soft=True, torsion=0.01, soft_rings=-1), "soft_rings"),
    (dict(soft="yes", torsion=0.01), "soft"),
])
@pytest.mark.parametrize("fn", [pg.grasp_quality, pg.wrench_matrix])
def test_bad_input_raises_value_error_naming_the_argument(fn, change, name):
    kwargs = dict(GOOD, **change)
    with pytest.raises(ValueError, match=rf"^{name}:"):
        fn(**kwargs)


def test_contact_wrenches_match_the_reference():
    """pairgrasp.contact_wrenches (the C++ wrench matrix behind pairgrasp.wrench_matrix) against
    the wrenches built one by one in this file, point and soft contacts."""
    rng = np.random.default_rng(11)
    P = rng.normal(size=(6, 3)) * 0.05
    N = rng.normal(size=(6, 3))
    N[2] = [0.0, 0.0, 2.0]          # a tie in the tangent-axis choice, and a non-unit normal
    c = rng.normal(size=3) * 0.01
    for mu, k in ((0.5, 8), (0.0, 3), (1.3, 17)):
        cpp = np.asarray(pg.contact_wrenches(P, N, c, 0.07, mu=mu, edges=k))
        assert cpp.shape == (6 * k, 6)
        np.testing.assert_allclose(cpp, reference_wrenches(P, N, c, 0.07, mu, k), atol=1e-13)
        soft = np.asarray(pg.contact_wrenches(P, N, c, 0.07, mu=mu, edges=k, soft=True, torsion=0.003,
                                              soft_rings=2))
        np.testing.assert_allclose(soft, reference_wrenches(P, N, c, 0.07, mu, k, 0.003, 2), atol=1e-13)
    with pytest.raises(ValueError, match="edges"):
        pg.contact_wrenches(P, N, c, 0.07, edges=2)
    with pytest.raises(ValueError, match="radius"):
        pg.contact_wrenches(P, N, c, -1.0)
    with pytest.raises(ValueError, match="torsion"):
        pg.contact_wrenches(P, N, c, 0.07, soft=True)


# ------------------------------------------------------------------ SciPy's qhull as the oracle

def _scipy_cases(rng):
    """(P, N, center, radius, mu, edges, torsion, rings) of random and hand-made grasps."""
    cases = []
    for m in (3, 4, 6, 9, 14):
        P, N = sphere_grasp(rng, m, scatter=0.3)
        cases.append((P, N, rng.normal(size=3) * 0.003, 0.03, float(rng.uniform(0.2, 1.2)), 8, None, 0))
    for m in (4, 7, 12):
        P, N, r = box_grasp(rng, m)
        cases.append((P, N, ORIGIN, r, float(rng.uniform(0.2, 1.0)), 6, None, 0))
    a = 0.02                                                     # the cube's face centres
    cube = np.vstack([a * np.eye(3), -a * np.eye(3)])
    cases.append((cube, cube / a, ORIGIN, math.sqrt(3) * a, 0.5, 8, None, 0))
    for m, rings in ((2, 0), (3, 1), (5, 2)):                    # soft contacts
        P, N = sphere_grasp(rng, m, scatter=0.2)
        cases.append((P, N, ORIGIN, 0.03, float(rng.uniform(0.3, 1.0)), 6, 0.004, rings))
    return cases


def test_epsilon_and_volume_match_scipy_convex_hull():
    """Epsilon and volume equal those of SciPy's ConvexHull of the wrenches built in NumPy, within
    1e-9 relative, on random and hand-made contact sets, point and soft contacts."""
    rng = np.random.default_rng(40)
    fc = 0
    for P, N, c, r, mu, R, torsion, rings in _scipy_cases(rng):
        soft = torsion is not None
        q = pg.grasp_quality(P, N, c, r, mu=mu, edges=R, soft=soft, torsion=torsion, soft_rings=rings,
                             max_hull_wrenches=100_000)
        eps, vol = _full_hull_epsilon(P, N, r, mu, R, torsion, rings, center=c)
        assert q.volume_exact
        assert q.force_closure == (eps > 1e-9), (q, eps)
        assert q.epsilon == pytest.approx(eps if q.force_closure else 0.0, rel=1e-9, abs=1e-15)
        assert q.volume == pytest.approx(vol, rel=1e-9)
        fc += q.force_closure
    assert fc >= 6


def test_default_reduction_matches_scipy_convex_hull():
    """With the default max_hull_wrenches (the active set on larger sets), epsilon still equals
    SciPy's full-hull epsilon; the volume is a lower bound when not exact."""
    rng = np.random.default_rng(41)
    for m in (30, 45, 60):
        P, N = sphere_grasp(rng, m, scatter=0.2)
        eps, vol = _full_hull_epsilon(P, N, 0.03, 0.5, 8)
        q = pg.grasp_quality(P, N, ORIGIN, 0.03)
        assert q.epsilon == pytest.approx(eps, rel=1e-9)
        assert q.volume <= vol * (1 + 1e-9)
        assert q.volume == pytest.approx(vol, rel=1e-9) if q.volume_exact else q.volume < vol


def test_upper_bound_is_never_below_epsilon():
    rng = np.random.default_rng(42)
    tight = 0
    for trial in range(40):
        P, N = sphere_grasp(rng, int(rng.integers(2, 12)), scatter=0.5)
        mu, R = float(rng.uniform(0.05, 1.5)), int(rng.integers(3, 12))
        torsion = 0.003 if trial % 3 == 0 else None
        kw = dict(mu=mu, edges=R, soft=torsion is not None, torsion=torsion)
        bound = pg.epsilon_upper_bound(P, N, ORIGIN, 0.03, **kw)
        eps = pg.grasp_quality(P, N, ORIGIN, 0.03, **kw).epsilon
        W = reference_wrenches(P, N, ORIGIN, 0.03, mu, R, torsion)
        assert eps <= bound * (1 + 1e-12)
        assert bound <= np.linalg.svd(W, compute_uv=False)[-1] * (1 + 1e-12)   # never above sigma_min
        tight += bound < 2 * eps
    assert tight >= 5
    assert pg.epsilon_upper_bound(np.zeros((0, 3)), np.zeros((0, 3)), ORIGIN, 0.03) == 0.0


@pytest.mark.long
def test_threads_give_the_serial_answers():
    """Many calls from a thread pool (the GIL is released during the C++ work, each call has its own
    qhull state) give exactly the serial answers."""
    rng = np.random.default_rng(43)
    grasps = [sphere_grasp(rng, int(rng.integers(4, 30)), scatter=0.3) for _ in range(40)]

    def run(k):
        P, N = grasps[k]
        return pg.grasp_quality(P, N, ORIGIN, 0.03, mu=0.6, max_hull_wrenches=7 if k % 3 == 0 else 320)

    serial = [run(k) for k in range(len(grasps))]
    with ThreadPoolExecutor(max_workers=4) as pool:
        for _ in range(2):
            assert list(pool.map(run, range(len(grasps)))) == serial
