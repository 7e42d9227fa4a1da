"""Whether a grasp's closing fingers come to rest at its planned contacts.

A hand closes by driving each closing DOF with its actuator until the fingers stall against the
object. The physics check's actuators do exactly that (each pushes with its joint's URDF ``effort``,
docs/physics.md), and so do the motors of a real hand. Before any load, the object then stays where
the plan put it only if contact forces inside the friction cones can balance those stall torques and
one another. :func:`closing_friction` asks for the least friction coefficient at which they can: a
grasp that needs more than its contacts have is pushed along while the fingers close, until it
comes to rest somewhere the plan did not put it. In the physics check it ordered the grasps of one
plan by how often they held better than epsilon or the load resistance on the held-out objects' dev
half, and worse than chance on the test half, so no ranking uses it (docs/physics.md).
"""
from __future__ import annotations

import numpy as np

from . import _core
from .quality import _count, _real

__all__ = ["closing_friction"]


def closing_friction(hand, wrist_pose, dofs, points, normals, links, center, mu_max: float = 2.0, edges: int = 8,
                     tolerance: float = 1e-3) -> float:
    """The least friction coefficient at which the closing DOFs, each pushing with its stall torque,
    are balanced by contact forces at the grasp's contacts, with no load on the object.

    Each closing DOF (:func:`pairgrasp.closing_directions`) that moves a contact pushes with
    ``|ratio| * effort`` of its first joint (the URDF effort), as the physics check's actuator does
    (all equal when one has none): the work it does per unit of closing equals that of the contact
    forces on the contacts it moves. DOFs that do not close the
    hand (the Barrett spread) and links no DOF moves (the palm) push back with whatever force
    balance needs. The forces lie in the friction pyramids of :mod:`pairgrasp.quality` and add up to
    no net force and no net torque about ``center``.

    Args:
        hand: :class:`pairgrasp.Hand`.
        wrist_pose: (4, 4) wrist frame in the target frame (m).
        dofs: (D,) closed DOF values, within the hand's limits.
        points, normals: (C, 3) contacts and the target's OUTWARD normals there (the planner's
            ``Grasp.contact_points`` and ``contact_normals``).
        links: (C,) the hand link of each contact, by name or by index into ``Hand.links``.
        center: (3,) the torque origin, the target's centre of mass (m).
        mu_max: the largest coefficient tried.
        edges: edges of each friction pyramid.
        tolerance: the answer's accuracy (bisection; each trial coefficient is a non-negative
            least-squares feasibility test, in C++: ``closing_friction()`` of ``grasp.hpp``).

    Returns:
        The coefficient in [0, mu_max] (0: the normal forces alone balance; above the contacts' own
        friction, the closing fingers push the object along), ``inf`` when even ``mu_max`` does not
        balance them (a single finger pushing the object away), ``nan`` when no closing DOF moves a
        contact (nothing is pushed).

    Raises:
        ValueError: malformed input, naming the argument; DOF values outside the limits.
    """
    p = np.asarray(points, float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points: expected an array of shape (N, 3), got shape {p.shape}")
    if len(links) != len(p):
        raise ValueError(f"links: expected {len(p)} links, one per contact, got {len(links)}")
    index = []
    for link in links:
        i = hand.link_index(link) if isinstance(link, str) else (int(link) if isinstance(link, (int, np.integer))
                                                                 and not isinstance(link, bool) else -1)
        if not 0 <= i < len(hand.links):
            raise ValueError(f"links: {link!r} is not a link with geometry of hand {hand.name}")
        index.append(i)
    mu_max = _real("mu_max", mu_max, low=0.0, strict=True)
    tolerance = _real("tolerance", tolerance, low=0.0, strict=True)
    return float(_core._closing_friction(hand, wrist_pose, dofs, p, np.asarray(normals, float), index,
                                         center, mu_max, _count("edges", edges, 3), tolerance))
