"""A hand folder from a MuJoCo model (``pairgrasp hand import``): the subtree below one body of an
MJCF (or a URDF MuJoCo reads) written as a URDF, its geometry as STL files, and a proposed spec.

MuJoCo compiles the model (``<include>``, defaults, mesh assets, ``euler``/``quat``/``axisangle``
frames, angle units are all resolved by :class:`mujoco.MjModel`); this module reads the compiled
model only.

* **Links**: one per body of the subtree, named as the body. A body's frame becomes its link's
  frame when the body has no joint; with joints, the link frame sits at the last joint's anchor
  (URDF turns a link about its own origin, MuJoCo about an anchor), and a body with several joints
  gets one massless-looking intermediate link per extra joint (``<body>__<joint>``, mass 1e-6 kg).
* **Joints**: hinge → ``revolute``, slide → ``prismatic``, with the joint's range (an unlimited
  hinge gets [-pi, pi]). Angles are measured from the joint's ``ref`` (MuJoCo turns a body by
  ``qpos - qpos0``), so a URDF angle u is ``qpos - ref``. Ball and free joints are refused.
* **Couplings** become ``<mimic>``: a joint equality with a linear polynomial (MuJoCo's
  ``y - y0 = a0 + a1 (x - x0)``); a tendon equality on a fixed tendon of two joints; and a fixed
  tendon of two joints limited to a range narrower than a tenth of the lengths its joints sweep
  (the Shadow hand's distal joints), taken at the middle of that range. The joint with the larger
  index (the one deeper in the tree) follows. A joint equality with no second joint locks its
  joint: it becomes ``fixed`` at that angle. Anything else that ties bodies of the hand (a
  polynomial coupling, connect and weld constraints that close a loop, tendons of more joints) is
  refused with one line naming it.
* **Geometry**: the collision geoms (``contype`` or ``conaffinity`` non-zero; the visual ones when a
  link has none) of each body, meshes as MuJoCo holds them and primitives (box, sphere, capsule,
  cylinder, ellipsoid) tessellated, merged into one STL per link in the link frame.
"""
from __future__ import annotations

import json
import math
import os
import re
import shutil
import xml.etree.ElementTree as ET
from typing import Dict, List, Optional, Tuple

import numpy as np

_NARROW = 0.1          # a two-joint tendon limited to less than this share of its swept length couples
_INTERMEDIATE_MASS = 1e-6
_LINEAR_TOL = 1e-12


def _mujoco():
    try:
        import mujoco
        import trimesh  # noqa: F401  (the links' meshes)
    except ImportError as e:
        raise RuntimeError(f"hand import needs MuJoCo and trimesh ({e.name} is missing): "
                           "pip install .[sim]") from None
    return mujoco


def _quat_matrix(q) -> np.ndarray:
    w, x, y, z = (float(v) for v in q)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _pose(pos=(0, 0, 0), quat=(1, 0, 0, 0)) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = _quat_matrix(quat)
    T[:3, 3] = pos
    return T


def _axis_angle(axis, angle) -> np.ndarray:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    T = np.eye(4)
    T[:3, :3] = np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K
    return T


def _rpy(R) -> Tuple[float, float, float]:
    """URDF's roll-pitch-yaw (R = Rz(yaw) Ry(pitch) Rx(roll))."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if abs(math.cos(pitch)) < 1e-9:       # gimbal lock: roll absorbed into yaw
        return 0.0, pitch, math.atan2(-R[0, 1], R[1, 1])
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def _origin(parent: ET.Element, T: np.ndarray) -> None:
    r = _rpy(T[:3, :3])
    ET.SubElement(parent, "origin", xyz=" ".join(f"{v:.17g}" for v in T[:3, 3]),
                  rpy=" ".join(f"{v:.17g}" for v in r))


def _name(m, mujoco, obj, i: int, prefix: str) -> str:
    return mujoco.mj_id2name(m, obj, i) or f"{prefix}{i}"


def _geom_mesh(m, mujoco, g: int):
    """The geom's triangles in its body's frame (trimesh), or None for a type with no surface to grasp."""
    import trimesh

    t, size = int(m.geom_type[g]), np.asarray(m.geom_size[g], float)
    G = mujoco.mjtGeom
    if t == G.mjGEOM_MESH:
        k = int(m.geom_dataid[g])
        v = np.asarray(m.mesh_vert[m.mesh_vertadr[k]:m.mesh_vertadr[k] + m.mesh_vertnum[k]], float)
        f = np.asarray(m.mesh_face[m.mesh_faceadr[k]:m.mesh_faceadr[k] + m.mesh_facenum[k]], int)
        mesh = trimesh.Trimesh(v, f, process=False)
    elif t == G.mjGEOM_BOX:
        mesh = trimesh.creation.box(extents=2 * size)
    elif t == G.mjGEOM_SPHERE:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    elif t == G.mjGEOM_ELLIPSOID:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        mesh.apply_scale(size)
    elif t == G.mjGEOM_CAPSULE:
        mesh = trimesh.creation.capsule(height=2 * size[1], radius=size[0], count=[16, 8])
    elif t == G.mjGEOM_CYLINDER:
        mesh = trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=24)
    else:
        return None
    mesh.apply_transform(_pose(m.geom_pos[g], m.geom_quat[g]))
    return mesh


class _Joint:
    def __init__(self, m, mujoco, j: int):
        self.id = j
        self.name = _name(m, mujoco, mujoco.mjtObj.mjOBJ_JOINT, j, "joint")
        self.type = int(m.jnt_type[j])
        self.body = int(m.jnt_bodyid[j])
        self.pos = np.asarray(m.jnt_pos[j], float)
        self.axis = np.asarray(m.jnt_axis[j], float)
        self.ref = float(m.qpos0[m.jnt_qposadr[j]])
        self.limited = bool(m.jnt_limited[j])
        self.range = np.asarray(m.jnt_range[j], float)
        self.mimic: Optional[Tuple[str, float, float]] = None   # (master, multiplier, offset) in URDF angles
        self.locked: Optional[float] = None                      # URDF angle of a locked joint


def _couplings(m, mujoco, model: str, joints: Dict[int, _Joint], bodies: set) -> None:
    """Sets each follower's ``mimic`` (or ``locked``) from the model's equalities and tendons;
    raises ValueError naming what cannot be a linear coupling between two joints of the hand."""
    E, W = mujoco.mjtEq, mujoco.mjtWrap
    in_hand = lambda j: j in joints    # noqa: E731

    def tendon_joints(t: int):
        adr, num = int(m.tendon_adr[t]), int(m.tendon_num[t])
        if any(int(m.wrap_type[w]) != W.mjWRAP_JOINT for w in range(adr, adr + num)):
            return None
        return [(int(m.wrap_objid[w]), float(m.wrap_prm[w])) for w in range(adr, adr + num)]

    def tendon_name(t):
        return _name(m, mujoco, mujoco.mjtObj.mjOBJ_TENDON, t, "tendon")

    def couple(follower: int, master: int, multiplier: float, offset: float, what: str):
        f = joints[follower]
        if f.mimic is not None or f.locked is not None:
            raise ValueError(f"{model}: {what}: joint '{f.name}' is already coupled to "
                             f"'{f.mimic[0] if f.mimic else 'a fixed angle'}'; a joint follows one other joint only")
        f.mimic = (joints[master].name, multiplier, offset)

    def from_tendon(t: int, length: float, what: str):
        """c_a qpos_a + c_b qpos_b = length, for a fixed tendon of two joints of the hand."""
        parts = tendon_joints(t)
        if parts is None or len(parts) != 2:
            raise ValueError(f"{model}: {what}: tendon '{tendon_name(t)}' is not a fixed tendon of two joints; "
                             "only those become <mimic> couplings")
        (ja, ca), (jb, cb) = sorted(parts)
        if not (in_hand(ja) and in_hand(jb)):
            if in_hand(ja) or in_hand(jb):
                raise ValueError(f"{model}: {what}: tendon '{tendon_name(t)}' couples a joint of the hand to one "
                                 "above the wrist")
            return
        if ca == 0 or cb == 0:
            return
        a, b = joints[ja], joints[jb]
        # c_a (u_a + ref_a) + c_b (u_b + ref_b) = length, solved for the deeper joint b.
        couple(jb, ja, -ca / cb, (length - ca * a.ref) / cb - b.ref, what)

    for e in range(m.neq):
        if not bool(m.eq_active0[e]):
            continue
        name = _name(m, mujoco, mujoco.mjtObj.mjOBJ_EQUALITY, e, "equality")
        what = f"equality '{name}'"
        t, o1, o2 = int(m.eq_type[e]), int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        poly = np.asarray(m.eq_data[e][:5], float)
        if t == E.mjEQ_JOINT:
            if not in_hand(o1) and not (o2 >= 0 and in_hand(o2)):
                continue
            if np.any(np.abs(poly[2:]) > _LINEAR_TOL):
                raise ValueError(f"{model}: {what} couples joint '{_name(m, mujoco, mujoco.mjtObj.mjOBJ_JOINT, o1, 'joint')}' "
                                 "by a polynomial of degree > 1; only linear couplings become <mimic>")
            if o2 < 0:
                f = joints[o1]
                if f.mimic is not None:
                    raise ValueError(f"{model}: {what}: joint '{f.name}' is both locked and coupled")
                f.locked = float(poly[0])
                continue
            if not (in_hand(o1) and in_hand(o2)):
                raise ValueError(f"{model}: {what} couples a joint of the hand to one above the wrist")
            # MuJoCo: y - y0 = a0 + a1 (x - x0), y joint1, x joint2, both from their refs: u1 = a0 + a1 u2.
            couple(o1, o2, float(poly[1]), float(poly[0]), what)
        elif t == E.mjEQ_TENDON:
            parts1 = tendon_joints(o1)
            if parts1 is None:   # a spatial tendon: it touches the hand if one of its sites or geoms does
                adr, num = int(m.tendon_adr[o1]), int(m.tendon_num[o1])
                owner = {W.mjWRAP_SITE: m.site_bodyid, W.mjWRAP_SPHERE: m.geom_bodyid, W.mjWRAP_CYLINDER: m.geom_bodyid}
                touches = any(int(owner[int(m.wrap_type[w])][int(m.wrap_objid[w])]) in bodies
                              for w in range(adr, adr + num) if int(m.wrap_type[w]) in owner)
            else:
                touches = any(in_hand(j) for j, _ in parts1)
            if not touches:
                continue
            if o2 >= 0:
                raise ValueError(f"{model}: {what} couples two tendons; only a tendon held at one length "
                                 "becomes a <mimic> coupling")
            if np.any(np.abs(poly[1:]) > _LINEAR_TOL):
                raise ValueError(f"{model}: {what}: a polynomial of one tendon's length is not a linear coupling")
            # MuJoCo: L - L0 = a0, L0 the tendon's length at qpos0.
            from_tendon(o1, float(m.tendon_length0[o1]) + float(poly[0]), what)
        elif t in (E.mjEQ_CONNECT, E.mjEQ_WELD):
            objs = [o for o in (o1, o2) if o >= 0]
            if int(m.eq_objtype[e]) == mujoco.mjtObj.mjOBJ_SITE:
                objs = [int(m.site_bodyid[o]) for o in objs]
            if any(b in bodies for b in objs):
                kind = "connect" if t == E.mjEQ_CONNECT else "weld"
                raise ValueError(f"{model}: {what} ({kind}) ties bodies of the hand together: a URDF hand is a tree "
                                 "of joints, so a closed linkage cannot be imported")

    for t in range(m.ntendon):
        if not bool(m.tendon_limited[t]):
            continue
        parts = tendon_joints(t)
        if parts is None or len(parts) != 2 or not all(in_hand(j) for j, _ in parts):
            continue
        lo, hi = (float(v) for v in m.tendon_range[t])
        swept = 0.0
        for j, c in parts:
            jj = joints[j]
            span = (jj.range[1] - jj.range[0]) if jj.limited else 2 * math.pi
            swept += abs(c) * span
        if swept > 0 and hi - lo < _NARROW * swept:
            from_tendon(t, (lo + hi) / 2, f"tendon '{tendon_name(t)}'")

    # A master that follows in turn: the follower follows that joint's master (linear maps compose).
    by_name = {j.name: j for j in joints.values()}
    for j in joints.values():
        seen = {j.name}
        while j.mimic is not None and by_name[j.mimic[0]].mimic is not None:
            master = by_name[j.mimic[0]]
            if master.name in seen:
                raise ValueError(f"{model}: joints {sorted(seen)} are coupled in a loop")
            seen.add(master.name)
            k, c = j.mimic[1], j.mimic[2]
            mk, mc = master.mimic[1], master.mimic[2]
            j.mimic = (master.mimic[0], k * mk, k * mc + c)
        if j.mimic is not None and by_name[j.mimic[0]].locked is not None:
            j.locked = j.mimic[1] * by_name[j.mimic[0]].locked + j.mimic[2]
            j.mimic = None


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name)


def import_hand(model: str, wrist: str, out_dir: str, name: Optional[str] = None, force: bool = False) -> dict:
    """Writes the hand below body ``wrist`` of the MuJoCo model ``model`` (MJCF, or a URDF MuJoCo
    reads) to ``out_dir``: ``hand.urdf``, ``meshes/<link>.stl`` and ``hand.json`` (the spec that
    :func:`pairgrasp.propose_spec` proposes for it, with paths relative to the folder). Returns the
    spec. Raises ValueError naming the problem (a model MuJoCo cannot load, no such body, a joint
    or coupling a URDF cannot hold, no moving joint) with nothing written; an existing ``out_dir``
    is replaced only with ``force``."""
    mujoco = _mujoco()
    import trimesh

    from .hand_spec import propose_spec

    model = os.fspath(model)
    if not os.path.isfile(model):
        raise ValueError(f"{model}: no such file")
    try:
        m = mujoco.MjModel.from_xml_path(model)
    except Exception as e:  # MuJoCo raises ValueError with its own multi-line message
        first = " ".join(str(e).split())
        raise ValueError(f"{model}: MuJoCo cannot load it: {first}") from None
    B = mujoco.mjtObj.mjOBJ_BODY
    w = mujoco.mj_name2id(m, B, wrist)
    if w < 0:
        names = [mujoco.mj_id2name(m, B, b) for b in range(1, m.nbody)]
        named = [n for n in names if n]
        raise ValueError(f"{model}: --wrist: no body '{wrist}' (bodies: {', '.join(named[:12])}"
                         f"{', ...' if len(named) > 12 else ''})")
    if w == 0:
        raise ValueError(f"{model}: --wrist: the world body is not a hand; name the hand's root body")
    if os.path.exists(out_dir) and not force:
        raise ValueError(f"-o: {out_dir} exists (--force replaces it)")

    # The subtree, parents before children (MuJoCo numbers bodies so).
    bodies = [w] + [b for b in range(w + 1, m.nbody) if _descends(m, b, w)]
    in_tree = set(bodies)
    joints: Dict[int, _Joint] = {}
    for b in bodies[1:]:                      # the wrist's own joints move it relative to its parent: ignored
        for j in range(int(m.body_jntadr[b]), int(m.body_jntadr[b]) + int(m.body_jntnum[b])):
            jt = _Joint(m, mujoco, j)
            if jt.type not in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
                kind = "free" if jt.type == mujoco.mjtJoint.mjJNT_FREE else "ball"
                raise ValueError(f"{model}: joint '{jt.name}' is a {kind} joint; a URDF hand has hinge and slide "
                                 "joints only")
            if jt.type == mujoco.mjtJoint.mjJNT_SLIDE and not jt.limited:
                raise ValueError(f"{model}: slide joint '{jt.name}' has no range; a prismatic joint needs limits")
            joints[j] = jt
    _couplings(m, mujoco, model, joints, in_tree)
    if not any(j.mimic is None and j.locked is None for j in joints.values()):
        raise ValueError(f"{model}: the hand below body '{wrist}' has no moving joint (nothing to close)")

    body_name = {b: _safe(_name(m, mujoco, B, b, "body")) for b in bodies}
    for kind, names in (("bodies", list(body_name.values())), ("joints", [_safe(j.name) for j in joints.values()])):
        clash = sorted({n for n in names if names.count(n) > 1})
        if clash:
            raise ValueError(f"{model}: {kind} of the hand share a URDF name once their characters outside "
                             f"[A-Za-z0-9_.-] become '_': {', '.join(clash[:5])}")
    robot = ET.Element("robot", name=name or _safe(os.path.splitext(os.path.basename(model))[0]))
    meshes: Dict[str, trimesh.Trimesh] = {}
    link_of: Dict[int, str] = {}          # body -> the link holding its geometry
    body_in_link: Dict[int, np.ndarray] = {}   # body -> pose of the body frame in that link's frame

    def link(nm: str, mass: float, inertial_pose: np.ndarray, inertia) -> ET.Element:
        el = ET.SubElement(robot, "link", name=nm)
        ine = ET.SubElement(el, "inertial")
        _origin(ine, inertial_pose)
        ET.SubElement(ine, "mass", value=f"{max(mass, _INTERMEDIATE_MASS):.17g}")
        ix = [max(float(v), 1e-12) for v in inertia]
        ET.SubElement(ine, "inertia", ixx=f"{ix[0]:.17g}", iyy=f"{ix[1]:.17g}", izz=f"{ix[2]:.17g}",
                      ixy="0", ixz="0", iyz="0")
        return el

    link_elems: Dict[str, ET.Element] = {}
    for b in bodies:
        own = [joints[j] for j in sorted(joints) if joints[j].body == b]
        C = np.eye(4) if not own else _pose(-own[-1].pos)        # body frame in its link's frame
        nm = body_name[b]
        inertial = C @ _pose(m.body_ipos[b], m.body_iquat[b])
        link_elems[nm] = link(nm, float(m.body_mass[b]), inertial, m.body_inertia[b])
        link_of[b], body_in_link[b] = nm, C
        if b == w:
            continue
        p = int(m.body_parentid[b])
        offset = body_in_link[p] @ _pose(m.body_pos[b], m.body_quat[b])   # body frame in the parent link's
        parent, prev = link_of[p], np.zeros(3)
        for k, jt in enumerate(own):
            child = nm if k == len(own) - 1 else f"{nm}__{_safe(jt.name)}"
            if child != nm:
                link_elems[child] = link(child, 0.0, np.eye(4), (1e-12, 1e-12, 1e-12))
            origin = (offset @ _pose(jt.pos)) if k == 0 else _pose(jt.pos - prev)
            prev = jt.pos
            el = ET.SubElement(robot, "joint", name=_safe(jt.name))
            ET.SubElement(el, "parent", link=parent)
            ET.SubElement(el, "child", link=child)
            if jt.locked is not None:
                el.set("type", "fixed")
                turn = (_axis_angle(jt.axis, jt.locked) if jt.type == mujoco.mjtJoint.mjJNT_HINGE
                        else _pose(jt.axis / np.linalg.norm(jt.axis) * jt.locked))
                _origin(el, origin @ turn)
            else:
                hinge = jt.type == mujoco.mjtJoint.mjJNT_HINGE
                el.set("type", "revolute" if hinge else "prismatic")
                _origin(el, origin)
                ET.SubElement(el, "axis", xyz=" ".join(f"{v:.17g}" for v in jt.axis / np.linalg.norm(jt.axis)))
                lo, hi = (jt.range - jt.ref) if jt.limited else (-math.pi, math.pi)
                ET.SubElement(el, "limit", lower=f"{lo:.17g}", upper=f"{hi:.17g}", effort="100", velocity="10")
                if jt.mimic is not None:
                    ET.SubElement(el, "mimic", joint=_safe(jt.mimic[0]), multiplier=f"{jt.mimic[1]:.17g}",
                                  offset=f"{jt.mimic[2]:.17g}")
            parent = child
        if not own:
            el = ET.SubElement(robot, "joint", name=f"{nm}__fixed", type="fixed")
            ET.SubElement(el, "parent", link=parent)
            ET.SubElement(el, "child", link=nm)
            _origin(el, offset)

    for b in bodies:
        geoms = range(int(m.body_geomadr[b]), int(m.body_geomadr[b]) + int(m.body_geomnum[b])) \
            if int(m.body_geomnum[b]) > 0 else []
        colliding = [g for g in geoms if m.geom_contype[g] != 0 or m.geom_conaffinity[g] != 0]
        parts = [_geom_mesh(m, mujoco, g) for g in (colliding or list(geoms))]
        parts = [p for p in parts if p is not None and len(p.faces)]
        if not parts:
            continue
        mesh = trimesh.util.concatenate(parts)
        mesh.apply_transform(body_in_link[b])
        meshes[link_of[b]] = mesh
        for tag in ("visual", "collision"):
            el = ET.SubElement(link_elems[link_of[b]], tag)
            ET.SubElement(ET.SubElement(el, "geometry"), "mesh", filename=f"meshes/{link_of[b]}.stl")
    if not meshes:
        raise ValueError(f"{model}: the hand below body '{wrist}' has no geometry")

    tmp = f"{out_dir.rstrip(os.sep)}.part"
    shutil.rmtree(tmp, ignore_errors=True)
    os.makedirs(os.path.join(tmp, "meshes"))
    try:
        for nm, mesh in meshes.items():
            mesh.export(os.path.join(tmp, "meshes", f"{nm}.stl"))
        ET.indent(robot)
        ET.ElementTree(robot).write(os.path.join(tmp, "hand.urdf"), encoding="unicode", xml_declaration=True)
        spec = propose_spec(os.path.join(tmp, "hand.urdf"), body_name[w], name=name or robot.get("name"))
        spec["urdf"] = "hand.urdf"
        spec.pop("package_paths", None)
        with open(os.path.join(tmp, "hand.json"), "w") as f:
            json.dump(spec, f, indent=2)
            f.write("\n")
        if os.path.exists(out_dir):
            shutil.rmtree(out_dir)
        os.replace(tmp, out_dir)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return spec


def _descends(m, b: int, root: int) -> bool:
    while b > 0:
        if b == root:
            return True
        b = int(m.body_parentid[b])
    return False
