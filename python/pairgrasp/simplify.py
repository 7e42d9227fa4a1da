"""Simplifying a large target before it is tessellated.

A scanned or CAD-exported mesh may carry 10^5-10^6 triangles, far finer than the planner's unit
facets (h = 5 mm): the tessellation, the collision hierarchy and the distance fields then pay for
detail the plan cannot see, and scanner noise on tiny triangles turns every triangle into a facet of
its own (the facets keep to faces whose normals are within 60 degrees). :func:`simplify_mesh`
reduces such a mesh by quadric edge collapse (``fast-simplification``, the Fast Quadric Mesh
Simplification library) and measures what that cost: the *error bound* is the larger of the largest
distance of an original vertex or face centre to the simplified surface and of a simplified vertex
or face centre to the original surface (a Hausdorff distance sampled at vertices and face centres,
:class:`pairgrasp.SurfaceQuery`). When the bound exceeds ``max_error`` the reduction is halved until
it fits, or the mesh is left as it is.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from . import _core

__all__ = ["Simplification", "simplify_mesh"]


@dataclass(frozen=True)
class Simplification:
    """What :func:`simplify_mesh` did.

    Attributes:
        faces_before: faces of the mesh given.
        faces: faces of the simplified mesh (``faces_before`` when it was left as it is).
        error_bound: m, the sampled Hausdorff distance between the two surfaces (0 when unchanged).
        method: the library and version that simplified it.
    """

    faces_before: int
    faces: int
    error_bound: float
    method: str

    def to_dict(self) -> dict:
        return {"faces_before": self.faces_before, "faces": self.faces,
                "error_bound": round(float(self.error_bound), 9), "method": self.method}


def _samples(mesh) -> np.ndarray:
    V, F = np.asarray(mesh.vertices, float), np.asarray(mesh.faces)
    return np.concatenate([V, V[F].mean(axis=1)])


def surface_distance(a, b) -> float:
    """Largest distance of a vertex or face centre of either mesh to the other's surface, m."""
    return max(float(np.max(np.asarray(_core.SurfaceQuery(y).distance(_samples(x)))))
               for x, y in ((a, b), (b, a)))


def simplify_mesh(mesh, max_faces: int, max_error: float) -> Tuple[object, Optional[Simplification]]:
    """``mesh`` reduced towards ``max_faces`` faces when it has more (the collapses stop early where
    they would distort it, so a few more may remain), within ``max_error`` (m).

    Returns:
        (mesh, Simplification): the simplified :class:`pairgrasp.Mesh` (cleaned and oriented as
        :func:`pairgrasp.make_mesh` does) and what was done; ``(mesh, None)`` when the mesh has at
        most ``max_faces`` faces. A mesh that no reduction keeps within ``max_error`` comes back as
        it is, with ``faces == faces_before``.

    Raises:
        ImportError: fast-simplification is not installed.
    """
    n = len(mesh.faces)
    if n <= max_faces:
        return mesh, None
    import fast_simplification
    from importlib.metadata import version

    method = f"quadric edge collapse (fast-simplification {version('fast-simplification')})"
    V = np.array(mesh.vertices, float, order="C")              # writable copies: the library needs them
    F = np.array(mesh.faces, np.int64, order="C")
    target = max_faces
    while target < n:
        V2, F2 = fast_simplification.simplify(V, F, target_reduction=1.0 - target / n, agg=1)
        try:
            small = _core.make_mesh(np.asarray(V2, float), np.asarray(F2, np.int64), mesh.source)
        except ValueError:
            small = None
        if small is not None:
            err = surface_distance(mesh, small)
            if err <= max_error:
                return small, Simplification(n, len(small.faces), err, method)
        target *= 2
    return mesh, Simplification(n, n, 0.0, method)
