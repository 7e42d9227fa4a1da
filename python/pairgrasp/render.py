"""Pictures: a grasp (hand and target together) and the paper's Figures 7 and 8.

Drawn with matplotlib's Agg backend (no display needed). Lengths in metres; the pictures show
millimetres.
"""
from __future__ import annotations

import os
from typing import Optional, Sequence

import numpy as np

__all__ = ["draw_grasp", "draw_planned", "figure7", "figure7_samples", "figure8", "classical_mds", "simulation_figure"]

FREE_COLOR = (0.70, 0.74, 0.80)
OCCLUDED_COLOR = (0.93, 0.55, 0.20)
HAND_COLOR = (0.25, 0.35, 0.60)
CONTACT_COLOR = (0.85, 0.10, 0.10)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _shade(normals: np.ndarray, base, light=(0.3, -0.4, 0.87)) -> np.ndarray:
    light = np.asarray(light, float) / np.linalg.norm(light)
    k = 0.45 + 0.55 * np.abs(normals @ light)
    return np.clip(np.asarray(base, float)[None, :] * k[:, None], 0.0, 1.0)


def _tri_normals(tris: np.ndarray) -> np.ndarray:
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    return n / np.where(ln > 0, ln, 1.0)


def _hand_triangles(hand, wrist_pose: np.ndarray, dofs: np.ndarray):
    poses = np.asarray(hand.link_poses(np.asarray(dofs, float), clamp=True))
    out = []
    for link, T in zip(hand.links, poses):
        mesh = link.mesh
        if mesh is None or len(mesh.faces) == 0:
            continue
        v = np.asarray(mesh.vertices, float)
        W = wrist_pose @ T
        v = v @ W[:3, :3].T + W[:3, 3]
        out.append(v[np.asarray(mesh.faces, int)])
    return np.concatenate(out) if out else np.zeros((0, 3, 3))


def draw_grasp(hand, target, free: Optional[np.ndarray], wrist_pose, dofs, path: str, title: str = "",
               contacts: Optional[np.ndarray] = None, views: Sequence[tuple] = ((25, -60), (25, 60)),
               support=None) -> str:
    """Writes a PNG of the hand at ``wrist_pose`` / ``dofs`` with the target (free faces grey,
    occluded faces orange), the contact points (red) and, given a :class:`pairgrasp.SupportPlane`,
    the table as a translucent square on it, from each of ``views`` (elevation, azimuth in degrees).
    Returns ``path``."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    plt = _pyplot()
    tv = np.asarray(target.vertices, float)
    tris = tv[np.asarray(target.faces, int)]
    free = np.ones(len(tris), bool) if free is None else np.asarray(free, bool)
    tn = _tri_normals(tris)
    tcol = np.where(free[:, None], _shade(tn, FREE_COLOR), _shade(tn, OCCLUDED_COLOR))
    htris = _hand_triangles(hand, np.asarray(wrist_pose, float), dofs)
    hcol = _shade(_tri_normals(htris), HAND_COLOR) if len(htris) else np.zeros((0, 3))
    allv = np.concatenate([tris.reshape(-1, 3), htris.reshape(-1, 3)]) * 1000.0
    lo, hi = allv.min(axis=0), allv.max(axis=0)
    centre, half = (lo + hi) / 2.0, (hi - lo).max() / 2.0 * 1.02
    fig = plt.figure(figsize=(5.0 * len(views), 5.0), dpi=100)
    table = None
    if support is not None:
        # A square on the plane, centred under the drawing and as wide as it (mm).
        n = np.asarray(support.normal, float) / np.linalg.norm(support.normal)
        u = np.cross(n, (1.0, 0.0, 0.0) if abs(n[0]) < 0.9 else (0.0, 1.0, 0.0))
        u /= np.linalg.norm(u)
        w = np.cross(n, u)
        c = centre - np.dot(centre - 1000.0 * np.asarray(support.point, float), n) * n
        table = np.array([[c + half * (a * u + b * w) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]])
    for k, (elev, azim) in enumerate(views):
        ax = fig.add_subplot(1, len(views), k + 1, projection="3d")
        if table is not None:
            ax.add_collection3d(Poly3DCollection(table, facecolors=(0.55, 0.45, 0.35), edgecolors="none", alpha=0.35))
        ax.add_collection3d(Poly3DCollection(tris * 1000.0, facecolors=tcol, edgecolors="none", alpha=1.0))
        if len(htris):
            ax.add_collection3d(Poly3DCollection(htris * 1000.0, facecolors=hcol, edgecolors=(0.1, 0.1, 0.2, 0.3),
                                                 linewidths=0.2, alpha=0.85))
        if contacts is not None and len(contacts):
            c = np.asarray(contacts, float) * 1000.0
            ax.scatter(c[:, 0], c[:, 1], c[:, 2], color=CONTACT_COLOR, s=6, depthshade=False)
        for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
            setter(c - half, c + half)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=elev, azim=azim)
        ax.set_xlabel("x (mm)", fontsize=7)
        ax.set_ylabel("y (mm)", fontsize=7)
        ax.set_zlabel("z (mm)", fontsize=7)
        ax.tick_params(labelsize=6)
    if title:
        fig.suptitle(title, fontsize=9)
    _save(fig, path)
    plt.close(fig)
    return path


def draw_planned(planner, grasp, path: str, label: str = "") -> str:
    """:func:`draw_grasp` of a planned :class:`pairgrasp.Grasp`, titled with its rank, epsilon,
    Q_A and penetration."""
    title = (f"{planner.hand.name} on {label or 'the target'}: rank {grasp.rank}, eps {grasp.epsilon:.4f}"
             f"{' (force closure)' if grasp.force_closure else ''}, Q_A {grasp.alignment_quality:.2f}, "
             f"penetration {1000 * grasp.penetration_depth:.2f} mm")
    return draw_grasp(planner.hand, planner.target, planner.free, grasp.wrist_pose, grasp.dofs, path, title=title,
                      contacts=grasp.contact_points, support=getattr(planner, "support", None))


def _save(fig, path: str):
    """Lays the figure out (tight) and saves it atomically: a partial PNG never appears under
    ``path``."""
    fig.tight_layout()
    # tight_layout() leaves matplotlib's PlaceHolderLayoutEngine set, and with any engine set
    # savefig() draws the whole figure once more before drawing it into the file; the layout is
    # done, so the engine goes (same pixels).
    fig.set_layout_engine(None)
    tmp = f"{path}.part"
    fig.savefig(tmp, format="png")
    os.replace(tmp, path)


def classical_mds(points: np.ndarray, dims: int = 2) -> np.ndarray:
    """Classical (Torgerson) multidimensional scaling of (N,k) points to (N,dims): double-centred
    squared Euclidean distances, top eigenvectors scaled by the square roots of their eigenvalues.
    With Euclidean distances this is the projection on the principal axes."""
    x = np.asarray(points, float)
    d2 = ((x[:, None, :] - x[None, :, :]) ** 2).sum(-1)
    n = len(x)
    j = np.eye(n) - np.ones((n, n)) / n
    b = -0.5 * j @ d2 @ j
    w, v = np.linalg.eigh(b)
    idx = np.argsort(w)[::-1][:dims]
    return v[:, idx] * np.sqrt(np.clip(w[idx], 0.0, None))


def figure7(planner, samples: Sequence[np.ndarray], path: str, max_target: int = 1500, seed: int = 0) -> str:
    """The paper's Figure 7: target pair features and the gripper's pair features for several DOF
    samples, projected to 2-D by classical MDS. Features (d, phi, beta_ij + beta_ji) are divided by
    their ranges (d_max, 2, 4) so that the projection weighs distance and angles alike."""
    from . import _core

    plt = _pyplot()
    pairs = np.asarray(planner.tindex.index.features, float)
    rng = np.random.default_rng(seed)
    if len(pairs) > max_target:
        pairs = pairs[rng.choice(len(pairs), max_target, replace=False)]
    scale = np.array([planner.d_max, 2.0, 4.0])  # the ranges of d, phi and beta_ij + beta_ji
    groups = []
    for q in samples:
        c = planner.constellation(q)
        pts, nrm = np.asarray(c.points), -np.asarray(c.normals)
        i, j = np.triu_indices(len(pts), 1)
        f = np.asarray(_core.pair_feature(pts[i], nrm[i], pts[j], nrm[j]), float)
        groups.append(f)
    allf = np.concatenate([pairs] + groups) / scale
    y = classical_mds(allf)
    fig, ax = plt.subplots(figsize=(6.0, 5.0), dpi=100)
    ax.scatter(y[: len(pairs), 0], y[: len(pairs), 1], s=3, color=(0.6, 0.6, 0.6), label="target pairs")
    start = len(pairs)
    cmap = plt.get_cmap("tab10")
    for k, (q, f) in enumerate(zip(samples, groups)):
        yy = y[start:start + len(f)]
        start += len(f)
        frac = planner.match_fraction(q)
        ax.scatter(yy[:, 0], yy[:, 1], s=18, color=cmap(k % 10), marker="^",
                   label=f"DOF {np.round(np.asarray(q), 2).tolist()}: {100 * frac:.0f}% matched")
    ax.set_xlabel("MDS 1")
    ax.set_ylabel("MDS 2")
    ax.set_title("Pair features: target and gripper constellations (Fig. 7)", fontsize=9)
    ax.legend(fontsize=6, loc="best")
    _save(fig, path)
    plt.close(fig)
    return path


def figure7_samples(planner, result, seed: int = 0):
    """DOF samples worth showing in Figure 7: the best grasp's sample, the mid-range sample, a grid
    sample the early rejection would drop (if one is found in 200 random draws) and the lower limits."""
    from .planner import dof_axes

    hand = planner.hand
    lo, hi = np.asarray(hand.dof_lower, float), np.asarray(hand.dof_upper, float)
    samples = [np.asarray(result.grasps[0].sample)] if result.grasps else []
    samples.append((lo + hi) / 2.0)
    axes = dof_axes(lo, hi, planner.steps(result.params.step))
    fractions = [planner.match_fraction(q) for q in samples]
    rng = np.random.default_rng(seed)
    for _ in range(200):
        q = np.array([a[rng.integers(len(a))] for a in axes])
        if planner.match_fraction(q) < planner.params.min_match_fraction * max(fractions):
            samples.append(q)
            break
    samples.append(lo.copy())
    return samples


def figure8(candidates, path: str, title: str = "") -> str:
    """The paper's Figure 8: alignment quality Q_A against grasp quality epsilon over the planned
    candidates (force-closure ones in colour), with the rank correlation in the title."""
    from scipy.stats import spearmanr

    plt = _pyplot()
    qa = np.array([c.alignment_quality for c in candidates], float)
    eps = np.array([c.epsilon for c in candidates], float)
    fc = np.array([c.force_closure for c in candidates], bool)
    fig, ax = plt.subplots(figsize=(6.0, 4.5), dpi=100)
    ax.scatter(qa[~fc], eps[~fc], s=8, color=(0.6, 0.6, 0.6), label=f"not force-closure ({int((~fc).sum())})")
    ax.scatter(qa[fc], eps[fc], s=14, color=(0.85, 0.2, 0.1), label=f"force-closure ({int(fc.sum())})")
    rho = float("nan")
    if len(qa) > 2 and np.ptp(qa) > 0 and np.ptp(eps) > 0:
        rho = float(spearmanr(qa, eps).statistic)
    ax.set_xlabel("alignment quality Q_A")
    ax.set_ylabel("grasp quality epsilon")
    ax.set_title(f"{title} Q_A vs epsilon over {len(qa)} candidates (Spearman {rho:.2f}) (Fig. 8)".strip(),
                 fontsize=9)
    ax.legend(fontsize=7)
    _save(fig, path)
    plt.close(fig)
    return path


def simulation_figure(epsilons: Sequence[float], results, params, path: str, title: str = "",
                      groups: Optional[Sequence[str]] = None) -> str:
    """Epsilon against the simulated outcome: each grasp's largest slip relative to the palm (mm, log
    scale), held grasps in green, slipped or dropped ones in red, the success threshold dashed.
    ``groups`` (one label per grasp) draws each group with its own marker."""
    plt = _pyplot()
    eps = np.asarray(epsilons, float)
    slip = np.array([r.slip_translation for r in results], float) * 1000.0
    floor, ceil = 0.01, 5000.0 * params.max_translation
    slip = np.clip(np.where(np.isfinite(slip), slip, ceil), floor, ceil)
    ok = np.array([r.success for r in results], bool)
    labels = list(groups) if groups is not None else ["grasps"] * len(results)
    markers = ["o", "s", "^", "D", "v", "P"]
    fig, ax = plt.subplots(figsize=(6.0, 4.5), dpi=100)
    for k, name in enumerate(dict.fromkeys(labels)):
        sel = np.array([lab == name for lab in labels], bool)
        mk = markers[k % len(markers)]
        for mask, colour, what in ((sel & ok, (0.1, 0.6, 0.2), "held"), (sel & ~ok, (0.85, 0.15, 0.1), "not held")):
            if mask.any():
                ax.scatter(eps[mask], slip[mask], s=22, marker=mk, color=colour, alpha=0.8,
                           label=f"{name}: {what} ({int(mask.sum())})")
    ax.axhline(1000.0 * params.max_translation, color="k", ls="--", lw=0.8, label="success threshold")
    ax.set_yscale("log")
    ax.set_xlabel("grasp quality epsilon (planned)")
    ax.set_ylabel("largest slip relative to the palm (mm)")
    rate = 100.0 * ok.mean() if len(ok) else 0.0
    ax.set_title(f"{title} simulated: {int(ok.sum())}/{len(ok)} held ({rate:.0f}%)".strip(), fontsize=9)
    ax.legend(fontsize=7)
    _save(fig, path)
    plt.close(fig)
    return path
