"""Convex pieces of a mesh, for physics engines that collide convex shapes only.

A physics engine such as MuJoCo collides every mesh as its convex hull, so a non-convex solid (a
mug, an L-shaped finger) must be given as convex pieces or it collides as a solid hull that fills its
cavities and hooks. :func:`convex_pieces` returns the mesh's own vertices when the mesh is convex
(a closed mesh whose volume is within ``convex_tolerance`` of its hull's), and otherwise the parts of
an approximate convex decomposition by CoACD (the ``coacd`` package of the ``sim`` extra), cached on
disk per mesh and parameters: decomposing the bundled flask takes tens of seconds, reading the cache
milliseconds.

The cache folder is ``$PAIRGRASP_CACHE`` when set, else ``$XDG_CACHE_HOME/pairgrasp`` or
``~/.cache/pairgrasp``; entries are ``coacd-<sha256>.npz`` named by a hash of the vertices, faces,
the parameters and the CoACD version, written atomically, so a changed mesh never reads a stale
entry and a cache shared by several processes stays consistent.
"""
from __future__ import annotations

import hashlib
import os
import tempfile
from typing import List, Optional

import numpy as np

__all__ = ["convex_pieces", "cache_dir", "is_convex"]

# CoACD's concavity threshold (its default): the largest concavity left in a part, relative to the
# mesh's bounding-box diagonal. At 0.05 the bundled mug decomposes into 26 parts that keep its cavity
# and handle open, the flask into 10, the parallel jaw's L-shaped fingers into 3.
DEFAULT_THRESHOLD = 0.05


def cache_dir() -> str:
    """The folder convex decompositions are cached in (see the module documentation)."""
    if os.environ.get("PAIRGRASP_CACHE"):
        return os.environ["PAIRGRASP_CACHE"]
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "pairgrasp")


def _arrays(mesh):
    if isinstance(mesh, tuple):
        vertices, faces = mesh
    else:
        vertices, faces = mesh.vertices, mesh.faces
    V = np.ascontiguousarray(np.asarray(vertices, float).reshape(-1, 3))
    F = np.ascontiguousarray(np.asarray(faces, np.int32).reshape(-1, 3))
    if len(V) < 4 or len(F) < 4:
        raise ValueError(f"mesh: {len(V)} vertices and {len(F)} faces cannot bound a solid")
    if F.min() < 0 or F.max() >= len(V):
        raise ValueError(f"mesh: face indices must be in [0, {len(V)})")
    return V, F


def _hull_volume(points) -> float:
    from scipy.spatial import ConvexHull, QhullError

    try:
        return float(ConvexHull(points).volume)
    except (QhullError, ValueError):
        return 0.0


def _signed_volume(V, F) -> float:
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def is_convex(mesh, closed: Optional[bool] = None, convex_tolerance: float = 1e-3) -> bool:
    """Whether a mesh is convex: it is closed (``closed``: as known to the caller, e.g.
    :attr:`pairgrasp.Mesh.closed`; None: judged by the volume alone) and its enclosed volume is within
    ``convex_tolerance`` (relative) of its convex hull's."""
    V, F = _arrays(mesh)
    if closed is None and not isinstance(mesh, tuple):
        closed = bool(mesh.closed)
    if closed is False:
        return False
    hull = _hull_volume(V)
    return hull > 0 and abs(hull - _signed_volume(V, F)) <= convex_tolerance * hull


def convex_pieces(mesh, threshold: float = DEFAULT_THRESHOLD, seed: int = 0, closed: Optional[bool] = None,
                  cache: Optional[str] = None, use_cache: bool = True) -> List[np.ndarray]:
    """Convex pieces covering a mesh: a list of (K,3) vertex arrays, one per piece (each collides as
    the hull of its vertices).

    Args:
        mesh: a :class:`pairgrasp.Mesh` or a ``(vertices, faces)`` pair (metres).
        threshold: CoACD's concavity threshold (relative to the bounding-box diagonal), in (0, 1].
        seed: CoACD's random seed (the decomposition is deterministic for a seed).
        closed: whether the mesh is closed (None: ``mesh.closed`` for a Mesh, judged by volume for a
            pair).
        cache: the cache folder (None: :func:`cache_dir`).
        use_cache: read and write the cache.

    Raises:
        ValueError: a bad threshold or a mesh with too few vertices or faces.
        ImportError: the mesh is not convex and CoACD is not installed (``pip install .[sim]``).
    """
    if isinstance(threshold, bool) or not (np.isfinite(threshold) and 0 < threshold <= 1):
        raise ValueError(f"threshold: expected a number in (0, 1], got {threshold!r}")
    V, F = _arrays(mesh)
    if is_convex(mesh if closed is None else (V, F), closed=closed):
        return [V.copy()]
    try:
        import coacd
        from importlib.metadata import version
        coacd_version = version("coacd")
    except ImportError:
        raise ImportError("convex decomposition needs CoACD: pip install .[sim]") from None
    key = hashlib.sha256()
    for part in (V.tobytes(), F.tobytes(), f"{threshold!r} {seed} coacd {coacd_version}".encode()):
        key.update(part)
    folder = cache or cache_dir()
    path = os.path.join(folder, f"coacd-{key.hexdigest()}.npz")
    if use_cache and os.path.isfile(path):
        try:
            with np.load(path) as z:
                sizes, points = z["sizes"], z["points"]
            return [p.copy() for p in np.split(points, np.cumsum(sizes)[:-1])]
        except (OSError, ValueError, KeyError):
            pass  # an unreadable entry is recomputed and replaced
    coacd.set_log_level("error")
    parts = coacd.run_coacd(coacd.Mesh(V, F), threshold=float(threshold), seed=int(seed))
    pieces = [np.asarray(p[0], float).reshape(-1, 3) for p in parts]
    pieces = [p for p in pieces if len(p) >= 4 and _hull_volume(p) > 0.0]
    if not pieces:
        pieces = [V.copy()]
    if use_cache:
        os.makedirs(folder, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".coacd-", suffix=".npz", dir=folder)
        try:
            with os.fdopen(fd, "wb") as fh:
                np.savez(fh, sizes=np.array([len(p) for p in pieces]), points=np.concatenate(pieces))
            os.replace(tmp, path)
        except BaseException:
            if os.path.exists(tmp):
                os.remove(tmp)
            raise
    return pieces
