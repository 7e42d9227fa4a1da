"""Checks of a planning request that no single file or value reveals: a target that is not watertight.
(A target at the wrong scale for the hand, millimetres read as metres, is refused in C++ by
``resolve_planner``.)"""
from __future__ import annotations

import warnings

__all__ = ["InputWarning", "warn_if_open"]


class InputWarning(UserWarning):
    """An input that is used, but whose results deserve care (e.g. a target that is not watertight)."""


def warn_if_open(target, name: str) -> None:
    """Warns (InputWarning) when `target` is not watertight: penetration is then found from surface
    intersections only (a link wholly inside the target is not seen) and its centre of mass, the
    torque reference of epsilon, is the surface centroid."""
    if not target.closed:
        warnings.warn(
            f"{name}: the target is not watertight ({target.boundary_edges} boundary and "
            f"{target.non_manifold_edges} non-manifold edges): penetration is found from surface intersections "
            f"only and the centre of mass is the surface centroid", InputWarning, stacklevel=3)
