"""Planned grasps in 3-D: an interactive scene in the browser, or a glTF file.

``pairgrasp view OUTDIR/grasps.json`` serves the scene with viser (the optional extra
``pip install pairgrasp[view]``) and ``pairgrasp view OUTDIR/grasps.json --export scene.glb`` writes it
as binary glTF with trimesh, which any glTF viewer opens (viser is not needed for that).

The scene is built from grasps.json alone: the hand spec, the target, the paint file, the occluders,
the viewpoints and the obstacles recorded under ``inputs`` (paths relative to the current folder or to
the file's folder, as ``pairgrasp simulate`` reads them; ``hand`` / ``target`` override them). It holds

* ``target``: the target mesh as loaded (free faces grey), and ``target/occluded``: its occluded faces
  (orange), a copy lifted off the surface by 1/2000 of the target's size so that it draws over it;
* ``obstacle<k>`` and ``occluder<k>``: the plan's obstacles and occluders, translucent;
* per grasp of rank K: a node ``grasp<K>`` at the wrist pose and under it one node ``grasp<K>/<link>``
  per link with geometry, at ``Hand.link_poses(dofs)`` (the link meshes in their own frames);
  ``grasp<K>/contacts`` (a small sphere per contact, red) and ``grasp<K>/normals`` (a short segment
  along each contact's outward target normal, green), both in the target frame.

Each grasp's rank, epsilon, force closure, Q_A, votes, penetration and, when ``pairgrasp simulate``
has run, the simulation outcome are shown in the viewer's panel and written into the glTF file's
scene ``extras`` (``grasps``). Lengths are metres; z is up.
"""
from __future__ import annotations

import math
import os
import time
import warnings
from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np

from . import _core
from .render import CONTACT_COLOR, FREE_COLOR, HAND_COLOR, OCCLUDED_COLOR
from .grasps_file import resolve_path

__all__ = ["Part", "SceneGrasp", "Scene", "load_scene", "to_trimesh", "export_glb", "serve"]

_NORMAL = (0.10, 0.60, 0.20)
_OBSTACLE = (0.55, 0.45, 0.35, 0.45)
_OCCLUDER = (0.60, 0.60, 0.70, 0.35)
VIEW_EXTRA = "pip install pairgrasp[view] (from a source tree: pip install .[view])"


@dataclass
class Part:
    """One mesh of the scene.

    Attributes:
        name: node name (``target``, ``grasp1/bh_palm``, ...).
        vertices, faces: the mesh in the part's own frame, metres.
        transform: 4x4 pose of that frame in its parent's frame (the target frame, or the wrist
            frame of ``parent``).
        color: RGBA in [0, 1].
        parent: ``grasp<K>`` for hand links, None for parts in the target frame.
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    transform: np.ndarray
    color: tuple
    parent: Optional[str] = None


@dataclass
class SceneGrasp:
    """One grasp of the scene: ``wrist_pose`` (target frame), its link parts (wrist frame), the
    contacts and normals as parts (target frame), and ``info`` (what the panel shows)."""

    rank: int
    node: str
    wrist_pose: np.ndarray
    links: List[Part]
    contacts: Optional[Part]
    normals: Optional[Part]
    contact_points: np.ndarray
    contact_normals: np.ndarray
    info: dict
    summary: str


@dataclass
class Scene:
    """A grasps.json file as a scene (:func:`load_scene`)."""

    path: str
    title: str
    parts: List[Part]
    grasps: List[SceneGrasp]
    center: np.ndarray
    bounds: np.ndarray
    size: float
    normal_length: float
    notes: List[str] = field(default_factory=list)

    def grasp(self, rank: int) -> SceneGrasp:
        for g in self.grasps:
            if g.rank == rank:
                return g
        have = ", ".join(str(g.rank) for g in self.grasps) or "none"
        raise ValueError(f"--rank: {self.path} has no grasp of rank {rank} (ranks: {have})")


def _sphere():
    """A unit icosphere (42 vertices, 80 faces)."""
    t = (1.0 + 5 ** 0.5) / 2.0
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
                  [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
                  [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], int)
    verts = list(v / np.linalg.norm(v, axis=1, keepdims=True))
    mid = {}
    faces = []
    for a, b, c in f:
        ab, bc, ca = [_midpoint(verts, mid, i, j) for i, j in ((a, b), (b, c), (c, a))]
        faces += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
    return np.array(verts), np.array(faces, int)


def _midpoint(verts, cache, i, j):
    key = (min(i, j), max(i, j))
    if key not in cache:
        m = verts[i] + verts[j]
        verts.append(m / np.linalg.norm(m))
        cache[key] = len(verts) - 1
    return cache[key]


def _spheres(points: np.ndarray, radius: float):
    sv, sf = _sphere()
    n = len(points)
    v = (points[:, None, :] + radius * sv[None]).reshape(-1, 3)
    f = (sf[None] + (np.arange(n) * len(sv))[:, None, None]).reshape(-1, 3)
    return v, f


def _segments(points: np.ndarray, directions: np.ndarray, length: float, radius: float):
    """Thin triangular prisms from each point along its direction (glTF lines draw 1 px wide in most
    viewers, so the normals are solids)."""
    d = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    a = np.where(np.abs(d[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(d, a)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    w = np.cross(d, u)
    ring = [radius * (math.cos(k * 2 * math.pi / 3) * u + math.sin(k * 2 * math.pi / 3) * w) for k in range(3)]
    base = np.stack([points + r for r in ring], axis=1)                 # (N, 3, 3)
    tip = base + length * d[:, None, :]
    v = np.concatenate([base, tip], axis=1).reshape(-1, 3)              # 6 per segment
    one = np.array([[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4], [2, 0, 3], [2, 3, 5], [0, 2, 1], [3, 4, 5]], int)
    f = (one[None] + (np.arange(len(points)) * 6)[:, None, None]).reshape(-1, 3)
    return v, f


def _summary(g, sim: Optional[dict]) -> str:
    text = (f"rank {g.rank}: ε {g.epsilon:.4f}, force closure {'yes' if g.force_closure else 'no'}, "
            f"Q_A {g.alignment_quality:.3f}, {g.votes} votes, penetration {1000 * g.penetration_depth:.2f} mm, "
            f"{len(g.contact_points)} contacts")
    if sim:
        text += f"; simulated: {sim.get('outcome', '?')}"
        slip, turn = sim.get("slip_translation"), sim.get("slip_rotation")
        if isinstance(slip, (int, float)) and isinstance(turn, (int, float)):
            text += f" (slip {1000 * slip:.2f} mm, turn {math.degrees(turn):.1f}°)"
    return text


def load_scene(path, hand=None, target=None) -> Scene:
    """Builds the scene of a grasps.json file (see the module's documentation).

    Raises:
        pairgrasp.FileError: a missing or malformed grasps file, or a recorded input that is missing.
        ValueError: a hand other than the one the grasps were planned for, or a target with another
            number of faces.
    """
    from .grasps_file import load_planned, recorded_free_surface, recorded_support

    path = os.fspath(path)
    given = target
    planned = load_planned(path, hand, target)
    gf, hand, scale, base = planned.grasps, planned.hand, planned.scale, planned.base
    inputs = gf.inputs
    target_name = given if given is not None else inputs.get("target")
    notes: List[str] = []
    surface, occluders = recorded_free_surface(planned, path, notes)
    target, free = surface.mesh, np.asarray(surface.free, bool)
    support = recorded_support(inputs)

    tv = np.asarray(target.vertices, float)
    tf = np.asarray(target.faces, np.int64)
    lo, hi = tv.min(axis=0), tv.max(axis=0)
    size = float(np.linalg.norm(hi - lo)) or 0.1
    eye = np.eye(4)
    parts = [Part("target", tv, tf, eye, (*FREE_COLOR, 1.0))]
    if not free.all():
        occ_faces = tf[~free]
        tri = tv[occ_faces]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        tri = tri + (size / 2000.0) * n[:, None, :]
        parts.append(Part("target/occluded", tri.reshape(-1, 3), np.arange(3 * len(tri)).reshape(-1, 3), eye,
                          (*OCCLUDED_COLOR, 1.0)))
    for k, o in enumerate(inputs.get("obstacles") or []):
        if o == "<mesh>":
            notes.append(f"inputs.obstacles[{k}] was an in-memory mesh: not shown")
            continue
        m = _core.load_mesh(resolve_path(o, base, f"{path}: inputs.obstacles[{k}]"), scale=scale)
        parts.append(Part(f"obstacle{k + 1}", np.asarray(m.vertices, float), np.asarray(m.faces, np.int64), eye,
                          _OBSTACLE))
    for k, m in enumerate(occluders):
        parts.append(Part(f"occluder{k + 1}", np.asarray(m.vertices, float), np.asarray(m.faces, np.int64), eye,
                          _OCCLUDER))
    if support is not None:
        m = _core.support_box(support, planned.target, 0.5 * size)
        parts.append(Part("support", np.asarray(m.vertices, float), np.asarray(m.faces, np.int64), eye, _OBSTACLE))

    edge = gf.parameters.get("edge")
    edge = float(edge) if isinstance(edge, (int, float)) and edge > 0 else size / 40.0
    radius, length = edge / 4.0, 2.0 * edge
    grasps = []
    raw = gf.document.get("grasps", [])
    for g, d in zip(gf.grasps, raw):
        node = f"grasp{g.rank}"
        poses = np.asarray(hand.link_poses(np.asarray(g.dofs, float), clamp=True), float)
        links = []
        for link, T in zip(hand.links, poses):
            m = link.mesh
            if m is None or len(m.faces) == 0:
                continue
            links.append(Part(f"{node}/{link.name}", np.asarray(m.vertices, float), np.asarray(m.faces, np.int64),
                              T, (*HAND_COLOR, 1.0), parent=node))
        pts, nrm = np.asarray(g.contact_points, float), np.asarray(g.contact_normals, float)
        contacts = normals = None
        if len(pts):
            v, f = _spheres(pts, radius)
            contacts = Part(f"{node}/contacts", v, f, eye, (*CONTACT_COLOR, 1.0))
            v, f = _segments(pts, nrm, length, radius / 4.0)
            normals = Part(f"{node}/normals", v, f, eye, (*_NORMAL, 1.0))
        sim = d.get("simulation") if isinstance(d.get("simulation"), dict) else None
        info = {"rank": g.rank, "epsilon": g.epsilon, "force_closure": g.force_closure,
                "alignment_quality": g.alignment_quality, "votes": g.votes,
                "penetration_depth": g.penetration_depth, "contacts": len(pts), "dof": [float(x) for x in g.dofs]}
        if sim:
            info["simulation"] = {k: sim[k] for k in ("outcome", "success", "slip_translation", "slip_rotation")
                                  if k in sim}
        grasps.append(SceneGrasp(g.rank, node, np.asarray(g.wrist_pose, float), links, contacts, normals, pts, nrm,
                                 info, _summary(g, sim)))
    title = f"{hand.name} on {os.path.basename(str(target_name or 'the target'))}"
    return Scene(path=path, title=title, parts=parts, grasps=grasps, center=(lo + hi) / 2.0,
                 bounds=np.array([lo, hi]), size=size,
                 normal_length=length, notes=notes)


def _select(scene: Scene, rank) -> List[SceneGrasp]:
    """``rank``: None (rank 1, or the first grasp), an int, or "all"."""
    if rank == "all":
        return list(scene.grasps)
    if rank is None:
        return scene.grasps[:1]
    return [scene.grasp(int(rank))]


def _import_trimesh():
    try:
        import trimesh
    except ImportError:
        raise ImportError(f"the glTF export needs trimesh: {VIEW_EXTRA}") from None
    return trimesh


def to_trimesh(scene: Scene, rank=None):
    """The scene as a ``trimesh.Scene``: the target, occluded faces, obstacles and occluders, and the
    grasp of ``rank`` (default: rank 1; ``"all"``: every grasp, each under its own ``grasp<K>`` node)."""
    trimesh = _import_trimesh()
    from trimesh.visual.material import PBRMaterial

    out = trimesh.Scene()
    base = out.graph.base_frame

    def add(part: Part, parent: str):
        rgba = [float(c) for c in part.color]
        mat = PBRMaterial(name=part.name, baseColorFactor=rgba, metallicFactor=0.0, roughnessFactor=0.8,
                          alphaMode="BLEND" if rgba[3] < 1.0 else "OPAQUE", doubleSided=rgba[3] < 1.0)
        mesh = trimesh.Trimesh(part.vertices, part.faces, process=False,
                               visual=trimesh.visual.TextureVisuals(material=mat))
        out.add_geometry(mesh, node_name=part.name, geom_name=part.name, parent_node_name=parent,
                         transform=part.transform)

    for p in scene.parts:
        add(p, base)
    chosen = _select(scene, rank)
    for g in chosen:
        out.graph.update(frame_to=g.node, frame_from=base, matrix=g.wrist_pose)
        for p in g.links:
            add(p, g.node)
        for p in (g.contacts, g.normals):
            if p is not None:
                add(p, base)
    out.metadata.update({"title": scene.title, "source": os.path.basename(scene.path),
                         "grasps": [g.info for g in chosen]})
    return out


def export_glb(scene: Scene, out_path, rank=None) -> str:
    """Writes :func:`to_trimesh` as binary glTF to ``out_path`` (atomically; its folder is created).
    Returns a one-line description of what was written."""
    out_path = os.fspath(out_path)
    if not out_path.lower().endswith(".glb"):
        raise ValueError(f"--export: expected a .glb file name, got {out_path}")
    if os.path.isdir(out_path):
        raise ValueError(f"--export: {out_path} is a directory")
    tscene = to_trimesh(scene, rank)
    data = tscene.export(file_type="glb")
    parent = os.path.dirname(os.path.abspath(out_path))
    os.makedirs(parent, exist_ok=True)
    tmp = f"{out_path}.part"
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
        os.replace(tmp, out_path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    chosen = _select(scene, rank)
    what = ", ".join(f"rank {g.rank}" for g in chosen) or "no grasp"
    return f"wrote {out_path}: {scene.title}, {what}; {len(tscene.geometry)} meshes"


def import_viser():
    """Imports viser, or raises ImportError naming the extra to install."""
    try:
        import viser
    except ImportError:
        raise ImportError(f"the interactive viewer needs viser: {VIEW_EXTRA}; "
                          f"--export FILE.glb works without it") from None
    return viser


def serve(scene: Scene, host: str = "127.0.0.1", port: int = 8080, rank=None, on_ready=None):
    """Serves the scene with viser and returns the server (it runs in background threads; call
    ``server.stop()``). A slider picks the grasp by rank; checkboxes show every grasp, the hand,
    the contacts and normals, the obstacles. ``on_ready(url)`` is called once it listens."""
    viser = import_viser()
    from viser import transforms as vtf

    server = viser.ViserServer(host=host, port=port, verbose=False)
    server.scene.set_up_direction("+z")
    c, s = scene.center, scene.size
    server.initial_camera.position = tuple(c + s * np.array([1.0, -1.3, 0.9]))
    server.initial_camera.look_at = tuple(c)
    server.initial_camera.near = s / 200.0
    server.initial_camera.far = s * 200.0
    server.scene.add_grid("/grid", width=4 * s, height=4 * s, cell_size=s / 10, section_size=s / 2,
                          position=(c[0], c[1], scene.bounds[0, 2]))

    def pose(T):
        return vtf.SO3.from_matrix(np.asarray(T)[:3, :3]).wxyz, np.asarray(T)[:3, 3]

    def add(name, part: Part):
        wxyz, pos = pose(part.transform)
        rgb = tuple(int(round(255 * x)) for x in part.color[:3])
        return server.scene.add_mesh_simple(name, part.vertices.astype(np.float32), part.faces.astype(np.uint32),
                                            color=rgb, opacity=part.color[3] if part.color[3] < 1 else None,
                                            side="double", wxyz=wxyz, position=pos)

    statics = {p.name: add("/" + p.name, p) for p in scene.parts}
    nodes, parts = {}, {}
    for g in scene.grasps:
        nodes[g.rank] = server.scene.add_frame(f"/{g.node}", show_axes=False)
        wxyz, pos = pose(g.wrist_pose)
        wrist = server.scene.add_frame(f"/{g.node}/wrist", axes_length=s / 8, axes_radius=s / 400,
                                       wxyz=wxyz, position=pos)
        links = [add(f"/{g.node}/wrist/{p.name.split('/', 1)[1]}", p) for p in g.links]
        contacts = add(f"/{g.node}/contacts", g.contacts) if g.contacts is not None else None
        normals = None
        if len(g.contact_points):
            seg = np.stack([g.contact_points, g.contact_points + scene.normal_length * g.contact_normals], axis=1)
            normals = server.scene.add_line_segments(f"/{g.node}/normals", seg.astype(np.float32),
                                                     colors=tuple(int(255 * x) for x in _NORMAL), thickness=2.0,
                                                     thickness_units="screen")
        parts[g.rank] = dict(wrist=wrist, links=links, contacts=contacts, normals=normals)

    gui = server.gui
    gui.add_markdown(f"**{scene.title}**  \n`{os.path.basename(scene.path)}`: {len(scene.grasps)} grasps")
    ranks = [g.rank for g in scene.grasps]
    first = _select(scene, None if rank == "all" else rank)
    info = gui.add_markdown(first[0].summary if first else "no grasps in this file")
    slider = None
    if len(ranks) > 1:
        slider = gui.add_slider("grasp (rank)", min=1, max=len(ranks), step=1,
                                initial_value=ranks.index(first[0].rank) + 1)
    every = gui.add_checkbox("every grasp", initial_value=rank == "all")
    show_hand = gui.add_checkbox("hand", initial_value=True)
    show_contacts = gui.add_checkbox("contacts and normals", initial_value=True)
    show_others = gui.add_checkbox("obstacles and occluders", initial_value=True)
    for note in scene.notes:
        gui.add_markdown(f"_note: {note}_")

    def refresh(_=None):
        current = ranks[int(slider.value) - 1] if slider is not None else (ranks[0] if ranks else None)
        for r in ranks:
            nodes[r].visible = every.value or r == current
            p = parts[r]
            p["wrist"].visible = show_hand.value
            for h in (p["contacts"], p["normals"]):
                if h is not None:
                    h.visible = show_contacts.value
        for name, h in statics.items():
            if name.startswith(("obstacle", "occluder")):
                h.visible = show_others.value
        if current is not None:
            info.content = scene.grasp(current).summary

    for control in (slider, every, show_hand, show_contacts, show_others):
        if control is not None:
            control.on_update(refresh)
    refresh()
    url = f"http://{'localhost' if host in ('0.0.0.0', '::') else host}:{server.get_port()}"
    if on_ready:
        on_ready(url)
    return server


def run(scene: Scene, host: str = "127.0.0.1", port: int = 8080, rank=None, out=None) -> int:
    """Serves the scene until Ctrl-C (what ``pairgrasp view`` does); ``out`` prints the URL line."""
    out = out or (lambda line: print(line, flush=True))
    server = serve(scene, host, port, rank,
                   on_ready=lambda url: out(f"viewing {scene.path} ({scene.title}, {len(scene.grasps)} grasps) "
                                            f"at {url} (Ctrl-C to stop)"))
    for note in scene.notes:
        warnings.warn(f"{scene.path}: {note}")
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
    return 0
