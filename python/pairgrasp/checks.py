"""Checks of a planning request that no single file or value reveals: a target that is not watertight,
a target far larger than the hand. (A target at the wrong scale for the hand, millimetres read as
metres, is refused in C++ by ``resolve_planner``; distance fields over the memory budget are refused by
``GraspPlanner``.)"""
from __future__ import annotations

import warnings

__all__ = ["InputWarning", "warn_if_open", "warn_if_large"]


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


def warn_if_large(target, span: float, name: str) -> None:
    """Warns (InputWarning) when the largest extent of `target` is over 5 times `span`, the largest
    distance between the hand's contacts (:func:`pairgrasp.hand_span`): the whole free surface is
    indexed and given distance fields, though a grasp touches only a hand-sized part of it, so the
    set-up takes long (tens of seconds for a 1.5 m box). Said before anything is built. Silent when every
    extent is over 50 spans: the planner refuses such a target as being in the wrong units."""
    v = target.vertices
    if len(v) == 0 or not span > 0:
        return
    extent = v.max(axis=0) - v.min(axis=0)
    largest = float(extent.max())
    if largest > 5.0 * span and not float(extent.min()) > 50.0 * span:
        warnings.warn(
            f"{name}: the target is {largest:.3g} m across, {largest / span:.0f} times the hand's span of {span:.3g} m; "
            f"its whole free surface is indexed, so the set-up may take long: leave only the part within reach free "
            f"(paint, occluders) to plan faster", InputWarning, stacklevel=3)
