"""Mass properties of a closed triangle mesh: mass, centre of mass and inertia tensor.

The solid is split into signed tetrahedra, one per face, with a common apex (the vertex centroid, to
keep the terms small); for the tetrahedron (apex, a, b, c) with edge vectors u, v, w from the apex,
the volume is det[u v w] / 6 and the second moment about the apex is
``V / 20 * (u uᵀ + v vᵀ + w wᵀ + (u + v + w)(u + v + w)ᵀ)``. Summed with their signs, the
tetrahedra outside the solid cancel, so the result is exact for any closed, consistently wound
(outward) mesh, convex or not. Units: metres, kilograms, kg·m².
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MassProperties", "mass_properties", "hull_mass_properties", "pieces_mass_properties",
           "solid_mass_properties"]


@dataclass(frozen=True)
class MassProperties:
    """Mass properties of a solid of uniform density.

    Attributes:
        mass: kg.
        volume: m³.
        center_of_mass: (3,) m, in the mesh frame.
        inertia: (3,3) inertia tensor about the centre of mass, axes of the mesh frame (kg·m²).
    """

    mass: float
    volume: float
    center_of_mass: np.ndarray
    inertia: np.ndarray


def mass_properties(mesh, density: float) -> MassProperties:
    """Mass, centre of mass and inertia of the solid bounded by a closed mesh.

    Args:
        mesh: a :class:`pairgrasp.Mesh`, or a ``(vertices (V,3), faces (F,3))`` pair, closed and wound
            outward (as :func:`pairgrasp.load_mesh` returns a watertight file).
        density: kg/m³, finite and > 0.

    Raises:
        ValueError: a density that is not a finite positive number, an empty or open mesh, or a mesh
            that encloses no positive volume (inside out or flat).
    """
    if isinstance(density, bool) or not np.isfinite(density) or density <= 0:
        raise ValueError(f"density: expected a finite number > 0 (kg/m^3), got {density!r}")
    if isinstance(mesh, tuple):
        vertices, faces = mesh
    else:
        vertices, faces = mesh.vertices, mesh.faces
    V = np.asarray(vertices, float).reshape(-1, 3)
    F = np.asarray(faces, np.int64).reshape(-1, 3)
    if len(F) == 0 or len(V) == 0:
        raise ValueError("mesh: no faces, so no volume")
    if F.min() < 0 or F.max() >= len(V):
        raise ValueError(f"mesh: face indices must be in [0, {len(V)})")
    if not _closed(F, len(V)):
        raise ValueError("mesh: not closed (every edge must join exactly two faces, wound oppositely), so it "
                         "bounds no solid")
    apex = V.mean(axis=0)
    u, v, w = (V[F[:, k]] - apex for k in range(3))
    vol = np.einsum("ij,ij->i", u, np.cross(v, w)) / 6.0
    volume = float(vol.sum())
    scale = float(np.abs(V - apex).max()) or 1.0
    if not volume > 1e-9 * scale ** 3:
        raise ValueError(f"mesh: encloses no positive volume ({volume:.3g} m^3); it must be closed and wound outward")
    s = u + v + w
    first = (vol[:, None] * s).sum(axis=0) / 4.0
    second = np.einsum("i,ij,ik->jk", vol, u, u) + np.einsum("i,ij,ik->jk", vol, v, v) \
        + np.einsum("i,ij,ik->jk", vol, w, w) + np.einsum("i,ij,ik->jk", vol, s, s)
    second /= 20.0
    c = first / volume                                  # centre of mass relative to the apex
    cov = second - volume * np.outer(c, c)              # second moment about the centre of mass
    inertia = density * (np.trace(cov) * np.eye(3) - cov)
    inertia = (inertia + inertia.T) / 2.0
    return MassProperties(mass=density * volume, volume=volume, center_of_mass=apex + c, inertia=inertia)


def _closed(F: np.ndarray, n: int) -> bool:
    """Every directed edge appears once and its reverse once: a closed, consistently wound surface."""
    a = F.reshape(-1)
    b = np.roll(F, -1, axis=1).reshape(-1)
    fwd = a * n + b
    if len(np.unique(fwd)) != len(fwd):
        return False
    return bool(np.isin(b * n + a, fwd).all())


def hull_mass_properties(vertices, density: float) -> MassProperties:
    """Mass properties of the convex hull of ``vertices`` (qhull through scipy)."""
    from scipy.spatial import ConvexHull

    V = np.asarray(vertices, float).reshape(-1, 3)
    hull = ConvexHull(V)
    F = hull.simplices.copy()
    c = V[hull.vertices].mean(axis=0)
    a, b, cc = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    flip = np.einsum("ij,ij->i", np.cross(b - a, cc - a), a - c) < 0
    F[flip] = F[flip][:, ::-1]
    return mass_properties((V, F), density)


def pieces_mass_properties(pieces, density: float, resolution: int = 64) -> MassProperties:
    """Mass properties of the union of convex pieces (each the hull of a (K,3) vertex array), which
    may overlap: the pieces' bounding box is cut into cubic cells, ``resolution`` along its longest
    side, and a cell whose centre lies in any piece counts as solid (with its own cube inertia). The
    error falls as 1/resolution (a few per cent of the mass at 64 cells on the bundled targets)."""
    from scipy.spatial import ConvexHull

    if isinstance(density, bool) or not np.isfinite(density) or density <= 0:
        raise ValueError(f"density: expected a finite number > 0 (kg/m^3), got {density!r}")
    hulls = [ConvexHull(np.asarray(p, float).reshape(-1, 3)) for p in pieces]
    if not hulls:
        raise ValueError("pieces: no convex piece, so no volume")
    lo = np.min([h.points.min(axis=0) for h in hulls], axis=0)
    hi = np.max([h.points.max(axis=0) for h in hulls], axis=0)
    a = float((hi - lo).max()) / resolution
    n = np.maximum(1, np.ceil((hi - lo) / a).astype(int))
    axes = [lo[k] + a * (np.arange(n[k]) + 0.5) for k in range(3)]
    P = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    solid = np.zeros(len(P), bool)
    for h in hulls:
        box = np.all((P >= h.points.min(axis=0)) & (P <= h.points.max(axis=0)), axis=1) & ~solid
        idx = np.nonzero(box)[0]
        inside = np.all(P[idx] @ h.equations[:, :3].T + h.equations[:, 3] <= 0, axis=1)
        solid[idx[inside]] = True
    X = P[solid]
    if not len(X):
        raise ValueError("pieces: no cell centre lies inside a piece (the pieces are thinner than a cell)")
    cell = density * a ** 3
    mass = cell * len(X)
    com = X.mean(axis=0)
    D = X - com
    cov = cell * D.T @ D                                   # second moment of the cell centres
    inertia = np.trace(cov) * np.eye(3) - cov + np.eye(3) * mass * a * a / 6.0   # + each cube's own
    return MassProperties(mass=mass, volume=mass / density, center_of_mass=com, inertia=inertia)


def _shells(F: np.ndarray, n: int) -> int:
    """Number of connected components of the faces (through shared vertices)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    a = np.concatenate([F[:, 0], F[:, 1]])
    b = np.concatenate([F[:, 1], F[:, 2]])
    used = np.unique(F)
    k, labels = connected_components(coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n)), directed=False)
    return len(np.unique(labels[used]))


def solid_mass_properties(mesh, density: float, pieces=None, mass=None):
    """Mass properties of a target for the physics check, and where they come from.

    A closed mesh gives its own solid, unless it has several shells whose solid exceeds the union of
    its convex ``pieces`` by 3% (overlapping shells, whose overlap the solid counts twice). A mesh
    that bounds no solid (open or non-manifold) gives its convex hull: measured on closed meshes with
    a hole made in them (docs/physics.md, "Open meshes"), CoACD's pieces of an open mesh are a thin
    shell around its surface (a tenth of an open box's mass), while the hull is exact for convex
    objects and over-fills concave ones (the flask by 43%). With ``mass`` (kg) the shape keeps its
    centre of mass and its inertia is scaled to that mass.

    Returns:
        (MassProperties, source): source is ``"solid"``, ``"convex pieces (overlapping shells)"`` or
        ``"convex hull (not closed)"``, followed by ``", mass given"`` when ``mass`` was.

    Raises:
        ValueError: a mass or density that is not a finite positive number.
    """
    if mass is not None and (isinstance(mass, bool) or not np.isfinite(mass) or mass <= 0):
        raise ValueError(f"mass: expected a finite number > 0 (kg), got {mass!r}")
    props, source = None, "solid"
    if mesh.closed:
        props = mass_properties(mesh, density)
        if pieces is not None and _shells(np.asarray(mesh.faces), len(mesh.vertices)) > 1:
            union = pieces_mass_properties(pieces, density)
            if union.volume < 0.97 * props.volume:
                props, source = union, "convex pieces (overlapping shells)"
    else:
        props, source = hull_mass_properties(mesh.vertices, density), "convex hull (not closed)"
    if mass is not None:
        s = float(mass) / props.mass
        props = MassProperties(mass=float(mass), volume=props.volume, center_of_mass=props.center_of_mass,
                               inertia=props.inertia * s)
        source += ", mass given"
    return props, source
