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

__all__ = ["MassProperties", "mass_properties"]


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
