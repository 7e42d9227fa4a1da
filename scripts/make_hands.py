#!/usr/bin/env python3
"""Generates the bundled hand models: URDF + meshes + hand spec.

    python3 scripts/make_hands.py            # writes models/barrett/ and models/parallel_jaw/

Outputs (committed to the repository, regenerate after editing this script):

models/barrett/
    bh8_28x.urdf                 Barrett BH8-28x at its published kinematic dimensions
    barrett.json                 hand spec: wrist link, 4 DOFs, active surfaces, approach
    meshes/bh_palm.dae           palm (COLLADA, authored in millimetres with <unit meter="0.001">)
    meshes/bh_knuckle.stl        spread (knuckle) link of fingers 1 and 2 (visual geometry only)
    meshes/bh_finger_prox.stl    proximal link
    meshes/bh_finger_dist_mm.stl distal link, in millimetres (the URDF scales it by 0.001)
models/parallel_jaw/
    parallel_jaw.urdf            two-finger parallel-jaw gripper, 1 prismatic DOF (mimic finger)
    parallel_jaw.json            hand spec
    meshes/pj_base.stl, meshes/pj_finger.stl

The models deliberately exercise every geometry path of the URDF loader: a COLLADA mesh with a
unit, a `package://` URI (resolved through the spec's "package_paths"), relative mesh paths, a
mesh `scale`, a `<box>` primitive with a geometry `<origin>`, visual-only links, fixed joints,
`<mimic>` joints and a DOF driving two joints with opposite ratios.

Dimensions (metres, radians): see models/README.md. Needs numpy and trimesh (with manifold3d
for the parallel-jaw finger's union).
"""
from __future__ import annotations

import json
import math
import pathlib
import struct

import numpy as np
import trimesh

ROOT = pathlib.Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"

# ----------------------------------------------------------------------------- Barrett BH8-28x
PALM_TOP = 0.075          # palm top face height above the wrist frame (base of the palm)
PALM_RADIUS = 0.048       # palm drawn as a 24-sided prism of this circumradius
BASE_OFFSET = 0.025       # spreading finger bases at x = +-0.025 on the palm top
KNUCKLE_REACH = 0.050     # knuckle link: spread axis to proximal joint, radially
KNUCKLE_HEIGHT = 0.020    # proximal joint axis height above the palm top
FINGER_WIDTH = 0.025      # finger links' width along the flexion axis
PROX_LENGTH = 0.070       # proximal joint to distal joint
PROX_THICKNESS = 0.018
DIST_LENGTH = 0.055       # distal joint to fingertip
DIST_THICKNESS = 0.016
DIST_REST = math.radians(42.0)   # distal link's rest bend, built into the distal joint origin
FLEX_MAX = 2.44
DIST_MAX = 0.84
MIMIC_DIST = 1.0 / 3.0

# ----------------------------------------------------------------------------- parallel jaw
PJ_BASE = ((-0.060, -0.020, 0.000), (0.060, 0.020, 0.050))   # base block (wrist frame)
PJ_STROKE = 0.040          # travel of each finger; the opening DOF is twice this
PJ_PAD = ((-0.008, -0.010, 0.020), (0.000, 0.010, 0.070))       # pad, finger frame, inner face x = 0
PJ_CARRIAGE = ((-0.025, -0.010, 0.000), (-0.005, 0.010, 0.025))  # carriage under the pad


def box(lo, hi) -> trimesh.Trimesh:
    return trimesh.creation.box(bounds=[lo, hi])


def write_stl(path: pathlib.Path, mesh: trimesh.Trimesh, scale: float = 1.0) -> None:
    """Binary STL, outward counter-clockwise winding, coordinates multiplied by `scale`."""
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0, path
    v = np.asarray(mesh.vertices, float) * scale
    tri = v[np.asarray(mesh.faces)]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    with open(path, "wb") as f:
        header = f"pairgrasp make_hands.py: {path.name}".encode()[:80]
        f.write(header.ljust(80, b" "))
        f.write(struct.pack("<I", len(tri)))
        for k in range(len(tri)):
            f.write(struct.pack("<12fH", *n[k], *tri[k].ravel(), 0))


def write_dae(path: pathlib.Path, mesh: trimesh.Trimesh, name: str, unit_meter: float) -> None:
    """Minimal COLLADA 1.4.1 file, Z up, coordinates given in units of `unit_meter` metres."""
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0, path
    v = np.asarray(mesh.vertices, float) / unit_meter
    f = np.asarray(mesh.faces, int)
    floats = " ".join(f"{x:.6g}" for x in v.ravel())
    idx = " ".join(str(i) for i in f.ravel())
    text = f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset>
    <contributor><authoring_tool>pairgrasp make_hands.py</authoring_tool></contributor>
    <unit name="millimeter" meter="{unit_meter:g}"/>
    <up_axis>Z_UP</up_axis>
  </asset>
  <library_geometries>
    <geometry id="{name}-mesh" name="{name}">
      <mesh>
        <source id="{name}-positions">
          <float_array id="{name}-positions-array" count="{v.size}">{floats}</float_array>
          <technique_common>
            <accessor source="#{name}-positions-array" count="{len(v)}" stride="3">
              <param name="X" type="float"/>
              <param name="Y" type="float"/>
              <param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <vertices id="{name}-vertices">
          <input semantic="POSITION" source="#{name}-positions"/>
        </vertices>
        <triangles count="{len(f)}">
          <input semantic="VERTEX" source="#{name}-vertices" offset="0"/>
          <p>{idx}</p>
        </triangles>
      </mesh>
    </geometry>
  </library_geometries>
  <library_visual_scenes>
    <visual_scene id="Scene" name="Scene">
      <node id="{name}" name="{name}">
        <instance_geometry url="#{name}-mesh"/>
      </node>
    </visual_scene>
  </library_visual_scenes>
  <scene>
    <instance_visual_scene url="#Scene"/>
  </scene>
</COLLADA>
"""
    path.write_text(text)


def prism(radius: float, z0: float, z1: float, sides: int) -> trimesh.Trimesh:
    """A regular prism about z, caps as fans around their centres (outward winding)."""
    a = 2 * math.pi * (np.arange(sides) + 0.5) / sides
    ring = np.c_[radius * np.cos(a), radius * np.sin(a)]
    v = np.vstack([np.c_[ring, np.full(sides, z0)], np.c_[ring, np.full(sides, z1)],
                   [[0, 0, z0], [0, 0, z1]]])
    cb, ct = 2 * sides, 2 * sides + 1
    faces = []
    for i in range(sides):
        j = (i + 1) % sides
        faces += [[i, j, sides + j], [i, sides + j, sides + i]]   # side
        faces += [[cb, j, i]]                                     # bottom, normal -z
        faces += [[ct, sides + i, sides + j]]                     # top, normal +z
    return trimesh.Trimesh(v, np.array(faces), process=False)


def fmt(*xs: float) -> str:
    """Shortest exact text of each number, with float noise (below 1e-15) rounded away."""
    out = []
    for x in map(float, xs):
        r = round(x, 12)
        out.append(repr(r if abs(r - x) < 1e-15 else x))
    return " ".join(out)


def mesh_visual_collision(filename: str, scale: str | None = None, visual_only: bool = False) -> str:
    s = f' scale="{scale}"' if scale else ""
    geom = f'<geometry><mesh filename="{filename}"{s}/></geometry>'
    out = f"    <visual>{geom}</visual>\n"
    if not visual_only:
        out += f"    <collision>{geom}</collision>\n"
    return out


def write_spec(path: pathlib.Path, spec: dict) -> None:
    """JSON with one line per DOF and per active surface."""
    lines = []
    for k, v in spec.items():
        if isinstance(v, list) and v and isinstance(v[0], dict):
            items = ",\n".join("    " + json.dumps(x) for x in v)
            lines.append(f'  "{k}": [\n{items}\n  ]')
        else:
            lines.append(f"  {json.dumps(k)}: {json.dumps(v)}")
    path.write_text("{\n" + ",\n".join(lines) + "\n}\n")


def barrett() -> None:
    d = MODELS / "barrett"
    (d / "meshes").mkdir(parents=True, exist_ok=True)

    write_dae(d / "meshes" / "bh_palm.dae", prism(PALM_RADIUS, 0.0, PALM_TOP, 24), "bh_palm", 0.001)
    hw = FINGER_WIDTH / 2
    knuckle_lo = (-hw, -hw, 0.0)
    knuckle_hi = (hw, KNUCKLE_REACH + hw, KNUCKLE_HEIGHT)
    write_stl(d / "meshes" / "bh_knuckle.stl", box(knuckle_lo, knuckle_hi))
    write_stl(d / "meshes" / "bh_finger_prox.stl",
              box((-hw, -PROX_THICKNESS / 2, 0.0), (hw, PROX_THICKNESS / 2, PROX_LENGTH)))
    write_stl(d / "meshes" / "bh_finger_dist_mm.stl",
              box((-hw, -DIST_THICKNESS / 2, 0.0), (hw, DIST_THICKNESS / 2, DIST_LENGTH)), scale=1000.0)

    pi = math.pi
    links = []
    joints = []
    links.append('  <link name="bh_palm">\n'
                 + mesh_visual_collision("package://barrett/meshes/bh_palm.dae") + "  </link>\n")
    # Finger 1 (x = +0.025) and 2 (x = -0.025) spread in opposite directions about z; finger 3 is
    # fixed at y = -0.050, its knuckle frame turned by pi so that every finger has the same local
    # convention: the proximal joint at +y of the knuckle frame, flexion about +x curling the
    # finger towards -y of the knuckle frame (the palm centre).
    for f, base_x in ((1, BASE_OFFSET), (2, -BASE_OFFSET)):
        links.append(f'  <link name="bh_f{f}_knuckle">\n'
                     + mesh_visual_collision("meshes/bh_knuckle.stl", visual_only=True) + "  </link>\n")
        lower, upper = (-pi, 0.0) if f == 1 else (0.0, pi)
        joints.append(
            f'  <joint name="bh_j{f}1" type="revolute">\n'
            f'    <parent link="bh_palm"/>\n    <child link="bh_f{f}_knuckle"/>\n'
            f'    <origin xyz="{fmt(base_x, 0, PALM_TOP)}" rpy="0 0 0"/>\n'
            f'    <axis xyz="0 0 1"/>\n'
            f'    <limit lower="{fmt(lower)}" upper="{fmt(upper)}" effort="5" velocity="1"/>\n'
            f'  </joint>\n')
    box_size = np.subtract(knuckle_hi, knuckle_lo)
    box_centre = np.add(knuckle_hi, knuckle_lo) / 2
    links.append(
        '  <link name="bh_f3_knuckle">\n'
        f'    <visual><origin xyz="{fmt(*box_centre)}" rpy="0 0 0"/>'
        f'<geometry><box size="{fmt(*box_size)}"/></geometry></visual>\n'
        f'    <collision><origin xyz="{fmt(*box_centre)}" rpy="0 0 0"/>'
        f'<geometry><box size="{fmt(*box_size)}"/></geometry></collision>\n'
        '  </link>\n')
    joints.append(
        '  <joint name="bh_j31" type="fixed">\n'
        '    <parent link="bh_palm"/>\n    <child link="bh_f3_knuckle"/>\n'
        f'    <origin xyz="{fmt(0, 0, PALM_TOP)}" rpy="{fmt(0, 0, pi)}"/>\n'
        '  </joint>\n')
    for f in (1, 2, 3):
        links.append(f'  <link name="bh_f{f}_prox">\n'
                     + mesh_visual_collision("meshes/bh_finger_prox.stl") + "  </link>\n")
        links.append(f'  <link name="bh_f{f}_dist">\n'
                     + mesh_visual_collision("meshes/bh_finger_dist_mm.stl", scale="0.001 0.001 0.001")
                     + "  </link>\n")
        joints.append(
            f'  <joint name="bh_j{f}2" type="revolute">\n'
            f'    <parent link="bh_f{f}_knuckle"/>\n    <child link="bh_f{f}_prox"/>\n'
            f'    <origin xyz="{fmt(0, KNUCKLE_REACH, KNUCKLE_HEIGHT)}" rpy="0 0 0"/>\n'
            f'    <axis xyz="1 0 0"/>\n'
            f'    <limit lower="0" upper="{fmt(FLEX_MAX)}" effort="5" velocity="1"/>\n'
            f'  </joint>\n')
        joints.append(
            f'  <joint name="bh_j{f}3" type="revolute">\n'
            f'    <parent link="bh_f{f}_prox"/>\n    <child link="bh_f{f}_dist"/>\n'
            f'    <origin xyz="{fmt(0, 0, PROX_LENGTH)}" rpy="{fmt(DIST_REST, 0, 0)}"/>\n'
            f'    <axis xyz="1 0 0"/>\n'
            f'    <limit lower="0" upper="{fmt(DIST_MAX)}" effort="5" velocity="1"/>\n'
            f'    <mimic joint="bh_j{f}2" multiplier="{MIMIC_DIST!r}" offset="0"/>\n'
            f'  </joint>\n')
    urdf = ('<?xml version="1.0"?>\n'
            '<!-- Barrett BH8-28x hand, generated by scripts/make_hands.py. Metres, radians. -->\n'
            '<robot name="barrett_bh8_28x">\n' + "".join(links) + "".join(joints) + "</robot>\n")
    (d / "bh8_28x.urdf").write_text(urdf)

    inner = {"axis": [0.0, -1.0, 0.0], "half_angle_deg": 30.0}
    spec = {
        "name": "barrett_bh8_28x",
        "urdf": "bh8_28x.urdf",
        "package_paths": [".."],
        "wrist_link": "bh_palm",
        "approach": [0.0, 0.0, 1.0],
        "dofs": [
            {"name": "spread", "joints": [{"joint": "bh_j11", "ratio": -1.0, "offset": 0.0},
                                          {"joint": "bh_j21", "ratio": 1.0, "offset": 0.0}],
             "step": 0.25},
        ] + [{"name": f"f{f}_flex", "joints": [{"joint": f"bh_j{f}2"}], "lower": 0.0, "upper": FLEX_MAX,
              "step": 0.25} for f in (1, 2, 3)],
        "active_surfaces": [{"link": "bh_palm",
                             "normal_cone": {"axis": [0.0, 0.0, 1.0], "half_angle_deg": 10.0}}]
        + [{"link": f"bh_f{f}_{part}", "normal_cone": inner} for f in (1, 2, 3) for part in ("prox", "dist")],
    }
    write_spec(d / "barrett.json", spec)


def parallel_jaw() -> None:
    d = MODELS / "parallel_jaw"
    (d / "meshes").mkdir(parents=True, exist_ok=True)
    write_stl(d / "meshes" / "pj_base.stl", box(*PJ_BASE))
    finger = trimesh.boolean.union([box(*PJ_PAD), box(*PJ_CARRIAGE)], engine="manifold")
    finger = trimesh.Trimesh(np.round(finger.vertices, 6), finger.faces)   # exact millimetre grid
    write_stl(d / "meshes" / "pj_finger.stl", finger)

    top = PJ_BASE[1][2]
    pi = math.pi
    urdf = f"""<?xml version="1.0"?>
<!-- Two-finger parallel-jaw gripper, generated by scripts/make_hands.py. Metres. -->
<robot name="parallel_jaw">
  <link name="pj_base">
{mesh_visual_collision("meshes/pj_base.stl")}  </link>
  <link name="pj_left_finger">
{mesh_visual_collision("meshes/pj_finger.stl")}  </link>
  <link name="pj_right_finger">
{mesh_visual_collision("meshes/pj_finger.stl")}  </link>
  <joint name="pj_left_joint" type="prismatic">
    <parent link="pj_base"/>
    <child link="pj_left_finger"/>
    <origin xyz="{fmt(0, 0, top)}" rpy="0 0 0"/>
    <axis xyz="-1 0 0"/>
    <limit lower="0" upper="{fmt(PJ_STROKE)}" effort="50" velocity="0.1"/>
  </joint>
  <joint name="pj_right_joint" type="prismatic">
    <parent link="pj_base"/>
    <child link="pj_right_finger"/>
    <origin xyz="{fmt(0, 0, top)}" rpy="{fmt(0, 0, pi)}"/>
    <axis xyz="-1 0 0"/>
    <limit lower="0" upper="{fmt(PJ_STROKE)}" effort="50" velocity="0.1"/>
    <mimic joint="pj_left_joint" multiplier="1" offset="0"/>
  </joint>
</robot>
"""
    (d / "parallel_jaw.urdf").write_text(urdf.replace("\n\n", "\n"))
    pad = {"normal_cone": {"axis": [1.0, 0.0, 0.0], "half_angle_deg": 20.0},
           "box": {"min": [-0.001, -1.0, -1.0], "max": [0.001, 1.0, 1.0]}}
    spec = {
        "name": "parallel_jaw",
        "urdf": "parallel_jaw.urdf",
        "wrist_link": "pj_base",
        "approach": [0.0, 0.0, 1.0],
        "dofs": [{"name": "opening", "joints": [{"joint": "pj_left_joint", "ratio": 0.5}], "step": 0.01}],
        "active_surfaces": [dict(link="pj_left_finger", **pad), dict(link="pj_right_finger", **pad)],
    }
    write_spec(d / "parallel_jaw.json", spec)


if __name__ == "__main__":
    barrett()
    parallel_jaw()
    print(f"wrote {MODELS / 'barrett'} and {MODELS / 'parallel_jaw'}")
