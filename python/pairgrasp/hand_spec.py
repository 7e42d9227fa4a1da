"""A hand spec proposed from a URDF, and a picture to check one (``pairgrasp hand init`` and
``pairgrasp hand show``).

The proposal (:func:`propose_spec`) reads the hand as the planner will (the wrist link's subtree,
through :func:`pairgrasp.load_hand`) and derives:

* **DOFs**: one per moving joint that is not a ``<mimic>`` (mimics follow their master), over the
  joint's URDF limits, a turning DOF stepped by the planner's default 0.25 rad or an eighth of its
  range if less (a slide's default step is an eighth of its range already). Two joints that mirror
  each other are one DOF (``<first>+<second>``, the second with ratio 1 or -1): they hang from the
  same link, are of the same type, have the same limits (ratio 1) or opposite ones (ratio -1), and,
  swept together over their range with the other joints at mid-range, move their child links (or,
  for a child without geometry, all that they carry) as mirror images: equal areas, and centroids
  mirrored through one plane that contains the approach, or turned half a turn about one line along
  it (one finger mesh turned over). So the Barrett spread's two knuckles (one motor, two URDF
  joints) are one DOF, as are the fingers of a two-finger gripper whose URDF states no ``<mimic>``.
* **Approach**: from the wrist link's centroid towards the centroid of the links that move, at
  mid-range, rounded to a frame axis when within 10 degrees of one.
* **Active surfaces**: the links a *closing* joint moves (a joint whose axis, in the wrist frame at
  mid-range, is more than 45 degrees from the approach: it swings or slides a finger across the
  approach rather than spinning it about it), each with the faces whose outward normals face the
  grasp centre at mid-range (the centroid of the moving links), written as a normal cone about
  their mean normal; and the palm (the wrist link's faces towards the approach) when closing brings
  the fingers down towards it.
* **Synergies** for a hand of more than ``SYNERGIES_ABOVE`` independent joints (the Shadow hand's
  18, the Allegro's 16: too many for the planner to sample one by one), at most ``MAX_DOFS``: the
  joints are grouped by finger (the link below the wrist their chain starts with); a finger's
  flexion joints are those within 30 degrees of parallel to its tip joint's axis, closing the way
  the planner's closing direction says; the fingers whose tips close (across the approach) the
  way of the most typical finger are the fingers, the rest oppose them (a thumb). ``close`` and
  ``close_opposing`` sweep each group's flexion joints from open (0) to closed (1) together;
  ``spread`` turns the fingers' other joints from -1 to 1 (half their range each way, positive
  moving the tip away from the fingers' centre) and ``turn_opposing`` the opposing group's (positive
  towards the fingers).
"""
from __future__ import annotations

import json
import math
import os
import tempfile
import xml.etree.ElementTree as ET
from typing import Dict, List, Optional, Sequence

import numpy as np

_MOVING = ("revolute", "continuous", "prismatic")
_CLOSING_AXIS_COS = math.cos(math.radians(45.0))   # a joint axis farther than this from the approach closes
_LEADING_COS = math.cos(math.radians(60.0))        # a face moving within this of its normal leads the closing
_SNAP_COS = math.cos(math.radians(10.0))           # an approach this near a frame axis becomes that axis
_PALM_CONE_DEG = 10.0
_FLEX_COS = math.cos(math.radians(30.0))           # a joint this near parallel to its finger's tip joint flexes it
_REVOLUTE_STEP = 0.25                              # rad: the planner's default step of a turning DOF
_STEPS_PER_RANGE = 8                               # ... at most an eighth of its range (a short finger's)
_MIRROR_TOL = 1e-4                                 # of the hand's size: mirrored centroids agree within this
_MIRROR_AREA = 0.02                                # mirrored joints carry areas within this fraction
MAX_DOFS = 4                                       # synergies proposed for a hand of many joints, at most
SYNERGIES_ABOVE = 5                                # independent joints; the Barrett hand's five stay one DOF each


def _urdf_subtree(urdf: str, wrist: str):
    """(moving joints that are not mimics, links with geometry) of the wrist's subtree, in file
    order, read from the URDF's structure only (the hand itself is loaded by pairgrasp.load_hand)."""
    try:
        robot = ET.parse(urdf).getroot()
    except (OSError, ET.ParseError) as e:
        raise ValueError(f"{urdf}: cannot read the URDF: {e}") from None
    links = {l.get("name"): l for l in robot.findall("link")}
    if wrist not in links:
        raise ValueError(f"{urdf}: --wrist: no link '{wrist}'")
    joints = robot.findall("joint")
    keep, frontier = {wrist}, [wrist]
    while frontier:
        parent = frontier.pop()
        for j in joints:
            p, c = j.find("parent"), j.find("child")
            if p is not None and c is not None and p.get("link") == parent and c.get("link") not in keep:
                keep.add(c.get("link"))
                frontier.append(c.get("link"))
    driven = [j.get("name") for j in joints
              if j.get("type") in _MOVING and j.find("parent") is not None and j.find("parent").get("link") in keep
              and j.find("mimic") is None]
    geometric = [n for n in links if n in keep
                 and (links[n].find("collision") is not None or links[n].find("visual") is not None)]
    if not driven:
        raise ValueError(f"{urdf}: the hand below '{wrist}' has no moving joint (nothing to close)")
    if not geometric:
        raise ValueError(f"{urdf}: the hand below '{wrist}' has no link with geometry")
    return driven, geometric


def _load(spec: dict, package_paths: Sequence[str]):
    import pairgrasp as pg

    fd, path = tempfile.mkstemp(suffix=".json", prefix="pairgrasp-hand-")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(spec, f)
        return pg.load_hand(path, package_paths=list(package_paths))
    finally:
        os.remove(path)


def _world_meshes(hand, dofs):
    """Per link with geometry: (vertices in the wrist frame, faces, face normals, face areas, face centroids)."""
    out = {}
    for link, T in zip(hand.links, np.asarray(hand.link_poses(np.asarray(dofs, float)))):
        v = np.asarray(link.mesh.vertices, float) @ T[:3, :3].T + T[:3, 3]
        f = np.asarray(link.mesh.faces, int)
        if len(f) == 0:
            continue
        tri = v[f]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area = np.linalg.norm(n, axis=1) / 2
        n = n / np.maximum(2 * area, 1e-300)[:, None]
        out[link.name] = dict(T=T, normals=n, areas=area, centroids=tri.mean(axis=1))
    return out


def _joint_axis(poses, j) -> np.ndarray:
    """Joint j's axis in the wrist frame, for the link transforms `poses` (hand.link_transforms)."""
    return poses[j.parent_link][:3, :3] @ np.asarray(j.origin, float)[:3, :3] @ np.asarray(j.axis, float)


def _centroid(m):
    w = m["areas"]
    return (m["centroids"] * w[:, None]).sum(axis=0) / max(w.sum(), 1e-300)


def _snap(v):
    v = v / np.linalg.norm(v)
    k = int(np.argmax(np.abs(v)))
    if abs(v[k]) >= _SNAP_COS:
        e = np.zeros(3)
        e[k] = math.copysign(1.0, v[k])
        return e
    return v


def _round(v, digits=4):
    return [round(float(x), digits) + 0.0 for x in v]


def propose_spec(urdf: str, wrist: str, package_paths: Sequence[str] = (), name: Optional[str] = None) -> dict:
    """A hand spec (a dict, as the JSON file holds it) for the hand below link ``wrist`` of the URDF
    at ``urdf``, derived as the module documents. ``package_paths`` resolve ``package://`` mesh URIs
    (the URDF's folder and its parent are tried after them). Raises ValueError naming the problem
    (no such link, no moving joint, no link with geometry, no face facing the grasp) and
    pairgrasp.FileError for a URDF the loader refuses."""
    urdf = os.path.abspath(urdf)
    folder = os.path.dirname(urdf)
    paths = [os.path.abspath(p) for p in package_paths] + [folder, os.path.dirname(folder)]
    driven, geometric = _urdf_subtree(urdf, wrist)
    base = {"urdf": urdf, "package_paths": paths, "wrist_link": wrist, "approach": [0, 0, 1],
            "dofs": [{"name": j, "joints": [{"joint": j}]} for j in driven],
            "active_surfaces": [{"link": l, "normal_cone": {"axis": [0, 0, 1], "half_angle_deg": 180}}
                                for l in geometric]}
    if name:
        base["name"] = name
    hand = _load(base, paths)
    lo, hi = np.asarray(hand.dof_lower, float), np.asarray(hand.dof_upper, float)
    mid = (lo + hi) / 2
    at_mid = _world_meshes(hand, mid)
    poses = hand.link_transforms(mid)

    # Which links each DOF moves (their pose changes between its limits, the others at mid-range).
    moved: Dict[str, set] = {}
    for d in range(len(mid)):
        a, b = mid.copy(), mid.copy()
        a[d], b[d] = lo[d], hi[d]
        Ta, Tb = hand.link_transforms(a), hand.link_transforms(b)
        moved[hand.dof_names[d]] = {n for n in at_mid if not np.allclose(Ta[n], Tb[n], atol=1e-9)}
    moving = set().union(*moved.values())
    if not moving:
        raise ValueError(f"{urdf}: no link with geometry moves below '{wrist}'")
    centre = np.mean([_centroid(at_mid[n]) for n in sorted(moving)], axis=0)
    wrist_centroid = _centroid(at_mid[wrist]) if wrist in at_mid else np.zeros(3)
    if np.linalg.norm(centre - wrist_centroid) < 1e-9:
        raise ValueError(f"{urdf}: cannot tell the approach: the moving links are centred on the wrist link")
    approach = _snap(centre - wrist_centroid)

    # Closing joints: axis (wrist frame, mid-range) far from the approach.
    joints = {j.name: j for j in hand.joints}
    closing_dofs = []
    for d, jname in enumerate(driven):
        j = joints[jname]
        if abs(float(_joint_axis(poses, j) @ approach)) < _CLOSING_AXIS_COS:
            closing_dofs.append(d)
    fingers = set().union(*(moved[hand.dof_names[d]] for d in closing_dofs)) if closing_dofs else set()
    if not fingers:
        raise ValueError(f"{urdf}: no joint below '{wrist}' closes across the approach {_round(approach, 3)}")

    surfaces = []
    axis_point = wrist_centroid

    def radius(m, n):  # distance of link n's centroid from the approach axis through the wrist
        r = _centroid(m[n]) - axis_point
        return float(np.linalg.norm(r - (r @ approach) * approach))

    # The faces that lead each closing DOF's motion.
    q0 = lo + 0.25 * (hi - lo)           # partly open: the fingers still surround the grasp
    at_q0 = _world_meshes(hand, q0)
    leading: Dict[str, np.ndarray] = {n: np.zeros(len(at_q0[n]["areas"]), bool) for n in fingers}
    for d in closing_dofs:
        step = 1e-4 * max(hi[d] - lo[d], 1e-3)
        q = q0.copy()
        q[d] += step
        after = _world_meshes(hand, q)
        links = [n for n in moved[hand.dof_names[d]] if n in fingers]
        # Closing moves the link the joint carries in towards the approach axis (its farther
        # links may already reach across it).
        child = joints[driven[d]].child_link
        near = [child] if child in links else links
        sign = -math.copysign(1.0, sum(radius(after, n) - radius(at_q0, n) for n in near) or 1.0)
        for n in links:
            v = sign * (after[n]["centroids"] - at_q0[n]["centroids"]) / step
            speed = np.linalg.norm(v, axis=1)
            leading[n] |= (speed > 1e-9) & (np.einsum("ij,ij->i", v, at_q0[n]["normals"]) >= _LEADING_COS * speed)
    # The palm: when closing brings the fingers down towards it (their mean height along the
    # approach drops by a quarter from the open to the closed end of the closing DOFs).
    if wrist in at_mid:
        heights = []
        for end in (lo, hi):
            q = mid.copy()
            q[closing_dofs] = end[closing_dofs]
            m = _world_meshes(hand, q)
            heights.append(np.mean([_centroid(m[n]) @ approach for n in fingers]) - wrist_centroid @ approach)
        top, bottom = max(heights), min(heights)
        palm = at_mid[wrist]
        if top > 0 and bottom < 0.75 * top and np.any(palm["normals"] @ approach >= math.cos(math.radians(_PALM_CONE_DEG))):
            surfaces.append({"link": wrist, "normal_cone": {"axis": _round(approach), "half_angle_deg": _PALM_CONE_DEG}})
    for link in [n for n in geometric if n in fingers]:
        m, lead = at_q0[link], leading[link]
        if not lead.any():
            continue
        mean = (m["normals"][lead] * m["areas"][lead, None]).sum(axis=0)
        if np.linalg.norm(mean) < 1e-12:
            continue
        mean /= np.linalg.norm(mean)
        axis_link = _snap(m["T"][:3, :3].T @ mean)                      # into the link frame
        spread = np.degrees(np.arccos(np.clip((m["normals"][lead] @ m["T"][:3, :3]) @ axis_link, -1, 1)))
        half = float(np.clip(np.percentile(spread, 90) + 5.0, 10.0, 60.0))
        surfaces.append({"link": link, "normal_cone": {"axis": _round(axis_link), "half_angle_deg": round(half, 1)}})
    if not surfaces:
        raise ValueError(f"{urdf}: no face of the moving links faces the grasp centre at mid-range")

    spec = {"name": name or hand.name, "urdf": urdf, "package_paths": paths, "wrist_link": wrist,
            "approach": _round(approach),
            "dofs": [{"name": j, "joints": [{"joint": j}]} for j in driven],
            "active_surfaces": surfaces}
    if len(driven) > SYNERGIES_ABOVE:
        spec["dofs"] = _synergies(_load(spec, paths), driven, wrist, urdf, approach)
    else:
        spec["dofs"] = _mirror_couplings(hand, driven, joints, approach, moved, at_mid)
    _load(spec, paths)      # the proposal loads as it is written
    return spec


def _mirror_couplings(hand, driven: List[str], joints: dict, approach: np.ndarray, moved: Dict[str, set],
                      at_mid: dict) -> List[dict]:
    """The DOFs of the proposal with joints that mirror each other merged (the module's docs);
    ``hand`` has one DOF per driven joint, named after it, and ``at_mid`` is its _world_meshes at
    mid-range."""
    from . import _core

    lo, hi = np.asarray(hand.dof_lower, float), np.asarray(hand.dof_upper, float)
    mid = (lo + hi) / 2
    index = {n: d for d, n in enumerate(hand.dof_names)}
    size = max(float(np.ptp(np.concatenate([m["centroids"] for m in at_mid.values()]), axis=0).max()), 1e-9)

    def carried(meshes, links):               # (area-weighted centroid, area) of the links' faces
        faces = {k: np.concatenate([meshes[n][k] for n in sorted(links)]) for k in ("centroids", "areas")}
        return _centroid(faces), float(faces["areas"].sum())

    def mirrors(a: str, b: str, s: float) -> bool:
        ja, jb = joints[a], joints[b]
        if ja.parent_link != jb.parent_link or ja.type != jb.type:
            return False
        da, db = index[a], index[b]
        la, lb = moved[a], moved[b]
        if not la or not lb or la & lb:
            return False
        if ja.child_link in la and jb.child_link in lb:    # the links the joints turn or slide themselves
            la, lb = {ja.child_link}, {jb.child_link}
        want = (lo[da], hi[da]) if s > 0 else (-hi[da], -lo[da])
        if not np.allclose((lo[db], hi[db]), want, rtol=1e-9, atol=1e-9):
            return False
        normal = origin = None
        mirrored = turned = True                # through the plane; half a turn about the approach
        for t in np.linspace(lo[da], hi[da], 5):
            q = mid.copy()
            q[da], q[db] = t, s * t
            m = _world_meshes(hand, q)
            (ca, area_a), (cb, area_b) = carried(m, la), carried(m, lb)
            if abs(area_a - area_b) > _MIRROR_AREA * max(area_a, area_b):
                return False
            if normal is None:            # the plane: the perpendicular bisector at the first value
                gap = ca - cb
                if np.linalg.norm(gap) < _MIRROR_TOL * size:
                    return False
                normal, origin = gap / np.linalg.norm(gap), (ca + cb) / 2
                if abs(float(normal @ approach)) > 0.05:
                    return False
            u = ca - origin
            mirrored &= bool(np.linalg.norm(ca - 2 * float(u @ normal) * normal - cb) <= _MIRROR_TOL * size)
            turned &= bool(np.linalg.norm(origin + 2 * float(u @ approach) * approach - u - cb) <= _MIRROR_TOL * size)
            if not (mirrored or turned):
                return False
        return True

    dofs, taken = [], set()
    for i, a in enumerate(driven):
        if a in taken:
            continue
        dof = {"name": a, "joints": [{"joint": a}]}
        for b in driven[i + 1:]:
            s = next((s for s in (1.0, -1.0) if b not in taken and mirrors(a, b, s)), None)
            if s is not None:
                dof = {"name": f"{a}+{b}", "joints": [{"joint": a}, {"joint": b, "ratio": s}]}
                taken.add(b)
                break
        if joints[a].type != _core.JointType.prismatic:     # a slide's default step is an eighth of its range
            dof["step"] = _r(min(_REVOLUTE_STEP, (hi[index[a]] - lo[index[a]]) / _STEPS_PER_RANGE))
        dofs.append(dof)
    return dofs


def _synergies(hand, driven: List[str], wrist: str, urdf: str, approach: np.ndarray) -> List[dict]:
    """At most MAX_DOFS synergies for a hand of more independent joints (the module's docs)."""
    from . import _core

    lo, hi = np.asarray(hand.dof_lower, float), np.asarray(hand.dof_upper, float)
    mid = (lo + hi) / 2
    dirs = np.asarray(_core.closing_directions(hand, mid), int).reshape(-1)
    joints = {j.name: j for j in hand.joints}
    parent_of = {j.child_link: j for j in hand.joints}

    def chain(link):                       # the joints from the wrist down to link, wrist first
        out = []
        while link in parent_of and link != wrist:
            out.append(parent_of[link])
            link = parent_of[link].parent_link
        return out[::-1]

    def finger(jname):                     # the link below the wrist that the joint's chain starts with
        return chain(joints[jname].child_link)[0].child_link

    poses = hand.link_transforms(mid)
    at_mid = _world_meshes(hand, mid)

    def axis(j):
        return _joint_axis(poses, j)

    groups: Dict[str, List[int]] = {}
    for d, jn in enumerate(driven):
        groups.setdefault(finger(jn), []).append(d)
    tips, flex, turn, sense = {}, {}, {}, {}
    for f, ds in groups.items():
        below = [l for l in at_mid if any(j.child_link == f for j in chain(l))]
        tip = max(below, key=lambda l: len(chain(l))) if below else None
        # The finger's flexion axis is its tip joint's: every finger's last joint flexes it.
        last = chain(tip)[-1] if tip else joints[driven[ds[-1]]]
        a_tip = axis(last)
        parallel = [d for d in ds if abs(float(axis(joints[driven[d]]) @ a_tip)) >= _FLEX_COS]
        # Their closing sense: the planner's closing direction where it has one, carried to the
        # finger's other flexion joints through the sense of their axes.
        refs = [d for d in parallel if dirs[d] != 0]
        flex[f] = parallel if refs else []
        for d in flex[f]:
            r = refs[0]
            sense[d] = int(dirs[r]) * (1 if float(axis(joints[driven[d]]) @ axis(joints[driven[r]])) > 0 else -1)
        turn[f] = [d for d in ds if d not in flex[f]]
        tips[f] = tip

    def tip_at(q, f):
        return _centroid(_world_meshes(hand, q)[tips[f]]) if tips[f] else np.zeros(3)

    tip_mid = {f: _centroid(at_mid[tips[f]]) if tips[f] else np.zeros(3) for f in groups}

    # Each finger's closing motion: its tip's displacement when its flexion joints close together.
    motion = {}
    for f in groups:
        if not flex[f] or tips[f] is None:
            continue
        q = mid.copy()
        for d in flex[f]:
            q[d] += sense[d] * 0.05 * (hi[d] - lo[d])
        v = tip_at(q, f) - tip_mid[f]
        v = v - (v @ approach) * approach          # across the approach: where the finger closes to
        if np.linalg.norm(v) > 1e-12:
            motion[f] = v / np.linalg.norm(v)
    if not motion:
        raise ValueError(f"{urdf}: {len(driven)} DOFs and no finger that closes: cannot propose at most {MAX_DOFS}")
    names = sorted(motion)
    ref = max(names, key=lambda f: sum(float(motion[f] @ motion[g]) for g in names))
    fingers = [f for f in sorted(groups) if f not in motion or float(motion[f] @ motion[ref]) > 0]
    opposing = [f for f in sorted(groups) if f not in fingers]
    centre_f = np.mean([tip_mid[f] for f in fingers if tips[f]], axis=0)

    def closing(ds, dof):
        return {"name": dof, "step": 0.25,        # from 0 (open) to 1 (closed), within every joint's limits
                "joints": [{"joint": driven[d], "ratio": _r(sense[d] * (hi[d] - lo[d])),
                            "offset": _r(lo[d] if sense[d] > 0 else hi[d])} for d in ds]}

    def turning(ds, dof, towards_centre, away):
        out = []
        for d in ds:
            f = finger(driven[d])
            q = mid.copy()
            q[d] += 0.05 * (hi[d] - lo[d])
            moved = tip_at(q, f) - tip_mid[f] if tips[f] else np.zeros(3)
            outward = tip_mid[f] - towards_centre if away else towards_centre - tip_mid[f]
            sign = 1.0 if float(moved @ outward) >= 0 else -1.0
            out.append({"joint": driven[d], "ratio": _r(sign * (hi[d] - lo[d]) / 2), "offset": _r(mid[d])})
        return {"name": dof, "step": 0.5, "joints": out}      # from -1 to 1 within every joint's limits

    dofs = []
    close_f = [d for f in fingers for d in flex[f]]
    close_o = [d for f in opposing for d in flex[f]]
    turn_f = [d for f in fingers for d in turn[f]]
    turn_o = [d for f in opposing for d in turn[f]]
    if close_f:
        dofs.append(closing(close_f, "close"))
    if close_o:
        dofs.append(closing(close_o, "close_opposing"))
    if turn_f:
        dofs.append(turning(turn_f, "spread", centre_f, away=True))
    if turn_o:
        dofs.append(turning(turn_o, "turn_opposing", centre_f, away=False))
    return dofs


def _r(x: float) -> float:
    return round(float(x), 12) + 0.0


def draw_hand(hand, path: str, title: str = "") -> str:
    """Writes a PNG of ``hand`` open, at mid-range and closed (each DOF at the limit its closing
    direction leads away from, midway, at the limit it leads to; DOFs that do not close at mid-range),
    with its active faces coloured and the approach drawn from the wrist. Returns ``path``."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from . import _core
    from .render import CONTACT_COLOR, HAND_COLOR, _pyplot, _save, _shade, _tri_normals

    lo, hi = np.asarray(hand.dof_lower, float), np.asarray(hand.dof_upper, float)
    mid = (lo + hi) / 2
    dirs = np.asarray(_core.closing_directions(hand, mid), int).reshape(-1)
    opened = np.where(dirs > 0, lo, np.where(dirs < 0, hi, mid))
    closed = np.where(dirs > 0, hi, np.where(dirs < 0, lo, mid))
    configs = (("open", opened), ("mid-range", mid), ("closed", closed))
    plt = _pyplot()
    fig = plt.figure(figsize=(15.0, 5.0), dpi=100)
    for k, (label, q) in enumerate(configs):
        tris, cols = [], []
        for link, T in zip(hand.links, np.asarray(hand.link_poses(q))):
            v = np.asarray(link.mesh.vertices, float) @ T[:3, :3].T + T[:3, 3]
            t = v[np.asarray(link.mesh.faces, int)] * 1000.0
            if len(t) == 0:
                continue
            n = _tri_normals(t)
            active = np.zeros(len(t), bool)
            active[np.asarray(link.active_faces, int)] = True
            cols.append(np.where(active[:, None], _shade(n, CONTACT_COLOR), _shade(n, HAND_COLOR)))
            tris.append(t)
        tris, cols = np.concatenate(tris), np.concatenate(cols)
        lo3, hi3 = tris.reshape(-1, 3).min(axis=0), tris.reshape(-1, 3).max(axis=0)
        c, half = (lo3 + hi3) / 2, (hi3 - lo3).max() / 2 * 1.05
        ax = fig.add_subplot(1, 3, k + 1, projection="3d")
        ax.add_collection3d(Poly3DCollection(tris, facecolors=cols, edgecolors=(0.1, 0.1, 0.2, 0.25), linewidths=0.2))
        a = np.asarray(hand.approach, float) * half
        ax.quiver(0, 0, 0, a[0], a[1], a[2], color="tab:blue", linewidth=1.5)
        for setter, x in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), c):
            setter(x - half, x + half)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=20, azim=-60)
        ax.set_title(f"{label}: " + ", ".join(f"{n} {x:.3g}" for n, x in zip(hand.dof_names, q)), fontsize=7)
        ax.tick_params(labelsize=6)
    fig.suptitle(title or f"{hand.name}: active faces red, approach blue (mm, wrist frame)", fontsize=9)
    _save(fig, path)
    plt.close(fig)
    return path
