#!/usr/bin/env python3
"""Runs pairgrasp on every bad input tried and prints what the user sees, as a Markdown table.

    python scripts/bad_inputs.py           # the table in docs/reliability.md ("Bad inputs")
    python scripts/bad_inputs.py --check   # also exit 1 unless every case fails cleanly

Each case makes its bad input in a scratch folder, then either runs the `pairgrasp` command there
(a subprocess, as a user runs it) or makes one API call. A case is clean when
  - the command exits with the expected status (2 for a bad command line, 1 otherwise) and prints
    exactly one line on stderr, `pairgrasp: error: ...`, with no traceback, and leaves no output
    folder (an input that is used with a warning exits 0 and prints one `pairgrasp: warning:` line);
  - the API call raises the documented exception (ValueError, pairgrasp.FileError) whose message is
    one line;
and in both cases the message holds the case's fragment: the file or the field at fault.
tests/py/test_bad_inputs.py runs the same cases.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import shutil
import struct
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Callable, List, Optional

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"
JAW = MODELS / "parallel_jaw" / "parallel_jaw.json"
BARRETT = MODELS / "barrett" / "barrett.json"
BOX = MODELS / "targets" / "box.stl"
FLASK = MODELS / "targets" / "flask.stl"


# ------------------------------------------------------------------------------------------ cases

@dataclass
class Cli:
    """A `pairgrasp` command run in the scratch folder; `shown` is how the table writes it."""
    argv: List[str]
    status: int = 1
    warning: bool = False  # the input is used: exit 0 with one warning line
    shown: str = ""


@dataclass
class Api:
    """One API call; `shown` is how the table writes it."""
    call: Callable[[], object]
    shown: str
    error: str = "ValueError"  # "ValueError" or "FileError"


@dataclass
class Case:
    input: str                                  # what is wrong, for the table
    make: Callable[[pathlib.Path], object]      # makes the input in a folder; returns Cli or Api
    expect: str                                 # fragment the message must hold


@dataclass
class Outcome:
    case: Case
    shown: str
    message: str
    status: str
    problems: List[str] = field(default_factory=list)


CASES: List[Case] = []


def case(input: str, expect: str):
    def register(make):
        CASES.append(Case(input, make, expect))
        return make
    return register


def plan(*, hand=JAW, target=BOX, extra=(), status=1):
    """A plan command line (parallel jaw, box, --edge 0.008, no pictures, quiet, -o out); the table
    shows only what differs from those defaults."""
    argv = ["plan", "--hand", str(hand), "--target", str(target), "--edge", "0.008", "--pictures", "0", "--quiet",
            *extra, "-o", "out"]
    given = ([] if hand == JAW else ["--hand", str(hand)]) + ([] if target == BOX else ["--target", str(target)])
    return Cli(argv, status=status, shown=" ".join(["pairgrasp plan", *given, *extra]))


# ---- files

def box_arrays():
    import pairgrasp as pg
    m = pg.load_mesh(str(BOX))
    return np.asarray(m.vertices), np.asarray(m.faces)


def write_stl(path, V, F):
    with open(path, "wb") as f:
        f.write(b"\0" * 80 + struct.pack("<I", len(F)))
        for t in F:
            f.write(struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *V[i]) for i in t) + b"\0\0")


def ascii_stl(V, F):
    s = "solid box\n"
    for t in F:
        s += " facet normal 0 0 0\n  outer loop\n" + "".join("   vertex %r %r %r\n" % tuple(map(float, V[i])) for i in t)
        s += "  endloop\n endfacet\n"
    return s + "endsolid box\n"


def obj(V, F):
    return "".join("v %r %r %r\n" % tuple(map(float, v)) for v in V) + "".join("f %d %d %d\n" % tuple(t + 1) for t in F)


def ply_binary(V, F):
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(V)}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {len(F)}\nproperty list uchar int vertex_indices\nend_header\n")
    body = b"".join(struct.pack("<3f", *v) for v in V) + b"".join(struct.pack("<B3i", 3, *t) for t in F)
    return head.encode() + body


def dae(V, F, p=None, unit='<unit meter="1"/>', nodes=None):
    pos = " ".join(repr(float(c)) for v in V for c in v)
    idx = p if p is not None else " ".join(str(int(i)) for t in F for i in t)
    nodes = nodes or '<node id="n"><instance_geometry url="#g"/></node>'
    return f"""<?xml version="1.0"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<asset>{unit}<up_axis>Z_UP</up_axis></asset>
<library_geometries><geometry id="g"><mesh>
<source id="s"><float_array id="a" count="{3 * len(V)}">{pos}</float_array>
<technique_common><accessor source="#a" count="{len(V)}" stride="3"><param name="X" type="float"/>
<param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
<vertices id="v"><input semantic="POSITION" source="#s"/></vertices>
<triangles count="{len(F)}"><input semantic="VERTEX" source="#v" offset="0"/><p>{idx}</p></triangles>
</mesh></geometry></library_geometries>
<library_visual_scenes><visual_scene id="scene">{nodes}</visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
"""


def copy_hand(d: pathlib.Path, spec_edit=None, urdf_edit=None) -> str:
    """The parallel jaw copied into d/hand (spec, URDF, meshes), optionally edited; its spec path."""
    h = d / "hand"
    shutil.copytree(JAW.parent, h)
    spec = json.loads((h / "parallel_jaw.json").read_text())
    if spec_edit:
        spec_edit(spec)
    (h / "parallel_jaw.json").write_text(json.dumps(spec))
    if urdf_edit:
        u = h / "parallel_jaw.urdf"
        u.write_text(urdf_edit(u.read_text()))
    return "hand/parallel_jaw.json"


def paint_doc(**kw):
    doc = {"format": "pairgrasp-paint", "version": 1, "faces": 12, "occluded": [0]}
    doc.update(kw)
    return json.dumps(doc)


# ---- meshes given as --target

@case("mesh file missing", "--target: no such file: missing.stl")
def _(d):
    return plan(target="missing.stl")


@case("mesh path is a folder", "--target: not a file: folder")
def _(d):
    (d / "folder").mkdir()
    return plan(target="folder")


@case("empty mesh file (0 bytes)", "empty.stl: empty file")
def _(d):
    (d / "empty.stl").write_bytes(b"")
    return plan(target="empty.stl")


@case("binary STL cut short", "cut.stl")
def _(d):
    write_stl(d / "full.stl", *box_arrays())
    (d / "cut.stl").write_bytes((d / "full.stl").read_bytes()[:-30])
    return plan(target="cut.stl")


@case("ASCII STL with a garbled number", "garbled.stl")
def _(d):
    (d / "garbled.stl").write_text(ascii_stl(*box_arrays()).replace("vertex", "vertex x1.2.3", 1))
    return plan(target="garbled.stl")


@case("STL with a NaN vertex", "nan.stl: vertex")
def _(d):
    V, F = box_arrays()
    V = V.copy()
    V[3, 1] = float("nan")
    write_stl(d / "nan.stl", V, F)
    return plan(target="nan.stl")


@case("random bytes named .stl", "noise.stl")
def _(d):
    (d / "noise.stl").write_bytes(np.random.default_rng(0).integers(0, 256, 3000, dtype=np.uint8).tobytes())
    return plan(target="noise.stl")


@case("mesh whose every triangle is degenerate", "flat.stl: no triangles left")
def _(d):
    V = np.array([[0, 0, 0], [0.05, 0, 0], [0.1, 0, 0], [0.02, 0, 0]], float)
    write_stl(d / "flat.stl", V, np.array([[0, 1, 2], [0, 3, 1]]))
    return plan(target="flat.stl")


@case("OBJ face index out of range", "bad_index.obj")
def _(d):
    V, F = box_arrays()
    (d / "bad_index.obj").write_text(obj(V, F) + "f 1 2 99\n")
    return plan(target="bad_index.obj")


@case("OBJ with vertices but no faces", "no_faces.obj")
def _(d):
    V, _ = box_arrays()
    (d / "no_faces.obj").write_text("".join("v %r %r %r\n" % tuple(map(float, v)) for v in V))
    return plan(target="no_faces.obj")


@case("binary PLY cut short", "cut.ply: ")
def _(d):
    (d / "cut.ply").write_bytes(ply_binary(*box_arrays())[:-9])
    return plan(target="cut.ply")


@case("PLY with a garbled header", "header.ply: ")
def _(d):
    (d / "header.ply").write_bytes(ply_binary(*box_arrays()).replace(b"element face", b"element fa ce", 1))
    return plan(target="header.ply")


@case("COLLADA index list with a non-integer", "letters.dae: <p> index list")
def _(d):
    V, F = box_arrays()
    (d / "letters.dae").write_text(dae(V, F, p="0 1 2 x 4 5"))
    return plan(target="letters.dae")


@case("COLLADA nodes that instance each other", "cycle.dae: <instance_node> references make a cycle")
def _(d):
    V, F = box_arrays()
    nodes = ('<node id="a"><instance_geometry url="#g"/><instance_node url="#b"/></node>'
             '<node id="b"><instance_node url="#a"/></node>')
    (d / "cycle.dae").write_text(dae(V, F, nodes=nodes))
    return plan(target="cycle.dae")


@case("COLLADA with a negative unit", "unit.dae: <asset><unit meter=\"-1\">")
def _(d):
    V, F = box_arrays()
    (d / "unit.dae").write_text(dae(V, F, unit='<unit meter="-1"/>'))
    return plan(target="unit.dae")


@case("COLLADA cut short", "cut.dae")
def _(d):
    V, F = box_arrays()
    text = dae(V, F)
    (d / "cut.dae").write_text(text[: len(text) // 2])
    return plan(target="cut.dae")


@case("unsupported mesh format", "shape.xyz")
def _(d):
    (d / "shape.xyz").write_text("0 0 0\n1 0 0\n0 1 0\n")
    return plan(target="shape.xyz")


@case("target in millimetres without --scale", "box_mm.stl: every extent of the target")
def _(d):
    V, F = box_arrays()
    write_stl(d / "box_mm.stl", V * 1000, F)
    return plan(target="box_mm.stl")


@case("--scale 0.001 on a target already in metres", "is it scaled twice")
def _(d):
    return plan(target=BOX, extra=["--scale", "0.001"])


@case("target that is not watertight (one face missing): planned, with a warning", "open.stl: the target is not watertight")
def _(d):
    V, F = box_arrays()
    write_stl(d / "open.stl", V, F[:-1])
    c = plan(target="open.stl", extra=["--top", "1", "--schedule", "fast", "--step", "0.03"])
    c.status, c.warning = 0, True
    return c


@case("--obstacle file missing", "--obstacle: no such file: table.stl")
def _(d):
    return plan(extra=["--obstacle", "table.stl"])


@case("--occluder mesh garbled", "holder.obj")
def _(d):
    (d / "holder.obj").write_text("v 0 0 0\nv 1 0\nf 1 2 3\n")
    return plan(extra=["--occluder", "holder.obj"])


@case("--support plane that cuts through the target", "--support: the plane cuts through the target")
def _(d):
    return plan(extra=["--support", "0.05"])


@case("--support that leaves nothing free", "--support: no free face left")
def _(d):
    return plan(extra=["--support", "--occluder-distance", "0.2"])


@case("--support plane not finite", "argument --support: expected finite numbers")
def _(d):
    return plan(extra=["--support", "0,0,nan,0,0,1"], status=2)


@case("--support normal zero", "argument --support: the normal NX,NY,NZ is zero")
def _(d):
    return plan(extra=["--support", "0,0,0,0,0,0"], status=2)


@case("--occluder-distance negative", "--occluder-distance")
def _(d):
    return plan(extra=["--support", "--occluder-distance", "-0.001"], status=2)


# ---- paint files

@case("paint file missing", "--paint: no such file: none.paint.json")
def _(d):
    return plan(extra=["--paint", "none.paint.json"])


@case("paint file made for another mesh", "flask.paint.json: faces: the paint is for a mesh of 9280 faces")
def _(d):
    shutil.copy(MODELS / "targets" / "flask.paint.json", d / "flask.paint.json")
    return plan(extra=["--paint", "flask.paint.json"])


@case("paint that leaves no face free", "occluded.paint.json: paint leaves no free face")
def _(d):
    (d / "occluded.paint.json").write_text(paint_doc(default="occluded", occluded=[]))
    return plan(extra=["--paint", "occluded.paint.json"])


@case("paint file cut short (invalid JSON)", "cut.paint.json: file: not valid JSON")
def _(d):
    (d / "cut.paint.json").write_text(paint_doc()[:-5])
    return plan(extra=["--paint", "cut.paint.json"])


@case("paint file with NaN", "nan.paint.json: file: not valid JSON")
def _(d):
    (d / "nan.paint.json").write_text(paint_doc(regions=[]).replace("[]", '[{"shape": "sphere", "center": [NaN, 0, 0], '
                                                                      '"radius": 1, "mark": "free"}]'))
    return plan(extra=["--paint", "nan.paint.json"])


@case("paint region with a negative radius", "radius.paint.json: regions[0].radius: must be > 0")
def _(d):
    (d / "radius.paint.json").write_text(paint_doc(regions=[{"shape": "sphere", "center": [0, 0, 0], "radius": -0.5,
                                                             "mark": "free"}]))
    return plan(extra=["--paint", "radius.paint.json"])


@case("paint face index out of range", "index.paint.json: occluded[1]")
def _(d):
    (d / "index.paint.json").write_text(paint_doc(occluded=[0, 12]))
    return plan(extra=["--paint", "index.paint.json"])


@case("paint file with an unknown key", "key.paint.json: colour: unknown key")
def _(d):
    (d / "key.paint.json").write_text(paint_doc(colour="red"))
    return plan(extra=["--paint", "key.paint.json"])


# ---- hands

@case("hand spec missing", "--hand: no such file: nohand.json")
def _(d):
    return plan(hand="nohand.json")


@case("hand spec not JSON", "hand/parallel_jaw.json: invalid JSON")
def _(d):
    copy_hand(d)
    (d / "hand" / "parallel_jaw.json").write_text("{'dofs': [}")
    return plan(hand="hand/parallel_jaw.json")


@case("hand spec without its dofs", "hand/parallel_jaw.json: dofs: missing")
def _(d):
    return plan(hand=copy_hand(d, spec_edit=lambda s: s.pop("dofs")))


@case("hand spec naming a joint the URDF lacks", "dofs[0].joints[0].joint: no joint 'pj_thumb_joint'")
def _(d):
    return plan(hand=copy_hand(d, spec_edit=lambda s: s["dofs"][0]["joints"][0].update(joint="pj_thumb_joint")))


@case("hand spec with an unknown key", "hand/parallel_jaw.json: speed")
def _(d):
    return plan(hand=copy_hand(d, spec_edit=lambda s: s.update(speed=3)))


@case("hand spec DOF limits beyond the URDF's", "dofs[0].upper")
def _(d):
    return plan(hand=copy_hand(d, spec_edit=lambda s: s["dofs"][0].update(lower=0.0, upper=0.5)))


@case("hand spec active surface selecting no face", "active_surfaces[0]")
def _(d):
    return plan(hand=copy_hand(d, spec_edit=lambda s: s["active_surfaces"][0].update(
        box={"min": [5, 5, 5], "max": [6, 6, 6]})))


@case("hand spec naming a URDF that does not exist", "hand/parallel_jaw.json: urdf: no such file")
def _(d):
    return plan(hand=copy_hand(d, spec_edit=lambda s: s.update(urdf="gone.urdf")))


@case("URDF that is not well-formed XML", "hand/parallel_jaw.urdf: malformed URDF")
def _(d):
    return plan(hand=copy_hand(d, urdf_edit=lambda u: u[: len(u) // 2]))


@case("URDF mesh file missing", "pj_finger_lost.stl")
def _(d):
    return plan(hand=copy_hand(d, urdf_edit=lambda u: u.replace("meshes/pj_finger.stl", "meshes/pj_finger_lost.stl")))


@case("URDF package:// URI that does not resolve", "cannot resolve 'package://nowhere/meshes/pj_base.stl'")
def _(d):
    return plan(hand=copy_hand(d, urdf_edit=lambda u: u.replace('"meshes/pj_base.stl"',
                                                                '"package://nowhere/meshes/pj_base.stl"')))


@case("URDF joint with an unsupported type", "pj_left_joint")
def _(d):
    return plan(hand=copy_hand(d, urdf_edit=lambda u: u.replace('name="pj_left_joint" type="prismatic"',
                                                                'name="pj_left_joint" type="floating"')))


# ---- command-line values

@case("--edge negative", "--edge: expected a finite number > 0, got '-1'")
def _(d):
    return plan(extra=["--edge", "-1"], status=2)


@case("--edge not a number", "--edge: expected a number, got 'fine'")
def _(d):
    return plan(extra=["--edge", "fine"], status=2)


@case("--edge nan", "--edge: expected a finite number > 0, got 'nan'")
def _(d):
    return plan(extra=["--edge", "nan"], status=2)


@case("--top 0", "--top: expected an integer >= 1, got '0'")
def _(d):
    return plan(extra=["--top", "0"], status=2)


@case("--threads -1", "--threads: expected an integer >= 0, got '-1'")
def _(d):
    return plan(extra=["--threads", "-1"], status=2)


@case("--scale 0", "--scale: expected a finite number > 0, got '0'")
def _(d):
    return plan(extra=["--scale", "0"], status=2)


@case("--viewpoint with two numbers", "--viewpoint")
def _(d):
    return plan(extra=["--viewpoint", "0", "1"], status=2)


@case("--schedule unknown", "--schedule: invalid choice: 'slow'")
def _(d):
    return plan(extra=["--schedule", "slow"], status=2)


@case("unknown option", "unrecognized arguments: --fast")
def _(d):
    return plan(extra=["--fast"], status=2)


@case("--hand not given", "the following arguments are required: --hand")
def _(d):
    return Cli(["plan", "--target", str(BOX), "-o", "out"], status=2, shown="pairgrasp plan --target models/targets/box.stl")


@case("-o names an existing file", "-o: out exists and is not a directory")
def _(d):
    (d / "out").write_text("precious")
    return plan()


@case("--edge so fine the pairs exceed the budget", "max_pairs: at a facet edge of 0.0002 m")
def _(d):
    return Cli(["plan", "--hand", str(BARRETT), "--target", str(FLASK), "--edge", "0.0002", "--quiet", "-o", "out"],
               shown="pairgrasp plan --hand models/barrett/barrett.json --target models/targets/flask.stl --edge 0.0002")


# ---- API calls

_objects = {}


def objects():
    """The parallel jaw, the box, a checker and an aligner, made once."""
    if not _objects:
        import pairgrasp as pg
        hand = pg.load_hand(str(JAW))
        mesh = pg.load_mesh(str(BOX))
        target = pg.build_target_index(mesh, edge=0.01, d_max=0.2)
        _objects.update(pg=pg, hand=hand, mesh=mesh, checker=pg.GraspChecker(hand, mesh),
                        aligner=pg.Aligner(target.index))
    return _objects


def api(shown, call, error="ValueError"):
    return Api(call, shown, error)


def nan_pose():
    T = np.eye(4)
    T[1, 3] = float("nan")
    return T


@case("DOF value beyond its limit", "dofs[0] ('opening'): value 0.5 m is outside its limits [0, 0.08] m")
def _(d):
    o = objects()
    return api("hand.link_transforms([0.5])", lambda: o["hand"].link_transforms([0.5]))


@case("DOF vector of the wrong length", "dofs: expected 1, got 2")
def _(d):
    o = objects()
    return api("hand.constellation([0.01, 0.02])", lambda: o["hand"].constellation([0.01, 0.02]))


@case("NaN DOF value", "dofs[0] ('opening'): value nan is not finite")
def _(d):
    o = objects()
    return api("checker.check(eye(4), [nan])", lambda: o["checker"].check(np.eye(4), [float("nan")]))


@case("NaN wrist pose", "wrist")
def _(d):
    o = objects()
    return api("checker.check(T_nan, [0.04])", lambda: o["checker"].check(nan_pose(), [0.04]))


@case("wrist pose that is not rigid (scaled)", "wrist")
def _(d):
    o = objects()
    return api("checker.close(2 * eye(4), [0.04])", lambda: o["checker"].close(np.diag([2.0, 2, 2, 1]), [0.04]))


@case("check_many with mismatched shapes", "dofs: expected a (2, 1) array")
def _(d):
    o = objects()
    return api("checker.check_many(eye(4)[None].repeat(2, 0), [[0.04]])",
               lambda: o["checker"].check_many(np.eye(4)[None].repeat(2, 0), [[0.04]]))


@case("constellation with a NaN point", "points: row 1 is not finite")
def _(d):
    o = objects()
    P = np.array([[0, 0, 0], [float("nan"), 0, 0], [0, 0.01, 0]])
    N = np.tile([0.0, 0, 1], (3, 1))
    return api("aligner.align(P_nan, N)", lambda: o["aligner"].align(P, N))


@case("constellation with non-unit normals", "normals: row 0 has length")
def _(d):
    o = objects()
    P = np.array([[0, 0, 0], [0.02, 0, 0], [0, 0.01, 0]])
    return api("aligner.align(P, 2 * N)", lambda: o["aligner"].align(P, np.tile([0.0, 0, 2], (3, 1))))


@case("mesh arrays with a NaN vertex", "vertices: vertex 1 is not finite")
def _(d):
    o = objects()
    V = np.array([[0, 0, 0], [float("nan"), 0, 0], [0, 1, 0]])
    return api("pg.make_mesh(V_nan, F)", lambda: o["pg"].make_mesh(V, np.array([[0, 1, 2]])))


@case("mesh arrays with coordinates of 1e200 m (found by fuzzing: areas overflowed)", "vertices: vertex 1")
def _(d):
    o = objects()
    V = np.array([[0, 0, 0], [1e200, 0, 0], [0, 1, 0]])
    return api("pg.make_mesh(V_huge, F)", lambda: o["pg"].make_mesh(V, np.array([[0, 1, 2]])))


@case("mesh arrays with a face index out of range", "faces: face 0 has index 7 out of range [0, 3)")
def _(d):
    o = objects()
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    return api("pg.make_mesh(V, [[0, 1, 7]])", lambda: o["pg"].make_mesh(V, np.array([[0, 1, 7]])))


@case("facet edge not positive", "edge")
def _(d):
    o = objects()
    return api("pg.tessellate(mesh, -0.01)", lambda: o["pg"].tessellate(o["mesh"], -0.01))


@case("pair index over its budget (from arrays)", "max_pairs: ")
def _(d):
    o = objects()
    f = o["pg"].tessellate(o["mesh"], 0.005)
    return api("pg.PairIndex(P, N, max_pairs=10000)",
               lambda: o["pg"].PairIndex(f.points, f.normals, d_max=0.2, max_pairs=10_000))


@case("target index over its budget", "max_pairs: at a facet edge of 0.0005 m")
def _(d):
    o = objects()
    return api("pg.build_target_index(box, edge=0.0005, max_pairs=10**6)",
               lambda: o["pg"].build_target_index(o["mesh"], edge=0.0005, max_pairs=10 ** 6))


@case("free mask of the wrong size", "paint: expected a (12,) bool mask")
def _(d):
    o = objects()
    return api("pg.Planner(hand, box, paint=ones(5, bool))",
               lambda: o["pg"].Planner(o["hand"], o["mesh"], paint=np.ones(5, bool)))


@case("unknown planner parameter", "unknown planner parameter 'edges_mm'")
def _(d):
    o = objects()
    return api("pg.Planner(hand, box, edges_mm=5)", lambda: o["pg"].Planner(o["hand"], o["mesh"], edges_mm=5))


@case("contacts with a NaN point", "points")
def _(d):
    o = objects()
    P = np.array([[0.03, 0, 0.06], [float("nan"), 0, 0.06]])
    N = np.array([[1.0, 0, 0], [-1.0, 0, 0]])
    return api("pg.grasp_quality(P_nan, N, c, r)", lambda: o["pg"].grasp_quality(P, N, np.zeros(3), 0.1))


GRASP = {"rank": 1, "wrist_pose": np.eye(4).tolist(), "dof": [0.04], "joints": {"pj_left_joint": 0.02},
         "epsilon": 0.1, "volume": 0.0, "force_closure": True, "alignment_quality": 5.0, "votes": 12,
         "penetration_depth": 0.0, "contacts": [{"point": [0.03, 0, 0.06], "normal": [1, 0, 0], "link": "pj_left_finger"}]}


def grasps_file(d, name, text):
    (d / name).write_text(text)
    return str(d / name)


def load_grasps_case(d, name, text, with_hand=False):
    o = objects()
    path = grasps_file(d, name, text)
    call = (lambda: o["pg"].load_grasps(path, hand=o["hand"])) if with_hand else (lambda: o["pg"].load_grasps(path))
    return api(f"pg.load_grasps('{name}'{', hand=jaw' if with_hand else ''})", call, "FileError")


def grasps_doc(**grasp):
    return json.dumps({"format": "pairgrasp.grasps/1", "grasps": [{**GRASP, **grasp}]})


@case("grasps.json missing", "none.json: cannot read")
def _(d):
    o = objects()
    return api("pg.load_grasps('none.json')", lambda: o["pg"].load_grasps(str(d / "none.json")), "FileError")


@case("grasps.json cut short", "cut.json: not valid JSON")
def _(d):
    return load_grasps_case(d, "cut.json", grasps_doc()[:-10])


@case("grasps.json of another format", "other.json: format: expected 'pairgrasp.grasps/1'")
def _(d):
    return load_grasps_case(d, "other.json", json.dumps({"format": "grasps/0", "grasps": []}))


@case("grasps.json with NaN", "nan.json: not valid JSON: NaN is not a number JSON allows")
def _(d):
    return load_grasps_case(d, "nan.json", grasps_doc().replace('"epsilon": 0.1', '"epsilon": NaN'))


@case("grasps.json wrist pose that is not a rotation", "pose.json: grasps[0].wrist_pose: the rotation part")
def _(d):
    return load_grasps_case(d, "pose.json", grasps_doc(wrist_pose=np.diag([1.0, 1, -1, 1]).tolist()))


@case("grasps.json without a field", "field.json: grasps[0]: missing 'votes'")
def _(d):
    g = dict(GRASP)
    g.pop("votes")
    return load_grasps_case(d, "field.json", json.dumps({"format": "pairgrasp.grasps/1", "grasps": [g]}))


@case("grasps.json DOF outside the hand's limits", "dof.json: grasps[0].dof[0] (opening): 0.3 is outside [0, 0.08]")
def _(d):
    return load_grasps_case(d, "dof.json", grasps_doc(dof=[0.3]), with_hand=True)


# ------------------------------------------------------------------------------------------ running

def _display(text: str, folder: pathlib.Path) -> str:
    """Paths as a user in the scratch folder (or the project root) would see them."""
    return text.replace(str(folder) + os.sep, "").replace(str(ROOT) + os.sep, "")


def run_case(c: Case, folder: pathlib.Path) -> Outcome:
    folder.mkdir(parents=True, exist_ok=True)
    what = c.make(folder)
    if isinstance(what, Cli):
        r = subprocess.run([sys.executable, "-m", "pairgrasp.cli", *what.argv], cwd=folder, capture_output=True,
                           text=True, timeout=900, stdin=subprocess.DEVNULL)
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        shown = what.shown or "pairgrasp " + " ".join(a if " " not in a else repr(a) for a in what.argv)
        out = Outcome(c, _display(shown, folder), _display(lines[0] if lines else "", folder), f"exit {r.returncode}")
        prefix = "pairgrasp: warning: " if what.warning else "pairgrasp: error: "
        if r.returncode != what.status:
            out.problems.append(f"exit status {r.returncode}, expected {what.status}")
        if len(lines) != 1 or not lines[0].startswith(prefix):
            out.problems.append(f"stderr is not one '{prefix.strip()}' line: {r.stderr[-500:]!r}")
        if "Traceback" in r.stderr:
            out.problems.append("a traceback was printed")
        if not what.warning and (folder / "out").is_dir():
            out.problems.append("an output folder was left")
    else:
        import pairgrasp as pg
        expected = {"ValueError": ValueError, "FileError": pg.FileError}[what.error]
        try:
            what.call()
        except Exception as e:  # noqa: BLE001 - the point is to see what comes out
            message = str(e)
            out = Outcome(c, what.shown, _display(message.splitlines()[0] if message else "", folder),
                          type(e).__name__ if type(e) is not pg.FileError else "FileError")
            if not isinstance(e, expected) or (expected is ValueError and isinstance(e, pg.FileError)):
                out.problems.append(f"raised {type(e).__name__}, expected {what.error}")
            if "\n" in message:
                out.problems.append("the message has more than one line")
        else:
            out = Outcome(c, what.shown, "", "no error")
            out.problems.append(f"no exception, expected {what.error}")
    if c.expect not in out.message:
        out.problems.append(f"the message does not hold {c.expect!r}")
    return out


def run_all(cases=None, workers: int = 2) -> List[Outcome]:
    cases = CASES if cases is None else cases
    objects()  # made once, before the threads
    with tempfile.TemporaryDirectory(prefix="pairgrasp-bad-") as tmp:
        base = pathlib.Path(tmp)
        with ThreadPoolExecutor(max_workers=workers) as pool:
            return list(pool.map(lambda kc: run_case(kc[1], base / f"case{kc[0]:03d}"), enumerate(cases)))


def markdown(outcomes: List[Outcome]) -> str:
    def cell(s):
        return "`" + s.replace("|", "\\|").replace("`", "'") + "`" if s else ""

    rows = ["| bad input | given as | what the user sees | result |", "| --- | --- | --- | --- |"]
    for o in outcomes:
        rows.append(f"| {o.case.input} | {cell(o.shown)} | {cell(o.message)} | {o.status}"
                    f"{' **NOT CLEAN: ' + '; '.join(o.problems) + '**' if o.problems else ''} |")
    return "\n".join(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 unless every case fails cleanly")
    args = ap.parse_args(argv)
    outcomes = run_all()
    print(markdown(outcomes))
    bad = [o for o in outcomes if o.problems]
    print(f"\n{len(outcomes)} bad inputs, {len(outcomes) - len(bad)} handled cleanly", file=sys.stderr)
    return 1 if (args.check and bad) else 0


if __name__ == "__main__":
    sys.exit(main())
