"""Checks of a planning request that no single file or value reveals: a target at the wrong scale for
the hand (millimetres read as metres), a target that is not watertight."""
from __future__ import annotations

import warnings

import numpy as np

__all__ = ["InputWarning", "check_target_scale", "warn_if_open"]

# A hand grasps a part of an object at most about its own size; an object whose every extent is this
# many times the hand's span (or whose largest is this many times smaller) is at the wrong scale.
MAX_SCALE_RATIO = 50.0
MIN_SCALE_RATIO = 1.0 / 200.0


class InputWarning(UserWarning):
    """An input that is used, but whose results deserve care (e.g. a target that is not watertight)."""


def check_target_scale(target, hand_span: float, name: str) -> None:
    """Raises ValueError when `target` (a Mesh) is far too large or too small for a hand whose
    samples span `hand_span` metres: the usual sign of a mesh in millimetres read as metres, or of
    a scale applied twice."""
    extent = np.ptp(np.asarray(target.bounds, float), axis=0)
    smallest, largest = float(extent.min()), float(extent.max())
    if smallest > MAX_SCALE_RATIO * hand_span:
        raise ValueError(
            f"{name}: every extent of the target is at least {smallest:.4g} m, {smallest / hand_span:.0f} times "
            f"the hand's span of {hand_span:.3g} m; is the mesh in millimetres? Load it with scale=0.001 "
            f"(CLI: --scale 0.001)")
    if largest < MIN_SCALE_RATIO * hand_span:
        raise ValueError(
            f"{name}: the target is at most {largest:.4g} m across, 1/{hand_span / largest:.0f} of the hand's "
            f"span of {hand_span:.3g} m; is it scaled twice? Lengths are metres (CLI: --scale)")


def warn_if_open(target, name: str) -> None:
    """Warns (InputWarning) when `target` is not watertight: penetration is then found from surface
    intersections only (a link wholly inside the target is not seen) and its centre of mass, the
    torque reference of epsilon, is the surface centroid."""
    if not target.closed:
        warnings.warn(
            f"{name}: the target is not watertight ({target.boundary_edges} boundary and "
            f"{target.non_manifold_edges} non-manifold edges): penetration is found from surface intersections "
            f"only and the centre of mass is the surface centroid", InputWarning, stacklevel=3)
