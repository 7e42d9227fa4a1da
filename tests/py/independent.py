"""Independent computations the end-to-end tests check the planner's output against.

Nothing here calls pairgrasp's own geometry or quality code: penetration is measured with trimesh's
signed distance (an R-tree over the triangles, winding by ray tests), box obstacles with the
closed-form signed distance of a box, and epsilon with SciPy's ConvexHull over wrenches built here
from GraspIt's convention. The hand's link meshes and forward kinematics (``Hand.link_poses``) come
from pairgrasp: they are what the planner places, and they are tested on their own in test_hand.py.
"""
import math

import igl
import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError


def to_trimesh(mesh) -> trimesh.Trimesh:
    """A pairgrasp Mesh as a trimesh (the same vertices and faces, nothing merged or fixed)."""
    return trimesh.Trimesh(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, int), process=False)


def link_meshes(hand, wrist_pose, dofs):
    """{link name: trimesh} of every link of the hand at ``dofs``, placed by ``wrist_pose`` (target frame)."""
    poses = np.asarray(hand.link_poses(np.asarray(dofs, float), clamp=False))
    out = {}
    for link, T in zip(hand.links, poses):
        if link.mesh is None or len(link.mesh.faces) == 0:
            continue
        m = to_trimesh(link.mesh)
        m.apply_transform(np.asarray(wrist_pose, float) @ T)
        out[link.name] = m
    return out


def surface_samples(mesh: trimesh.Trimesh, spacing: float, seed: int = 0) -> np.ndarray:
    """The mesh's vertices, edge midpoints and random surface points about ``spacing`` apart."""
    count = int(math.ceil(mesh.area / spacing ** 2))
    pts, _ = trimesh.sample.sample_surface(mesh, max(count, 1), seed=seed)
    mids = mesh.vertices[mesh.edges_unique].mean(axis=1)
    return np.vstack([mesh.vertices, mids, pts])


def signed_distance(mesh: trimesh.Trimesh, points) -> np.ndarray:
    """libigl's signed distance of the points to the closed mesh (m, positive outside, sign by the
    winding number)."""
    p = np.asarray(points, float).reshape(-1, 3)
    if not len(p):
        return np.zeros(0)
    s, _, _ = igl.signed_distance(p, np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64),
                                  sign_type=igl.SIGNED_DISTANCE_TYPE_WINDING_NUMBER)[:3]
    return np.asarray(s, float)


def depth_inside(mesh: trimesh.Trimesh, points) -> float:
    """The largest distance (m) of a point inside the closed mesh from its surface (0 when none is)."""
    s = signed_distance(mesh, points)
    return float(max(-s.min(), 0.0)) if len(s) else 0.0


def distance_to_faces(mesh: trimesh.Trimesh, faces, points) -> np.ndarray:
    """libigl's unsigned distance (m) of each point to the given faces of the mesh."""
    d2, _, _ = igl.point_mesh_squared_distance(np.asarray(points, float), np.asarray(mesh.vertices, float),
                                               np.asarray(mesh.faces, np.int64)[np.asarray(faces)])
    return np.sqrt(np.asarray(d2, float))


def penetration(links: dict, target: trimesh.Trimesh, spacing: float = 7.5e-4) -> float:
    """The deepest point of one surface inside the other, over every link and the target (m): link
    surface samples inside the target, and target surface samples inside each link (a thin part of
    the target can pass through a link without any link sample inside it)."""
    deepest = 0.0
    tpts = surface_samples(target, spacing)
    for m in links.values():
        deepest = max(deepest, depth_inside(target, surface_samples(m, spacing)), depth_inside(m, tpts))
    return deepest


def box_signed_distance(points, lo, hi) -> np.ndarray:
    """Closed-form signed distance to the axis-aligned box [lo, hi] (positive inside), metres."""
    p = np.asarray(points, float)
    c, half = (np.asarray(lo) + np.asarray(hi)) / 2, (np.asarray(hi) - np.asarray(lo)) / 2
    q = np.abs(p - c) - half
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    inside = np.minimum(q.max(axis=1), 0.0)
    return -(outside + inside)


def box_surface_grid(lo, hi, within_lo, within_hi, spacing: float) -> np.ndarray:
    """Points about ``spacing`` apart (edges included) on the faces of the box [lo, hi] that lie in
    the axis-aligned region [within_lo, within_hi]."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    a, b = np.maximum(lo, within_lo), np.minimum(hi, within_hi)
    out = []
    for axis in range(3):
        for side in (lo[axis], hi[axis]):
            if not a[axis] <= side <= b[axis]:
                continue
            u, v = [k for k in range(3) if k != axis]
            if a[u] > b[u] or a[v] > b[v]:
                continue
            gu = np.linspace(a[u], b[u], max(int(np.ceil((b[u] - a[u]) / spacing)) + 1, 2))
            gv = np.linspace(a[v], b[v], max(int(np.ceil((b[v] - a[v]) / spacing)) + 1, 2))
            pts = np.zeros((len(gu) * len(gv), 3))
            pts[:, u], pts[:, v] = np.repeat(gu, len(gv)), np.tile(gv, len(gu))
            pts[:, axis] = side
            out.append(pts)
    return np.vstack(out) if out else np.zeros((0, 3))


def box_clearance(links: dict, lo, hi, spacing: float = 5e-4) -> float:
    """Smallest distance between the hand's links and the box [lo, hi] (m; negative: they overlap):
    link surface samples against the box, and the box's surface samples near each link against it."""
    clear = math.inf
    for m in links.values():
        clear = min(clear, float(-box_signed_distance(surface_samples(m, spacing), lo, hi).max()))
        clear = min(clear, -depth_inside(m, box_surface_grid(lo, hi, m.bounds[0], m.bounds[1], spacing)))
    return clear


def box_mesh_file(path, lo, hi):
    """Writes the box [lo, hi] as an STL file and returns the path."""
    trimesh.creation.box(bounds=[lo, hi]).export(str(path))
    return str(path)


def tangent_basis(n_in):
    """The documented basis, written differently: t1 = n x (e x n) normalised, e the coordinate axis
    least aligned with n (lowest index on ties); t2 = n x t1."""
    e = np.eye(3)[int(np.argmin(np.abs(n_in)))]
    t1 = np.cross(n_in, np.cross(e, n_in))
    t1 = t1 / np.linalg.norm(t1)
    return t1, np.cross(n_in, t1)


def reference_wrenches(P, N, c, r, mu, R, gamma=None, rings=0):
    """Contact wrenches built one by one from the model's definition (module docstring)."""
    out = []
    for p, n in zip(np.asarray(P, float), np.asarray(N, float)):
        n_in = -n / np.linalg.norm(n)
        t1, t2 = tangent_basis(n_in)
        dirs = [(mu * math.cos(2 * math.pi * k / R), mu * math.sin(2 * math.pi * k / R), 0.0)
                for k in range(R)]
        if gamma is not None:
            for j in range(1, rings + 1):
                phi = (math.pi / 2) * j / (rings + 1)
                for sign in (1, -1):
                    dirs += [(a * math.cos(phi), b * math.cos(phi), sign * gamma * math.sin(phi))
                             for a, b, _ in dirs[:R]]
            dirs += [(0.0, 0.0, gamma), (0.0, 0.0, -gamma)]
        for a, b, m in dirs:
            f = n_in + a * t1 + b * t2
            out.append(np.concatenate([f, (np.cross(p - c, f) + m * n_in) / r]))
    return np.array(out)


def epsilon(points, normals, center, radius, mu=0.5, edges=8) -> float:
    """Ferrari-Canny epsilon of the contacts: the origin's distance to the nearest facet of the
    wrench hull when it lies strictly inside, else 0 (also for a hull that spans fewer than 6 dims)."""
    w = reference_wrenches(points, normals, center, radius, mu, edges)
    if len(w) < 7 or np.linalg.matrix_rank(w, tol=1e-9 * np.abs(w).max()) < 6:
        return 0.0
    try:
        hull = ConvexHull(w)
    except QhullError:  # nearly coplanar wrenches (contact patches on flat faces): joggled input
        hull = ConvexHull(w, qhull_options="QJ")
    # qhull's facet equations: a.x + b <= 0 inside, |a| = 1, so -b is the origin's signed distance.
    d = -hull.equations[:, -1]
    return float(d.min()) if d.min() > 0 else 0.0


def force_resistance(points, normals, center, radius, directions, mu=0.5, edges=8) -> np.ndarray:
    """For each unit force direction d, the largest t with (t d, 0) in the wrench hull, from SciPy's
    hull facets: the least offset / a.(d, 0) over the facets the ray meets. All 0 when the origin
    is not strictly inside (as epsilon())."""
    w = reference_wrenches(points, normals, center, radius, mu, edges)
    d = np.asarray(directions, float).reshape(-1, 3)
    if len(w) < 7 or np.linalg.matrix_rank(w, tol=1e-9 * np.abs(w).max()) < 6:
        return np.zeros(len(d))
    try:
        hull = ConvexHull(w)
    except QhullError:
        hull = ConvexHull(w, qhull_options="QJ")
    a, off = hull.equations[:, :3], -hull.equations[:, -1]
    if off.min() <= 0:
        return np.zeros(len(d))
    out = []
    for u in d:
        along = a @ u
        hit = along > 1e-12
        out.append(float(np.min(off[hit] / along[hit])))
    return np.array(out)


def load_resistance(points, normals, center, radius, mu=0.5, edges=8) -> float:
    """The least force_resistance() along +-x, +-y, +-z."""
    return float(force_resistance(points, normals, center, radius, np.vstack([np.eye(3), -np.eye(3)]), mu, edges).min())


def torque_reference(mesh: trimesh.Trimesh):
    """(centre of mass, largest vertex distance from it): the torque origin and scale."""
    c = np.asarray(mesh.center_mass, float)
    return c, float(np.linalg.norm(mesh.vertices - c, axis=1).max())


def closing_push(hand, wrist, dofs, points, normals, links, dirs):
    """pairgrasp.closing_push computed independently, by finite differences of Hand.link_transforms,
    for the closing directions ``dirs`` (+1 / -1 / 0 per DOF). Returns (opposition, drive)."""
    dirs = np.asarray(dirs)
    Wi = np.linalg.inv(wrist)
    T0 = hand.link_transforms(dofs)
    worst = least_drive = None
    for k in np.nonzero(dirs)[0]:
        q1 = np.array(dofs, float)
        h = 1e-6 if hand.dof_lower[k] <= q1[k] + 1e-6 * dirs[k] <= hand.dof_upper[k] else -1e-6
        q1[k] += h * dirs[k]
        T1 = hand.link_transforms(q1)
        push, weight, moved, drive = np.zeros(3), 0.0, [], -1.0
        for p, n, link in zip(points, normals, links):
            x = Wi[:3, :3] @ p + Wi[:3, 3]
            A = np.asarray(T1[link]) @ np.linalg.inv(np.asarray(T0[link]))
            v = wrist[:3, :3] @ (A[:3, :3] @ x + A[:3, 3] - x)
            moving = np.linalg.norm(v) > 1e-9
            moved.append(moving)
            if moving:
                u = v / np.linalg.norm(v) * np.sign(h)
                push += -n * max(0.0, -n @ u)
                weight += max(0.0, -n @ u)
                drive = max(drive, float(-n @ u))
        if weight == 0:
            continue
        o = 1 - np.linalg.norm(push) / weight
        still = [-n for n, m in zip(normals, moved) if not m]
        if still:
            o = max(o, max(float(f @ (-push / np.linalg.norm(push))) for f in still))
        worst = o if worst is None else min(worst, o)
        least_drive = drive if least_drive is None else min(least_drive, drive)
    return (-1.0 if worst is None else worst), (-1.0 if least_drive is None else least_drive)
