"""Reading and writing ``grasps.json``, the planner's output (schema in docs/grasps-json.md).

:func:`load_grasps` reads a file written by ``pairgrasp plan`` (or by hand, with the required fields)
back into :class:`pairgrasp.Grasp` objects, checking every field: a malformed file raises
:class:`pairgrasp.FileError` naming the file and the field (``grasps[2].wrist_pose: ...``), never a
KeyError or a silently wrong grasp. :func:`write_grasps` writes a document atomically (a partial file
never appears under the name).
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from typing import List, Optional

import numpy as np

from ._core import FileError
from .results import Grasp

__all__ = ["GRASPS_FORMAT", "GraspsFile", "load_grasps", "parse_grasps", "write_grasps"]

GRASPS_FORMAT = "pairgrasp.grasps/1"
# Same tolerance as the C++ rigidity check: max |R^T R - I|.
_RIGID_TOL = 1e-6


@dataclass(frozen=True)
class GraspsFile:
    """A grasps.json file read back.

    Attributes:
        path: the file read.
        grasps: the grasps, in file order (best first as written by the planner).
        inputs, parameters, counts, timings: the document's sections ({} when absent).
        document: the whole parsed document, unknown keys included.
    """

    path: str
    grasps: List[Grasp]
    inputs: dict
    parameters: dict
    counts: dict
    timings: dict
    document: dict


class _Bad(Exception):
    pass


def _number(v, where):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise _Bad(f"{where}: expected a finite number, got {json.dumps(v)[:40]}")
    return float(v)


def _array(v, shape, where):
    """A nested list of finite numbers of ``shape`` (None in shape: any length)."""
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise _Bad(f"{where}: expected numbers of shape {_shape(shape)}") from None
    if a.dtype == object or a.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, a.shape)):
        raise _Bad(f"{where}: expected numbers of shape {_shape(shape)}, got {_describe(v)}")
    if isinstance(v, list) and any(isinstance(x, bool) for x in np.asarray(v, dtype=object).ravel()):
        raise _Bad(f"{where}: expected numbers, got a boolean")
    if not np.isfinite(a).all():
        raise _Bad(f"{where}: NaN or infinite value")
    return a


def _shape(shape):
    return "(" + ", ".join("N" if s is None else str(s) for s in shape) + ")"


def _describe(v):
    try:
        return f"shape {np.asarray(v, dtype=float).shape}"
    except (TypeError, ValueError):
        return type(v).__name__


def _pose(v, where):
    T = _array(v, (4, 4), where)
    R = T[:3, :3]
    if np.abs(R.T @ R - np.eye(3)).max() > _RIGID_TOL or np.linalg.det(R) < 0:
        raise _Bad(f"{where}: the rotation part is not a rotation (|R^T R - I| > {_RIGID_TOL:g} or det < 0)")
    if np.abs(T[3] - [0, 0, 0, 1]).max() > 1e-9:
        raise _Bad(f"{where}: the last row must be [0, 0, 0, 1]")
    return T


def _get(d, key, where):
    if key not in d:
        raise _Bad(f"{where}: missing '{key}'")
    return d[key]


def _grasp(d, where, hand) -> Grasp:
    if not isinstance(d, dict):
        raise _Bad(f"{where}: expected an object, got {type(d).__name__}")
    rank = _get(d, "rank", where)
    if isinstance(rank, bool) or not isinstance(rank, int) or rank < 1:
        raise _Bad(f"{where}.rank: expected an integer >= 1, got {json.dumps(rank)[:40]}")
    pose = _pose(_get(d, "wrist_pose", where), f"{where}.wrist_pose")
    dofs = _array(_get(d, "dof", where), (None,), f"{where}.dof")
    if hand is not None:
        n = len(hand.dof_names)
        if len(dofs) != n:
            raise _Bad(f"{where}.dof: expected {n} values for hand {hand.name}, got {len(dofs)}")
        lo, hi = np.asarray(hand.dof_lower, float), np.asarray(hand.dof_upper, float)
        bad = np.nonzero((dofs < lo - 1e-9) | (dofs > hi + 1e-9))[0]
        if len(bad):
            k = int(bad[0])
            raise _Bad(f"{where}.dof[{k}] ({hand.dof_names[k]}): {dofs[k]:.6g} is outside [{lo[k]:.6g}, {hi[k]:.6g}]")
    joints = _get(d, "joints", where)
    if not isinstance(joints, dict):
        raise _Bad(f"{where}.joints: expected an object of joint name -> value")
    joints = {str(k): _number(v, f"{where}.joints.{k}") for k, v in joints.items()}
    fc = _get(d, "force_closure", where)
    if not isinstance(fc, bool):
        raise _Bad(f"{where}.force_closure: expected true or false, got {json.dumps(fc)[:40]}")
    votes = _get(d, "votes", where)
    if isinstance(votes, bool) or not isinstance(votes, int) or votes < 0:
        raise _Bad(f"{where}.votes: expected an integer >= 0, got {json.dumps(votes)[:40]}")
    scalars = {}
    for key in ("epsilon", "alignment_quality", "penetration_depth"):
        scalars[key] = _number(_get(d, key, where), f"{where}.{key}")
        if scalars[key] < 0:
            raise _Bad(f"{where}.{key}: expected a number >= 0, got {scalars[key]:g}")
    volume = _number(d.get("volume", 0.0), f"{where}.volume")
    contacts = _get(d, "contacts", where)
    if not isinstance(contacts, list):
        raise _Bad(f"{where}.contacts: expected a list")
    points, normals, links = [], [], []
    for k, c in enumerate(contacts):
        cw = f"{where}.contacts[{k}]"
        if not isinstance(c, dict):
            raise _Bad(f"{cw}: expected an object with point, normal, link")
        points.append(_array(_get(c, "point", cw), (3,), f"{cw}.point"))
        n = _array(_get(c, "normal", cw), (3,), f"{cw}.normal")
        if abs(np.linalg.norm(n) - 1.0) > 1e-6:
            raise _Bad(f"{cw}.normal: not a unit vector (length {np.linalg.norm(n):.6g})")
        normals.append(n)
        link = _get(c, "link", cw)
        if not isinstance(link, str):
            raise _Bad(f"{cw}.link: expected a link name")
        links.append(link)
    sample = _array(d["sample"], (len(dofs),), f"{where}.sample") if "sample" in d else dofs.copy()
    aligned = _pose(d["aligned_pose"], f"{where}.aligned_pose") if "aligned_pose" in d else pose.copy()
    backoff = _number(d.get("backoff", 0.0), f"{where}.backoff")
    fine_tuned = d.get("fine_tuned", False)
    if not isinstance(fine_tuned, bool):
        raise _Bad(f"{where}.fine_tuned: expected true or false")
    robust = {}
    for key in ("force_closure_probability", "robust_epsilon", "load_resistance"):   # optional
        if d.get(key) is not None:
            robust[key] = _number(d[key], f"{where}.{key}")
            if robust[key] < 0 or (key == "force_closure_probability" and robust[key] > 1):
                raise _Bad(f"{where}.{key}: expected a number in [0, {'1' if key[0] == 'f' else 'inf'}), got "
                           f"{robust[key]:g}")
    for key in ("opposition", "drive"):                                                     # optional
        if d.get(key) is not None:
            robust[key] = _number(d[key], f"{where}.{key}")
            if not -1.0 <= robust[key] <= 1.0:
                raise _Bad(f"{where}.{key}: expected a number in [-1, 1], got {robust[key]:g}")
    return Grasp(rank=rank, wrist_pose=pose, dofs=dofs, joints=joints, epsilon=scalars["epsilon"], volume=volume,
                 force_closure=fc, alignment_quality=scalars["alignment_quality"], votes=votes,
                 penetration_depth=scalars["penetration_depth"],
                 contact_points=np.reshape(np.array(points, float), (-1, 3)),
                 contact_normals=np.reshape(np.array(normals, float), (-1, 3)), contact_links=tuple(links),
                 sample=sample, aligned_pose=aligned, backoff=backoff, fine_tuned=fine_tuned, **robust)


def parse_grasps(doc, path: str = "<grasps>", hand=None) -> GraspsFile:
    """Checks a parsed grasps document (see :func:`load_grasps`)."""
    try:
        if not isinstance(doc, dict):
            raise _Bad(f"expected a JSON object, got {type(doc).__name__}")
        fmt = doc.get("format")
        if fmt != GRASPS_FORMAT:
            raise _Bad(f"format: expected {GRASPS_FORMAT!r}, got {json.dumps(fmt)[:40]}")
        items = _get(doc, "grasps", "document")
        if not isinstance(items, list):
            raise _Bad("grasps: expected a list")
        grasps = [_grasp(g, f"grasps[{k}]", hand) for k, g in enumerate(items)]
        sections = {}
        for key in ("inputs", "parameters", "counts", "timings"):
            v = doc.get(key, {})
            if not isinstance(v, dict):
                raise _Bad(f"{key}: expected an object")
            sections[key] = v
    except _Bad as e:
        raise FileError(f"{path}: {e}") from None
    return GraspsFile(path=path, grasps=grasps, document=doc, **sections)


def load_grasps(path, hand=None) -> GraspsFile:
    """Reads a grasps.json file.

    Args:
        path: the file (str or os.PathLike).
        hand: optional :class:`pairgrasp.Hand`; when given, each grasp's ``dof`` must have one value
            per DOF of the hand, within its limits.

    Raises:
        pairgrasp.FileError: the file is missing, unreadable, not JSON, or a field is malformed; the
            message names the file and the field.
    """
    path = os.fspath(path)
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
    except OSError as e:
        raise FileError(f"{path}: cannot read: {e.strerror or e}") from None
    try:
        doc = json.loads(raw.decode("utf-8"), parse_constant=_reject_constant)
    except UnicodeDecodeError as e:
        raise FileError(f"{path}: not UTF-8 text (byte {e.start})") from None
    except json.JSONDecodeError as e:
        raise FileError(f"{path}: not valid JSON: {e.msg} at line {e.lineno} column {e.colno}") from None
    except ValueError as e:
        raise FileError(f"{path}: not valid JSON: {e}") from None
    except RecursionError:
        raise FileError(f"{path}: not valid JSON: nested too deeply") from None
    return parse_grasps(doc, path, hand)


def _reject_constant(name):
    raise ValueError(f"{name} is not a number JSON allows")


def write_grasps(path, doc: dict) -> None:
    """Writes ``doc`` as JSON to ``path`` atomically (through ``path.part`` and a rename). NaN or
    infinite numbers raise ValueError (JSON has none)."""
    path = os.fspath(path)
    tmp = f"{path}.part"
    try:
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(doc, fh, indent=1, sort_keys=False, allow_nan=False)
            fh.write("\n")
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def resolve_path(path, base, where) -> str:
    """A file recorded in a grasps.json's ``inputs``: as written, else relative to the file's folder."""
    if not isinstance(path, str) or path == "<mesh>":
        raise FileError(f"{where}: the plan did not record a file ({path!r}); pass it explicitly")
    for cand in (path, os.path.join(base, path)):
        if os.path.isfile(cand):
            return cand
    raise FileError(f"{where}: no such file: {path}")


@dataclass(frozen=True)
class Planned:
    """A grasps.json read back with the hand and target it was planned for."""

    grasps: GraspsFile
    hand: object
    target: object
    scale: float
    base: str


def load_planned(path, hand=None, target=None, document=None) -> Planned:
    """Reads a grasps.json with its hand and target (given, or the files its ``inputs`` record):
    the grasps are checked against the hand, the target against the recorded face count.
    ``document``: the file's parsed content, used instead of reading ``path`` (which still names it
    and is the folder recorded paths are relative to).
    Raises FileError for a bad file or a missing input, ValueError for another hand or target."""
    from . import _core

    path = os.fspath(path)
    gf = load_grasps(path) if document is None else parse_grasps(document, path)
    base = os.path.dirname(os.path.abspath(path))
    inputs = gf.inputs
    if hand is None:
        hand = _core.load_hand(resolve_path(inputs.get("hand_spec"), base, f"{path}: inputs.hand_spec"))
    elif not isinstance(hand, _core.Hand):
        hand = _core.load_hand(os.fspath(hand))
    planned_for = inputs.get("hand")
    if planned_for is not None and planned_for != hand.name:
        raise ValueError(f"{path}: the grasps were planned for hand '{planned_for}', not '{hand.name}'")
    gf = parse_grasps(gf.document, path, hand)  # DOF counts and limits against this hand
    scale = float(inputs.get("scale", 1.0))
    if target is None:
        target = _core.load_mesh(resolve_path(inputs.get("target"), base, f"{path}: inputs.target"), scale=scale)
    elif not isinstance(target, _core.Mesh):
        target = _core.load_mesh(os.fspath(target), scale=scale)
    if len(target.faces) != inputs.get("target_faces", len(target.faces)):
        raise ValueError(f"{path}: the grasps were planned on a target of {inputs['target_faces']} faces, "
                         f"this one has {len(target.faces)}")
    return Planned(grasps=gf, hand=hand, target=target, scale=scale, base=base)



def recorded_support(inputs: dict):
    """The :class:`pairgrasp.SupportPlane` a grasps.json's ``inputs.support`` records, or None.
    Raises FileError for a malformed record."""
    from . import _core

    s = inputs.get("support")
    if s is None:
        return None
    try:
        return _core.SupportPlane(np.asarray(s["point"], float).reshape(3), np.asarray(s["normal"], float).reshape(3))
    except (KeyError, TypeError, ValueError) as e:
        raise FileError(f"inputs.support: expected {{'point': [x, y, z], 'normal': [x, y, z]}}, got {s!r} ({e})") \
            from None


def recorded_free_surface(planned: Planned, path: str, notes: List[str]):
    """The plan's free surface rebuilt from the recorded paint file, occluders, viewpoints and support
    at the recorded resolution: (pairgrasp.FreeSurface, occluder meshes). A difference from the
    recorded count of free faces, or an input that was not recorded, is added to ``notes``."""
    from . import _core

    inputs, target, base = planned.grasps.inputs, planned.target, planned.base
    faces = regions = None
    if inputs.get("paint") is not None:
        faces, regions = _core.read_paint(resolve_path(inputs["paint"], base, f"{path}: inputs.paint"), target)
    occ = []
    for k, o in enumerate(inputs.get("occluders") or []):
        if o == "<mesh>":
            notes.append(f"inputs.occluders[{k}] was an in-memory mesh: not shown, the surface near it not marked")
            continue
        occ.append(_core.load_mesh(resolve_path(o, base, f"{path}: inputs.occluders[{k}]"), scale=planned.scale))
    vp = inputs.get("viewpoints")
    resolution = (inputs.get("free_surface") or {}).get("resolution", float("inf"))
    surface = _core.free_surface(target, paint=faces, regions=regions or None, occluders=occ,
                                 distance=float(inputs.get("occluder_distance", 0.005)),
                                 viewpoints=None if vp is None else np.asarray(vp, float).reshape(-1, 3),
                                 support=recorded_support(inputs), resolution=float(resolution))
    want, got = inputs.get("free_faces"), int(np.count_nonzero(surface.free))
    if isinstance(want, int) and want != got:
        notes.append(f"the plan had {want} free faces of {len(surface.mesh.faces)}, the recorded inputs give {got}"
                     + (" (a free mask given as an array is not recorded)" if "paint" not in inputs else ""))
    return surface, occ
