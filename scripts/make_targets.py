#!/usr/bin/env python3
"""Generate the bundled grasp targets and their paint files (models/targets/).

Three objects of increasing polygon count, about the size of the Barrett hand (palm ~9 cm wide,
fingers ~12 cm long), like the targets of the paper's Figure 6:

  box.stl    a 0.06 x 0.06 x 0.12 m box (12 faces)
  mug.stl    a hollow mug with a rounded rim and a ring handle (a few thousand faces)
  flask.stl  a solid Erlenmeyer flask with a neck, a bead lip and a mouth (the most faces)

and an occluder for the paper's other scene, an object held by another hand:

  holder.stl a hand-like holder (a palm, two fingers wrapping one corner and a thumb) around the
             top of box.stl, in box.stl's frame: `--occluder` and `--obstacle` at once

All are in metres, stand on z = 0 with their symmetry axis along z, and are watertight: closed,
consistently wound with outward normals, free of self-intersections (the mug's parts are joined
with manifold3d's exact booleans). Each gets a paint file `<name>.paint.json` (format described in
models/README.md) marking which faces a gripper may touch.

The output is deterministic: running the script again rewrites byte-identical files (the mug's
boolean triangulation may differ between manifold3d releases; the files were made with 3.5).

Usage: python3 scripts/make_targets.py [--out models/targets] [--check]
  --check  regenerate in memory and fail if the committed files differ.
"""
from __future__ import annotations

import argparse
import json
import math
import re
import struct
import sys
from pathlib import Path

import numpy as np

try:
    import manifold3d as m3
except ImportError as e:  # pragma: no cover - reported to the user
    sys.exit(f"make_targets.py needs manifold3d (pip install manifold3d): {e}")

# ----------------------------------------------------------------------------- dimensions (metres)
# These numbers are documented in models/README.md ("## Targets"); the tests rebuild the volumes
# from them independently of the meshes.
BOX = dict(size=(0.06, 0.06, 0.12))

MUG = dict(
    radius=0.040,          # outer body radius
    height=0.100,          # body height (the rim bead rises above it)
    wall=0.0045,           # side wall thickness -> cavity radius 0.0355
    bottom=0.006,          # bottom thickness -> cavity floor at z = 0.006
    rim_minor=0.003,       # rim: torus of this tube radius centred on the wall's mid radius at z = height
    handle_center=(0.050, 0.0, 0.050),  # handle: torus in the xz plane centred here
    handle_major=0.028,    # its ring radius
    handle_minor=0.006,    # its tube radius
    segments=64,           # around the body and the rim
    rim_tube_segments=16,
    handle_segments=48,    # around the handle ring
    handle_tube_segments=20,
)

FLASK = dict(
    base_radius=0.040,     # radius of the flat bottom edge (before rounding)
    base_fillet=0.006,     # convex fillet between the bottom and the cone
    shoulder_z=0.100,      # height where the cone line meets the neck line
    neck_radius=0.014,
    shoulder_fillet=0.040, # concave fillet between the cone and the neck
    height=0.150,          # top of the lip
    bead=0.003,            # lip: outward half-round of this radius centred at (neck_radius, height - bead)
    mouth_radius=0.010,    # mouth: a cylindrical opening of this radius ...
    mouth_depth=0.025,     # ... and depth, down from the top
    segments=80,           # around the axis
)

# The holder: boxes (x0, x1, y0, y1, z0, z1) around the top of BOX, which spans x, y in [-0.03, 0.03]
# and z in [0, 0.12]; each touches the box's surface (the palm, the fingers, the thumb).
HOLDER = dict(
    palm=(0.030, 0.048, -0.040, 0.040, 0.072, 0.124),
    fingers=[  # each along the +y face, then around the corner along the -x face
        ((-0.043, 0.044, 0.030, 0.045, zc - 0.008, zc + 0.008),
         (-0.045, -0.030, -0.012, 0.041, zc - 0.007, zc + 0.007)) for zc in (0.084, 0.106)],
    thumb=(-0.004, 0.044, -0.045, -0.030, 0.092, 0.108),
)

# Paint: what a gripper may not touch.
BOX_PAINT_NOTE = "the bottom face rests on the table"
MUG_PAINT_NOTE = "the bottom rests on the table"
FLASK_PAINT_NOTE = "the top of the neck (lip and mouth) is unreachable, as in the paper's experiment"
FLASK_OCCLUDED_ABOVE = 0.140  # every face whose centroid is at or above this height


# ----------------------------------------------------------------------------- helpers
def _fillet(corner, d_in, d_out, radius, samples):
    """Points of a circular arc rounding the corner of a polyline.

    d_in: unit direction arriving at the corner; d_out: unit direction leaving it. Returns the arc
    from the tangent point on the incoming line to the one on the outgoing line (inclusive).
    """
    corner = np.asarray(corner, float)
    a = -np.asarray(d_in, float)  # from corner back along the incoming line
    b = np.asarray(d_out, float)
    theta = math.acos(float(np.clip(a @ b, -1.0, 1.0)))  # interior angle at the corner
    t = radius / math.tan(theta / 2.0)
    p0, p1 = corner + t * a, corner + t * b
    bis = (a + b) / np.linalg.norm(a + b)
    c = corner + bis * (radius / math.sin(theta / 2.0))
    a0 = math.atan2(*(p0 - c)[::-1])
    a1 = math.atan2(*(p1 - c)[::-1])
    sweep = (a1 - a0 + math.pi) % (2 * math.pi) - math.pi  # the short way round
    ang = a0 + sweep * np.linspace(0.0, 1.0, samples + 1)
    return c + radius * np.stack([np.cos(ang), np.sin(ang)], axis=1)


def _line(p0, p1, pieces):
    """p0..p1 split into `pieces` equal segments, both ends included."""
    s = np.linspace(0.0, 1.0, pieces + 1)[:, None]
    return (1 - s) * np.asarray(p0, float) + s * np.asarray(p1, float)


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def revolve_profile(profile, segments):
    """Triangle mesh of a closed (r, z) profile revolved about z.

    The profile runs from a point on the axis (r = 0) through r > 0 back to another point on the
    axis, counter-clockwise in the (r, z) half-plane seen from +y, i.e. the solid lies on the left
    when walking it. Axis points become single vertices (triangle fans); every other profile point
    becomes a ring of `segments` vertices, the first at angle 0. Faces are wound outward.
    """
    prof = np.asarray(profile, float)
    assert prof[0, 0] == 0.0 and prof[-1, 0] == 0.0 and (prof[1:-1, 0] > 0).all()
    ang = 2 * math.pi * np.arange(segments) / segments
    cos, sin = np.cos(ang), np.sin(ang)
    verts = [[0.0, 0.0, prof[0, 1]]]
    rings = []
    for r, z in prof[1:-1]:
        rings.append(len(verts) + np.arange(segments))
        verts.extend(np.stack([r * cos, r * sin, np.full(segments, z)], axis=1).tolist())
    top = len(verts)
    verts.append([0.0, 0.0, prof[-1, 1]])
    nxt = (np.arange(segments) + 1) % segments
    faces = []
    # Bottom fan: the profile leaves the axis going outward at the start (normal points -z side).
    r0 = rings[0]
    faces += [[0, r0[nxt[k]], r0[k]] for k in range(segments)]
    for ra, rb in zip(rings[:-1], rings[1:]):
        for k in range(segments):
            a0, a1, b0, b1 = ra[k], ra[nxt[k]], rb[k], rb[nxt[k]]
            faces.append([a0, a1, b1])
            faces.append([a0, b1, b0])
    rl = rings[-1]
    faces += [[top, rl[k], rl[nxt[k]]] for k in range(segments)]
    return np.asarray(verts, float), np.asarray(faces, np.int64)


def _manifold_mesh(man):
    m = man.to_mesh()
    return np.asarray(m.vert_properties, float)[:, :3], np.asarray(m.tri_verts, np.int64)


def _torus(major, minor, segments, tube_segments, phase=0.0):
    """Torus about z centred at the origin, as a manifold3d solid."""
    circle = m3.CrossSection.circle(minor, tube_segments).translate((major, 0.0))
    return m3.Manifold.revolve(circle, segments).rotate((0.0, 0.0, phase))


# ----------------------------------------------------------------------------- the targets
def make_box():
    sx, sy, sz = BOX["size"]
    man = m3.Manifold.cube((sx, sy, sz)).translate((-sx / 2, -sy / 2, 0.0))
    return _manifold_mesh(man)


def make_mug():
    p = MUG
    seg = p["segments"]
    outer = m3.Manifold.cylinder(p["height"], p["radius"], p["radius"], seg)
    r_in = p["radius"] - p["wall"]
    # The cavity runs past the top so that the body is open.
    cavity = m3.Manifold.cylinder(p["height"], r_in, r_in, seg).translate((0, 0, p["bottom"]))
    handle = (
        _torus(p["handle_major"], p["handle_minor"], p["handle_segments"], p["handle_tube_segments"])
        .rotate((90.0, 0.0, 0.0))
        .translate(p["handle_center"])
    )
    # Half a step out of phase with the body so that no rim vertex lies on a body edge.
    rim = _torus(
        p["radius"] - p["wall"] / 2, p["rim_minor"], seg, p["rim_tube_segments"], phase=180.0 / seg
    ).translate((0, 0, p["height"]))
    mug = ((outer + handle) - cavity) + rim
    assert mug.status() == m3.Error.NoError, mug.status()
    return _manifold_mesh(mug)


def flask_profile(arc_samples=8):
    """The flask's closed (r, z) profile, counter-clockwise, from the bottom centre round to the
    mouth floor centre."""
    p = FLASK
    rb, rn, zs, h, b = p["base_radius"], p["neck_radius"], p["shoulder_z"], p["height"], p["bead"]
    rm, zm = p["mouth_radius"], h - p["mouth_depth"]
    base, shoulder = np.array([rb, 0.0]), np.array([rn, zs])
    d_bottom = np.array([1.0, 0.0])
    d_cone = _unit(shoulder - base)
    d_neck = np.array([0.0, 1.0])
    arc_base = _fillet(base, d_bottom, d_cone, p["base_fillet"], arc_samples)
    arc_shoulder = _fillet(shoulder, d_cone, d_neck, p["shoulder_fillet"], arc_samples)
    bead_c = np.array([rn, h - b])
    ang = np.linspace(-math.pi / 2, math.pi / 2, arc_samples + 1)
    arc_bead = bead_c + b * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    pts = [
        _line([0.0, 0.0], arc_base[0], 6)[:-1],   # bottom disc, in rings
        arc_base[:-1],
        _line(arc_base[-1], arc_shoulder[0], 12)[:-1],  # the cone
        arc_shoulder[:-1],
        _line(arc_shoulder[-1], arc_bead[0], 8)[:-1],   # the neck
        arc_bead[:-1],
        _line(arc_bead[-1], [rm, h], 2)[:-1],            # the top annulus
        _line([rm, h], [rm, zm], 4)[:-1],                # the mouth wall, going down
        _line([rm, zm], [0.0, zm], 3),                   # the mouth floor, to the axis
    ]
    return np.concatenate(pts, axis=0)


def make_flask():
    v, f = revolve_profile(flask_profile(), FLASK["segments"])
    # Cross-check with manifold3d: it accepts only a valid closed 2-manifold.
    man = m3.Manifold(m3.Mesh(vert_properties=v.astype(np.float32), tri_verts=f.astype(np.uint32)))
    assert man.status() == m3.Error.NoError, man.status()
    return v, f


# ----------------------------------------------------------------------------- validation
def make_holder():
    def block(x0, x1, y0, y1, z0, z1):
        return m3.Manifold.cube((x1 - x0, y1 - y0, z1 - z0)).translate((x0, y0, z0))

    parts = [block(*HOLDER["palm"]), block(*HOLDER["thumb"])]
    for along_y, along_x in HOLDER["fingers"]:
        parts += [block(*along_y), block(*along_x)]
    man = parts[0]
    for p in parts[1:]:
        man = man + p
    return _manifold_mesh(man)


def check_mesh(name, v, f):
    """Refuse to write a mesh that is not watertight, outward, clean after float32 rounding."""
    v32 = v.astype(np.float32).astype(np.float64)
    # Welding exact float32 duplicates (what an STL reader does) must not merge distinct vertices.
    uniq = np.unique(v32, axis=0)
    assert len(uniq) == len(v), f"{name}: vertices coincide after float32 rounding"
    tri = v32[f]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    assert area.min() > 1e-10, f"{name}: face with area {area.min():.3g} m^2"
    # Closed and consistently wound: every directed edge appears once and its reverse once.
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    keys = {tuple(x) for x in e.tolist()}
    assert len(keys) == len(e), f"{name}: a directed edge is used twice"
    assert all((b, a) in keys for a, b in keys), f"{name}: open edge"
    sorted_faces = np.sort(f, axis=1)
    assert len(np.unique(sorted_faces, axis=0)) == len(f), f"{name}: duplicate face"
    vol = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0
    assert vol > 0, f"{name}: inward winding (volume {vol})"
    try:
        import trimesh

        tm = trimesh.Trimesh(v32, f, process=False)
        assert tm.is_watertight and tm.is_winding_consistent and tm.is_volume, name
    except ImportError:  # pragma: no cover
        pass
    return vol


def stl_bytes(v, f, name):
    """Binary STL (little endian, float32), facet normals from the rounded vertices."""
    v32 = v.astype(np.float32)
    tri = v32[f].astype(np.float64)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    rec = np.zeros(len(f), dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")]))
    rec["n"] = n.astype(np.float32)
    rec["v"] = v32[f]
    header = f"pairgrasp target {name}, metres".encode("ascii").ljust(80, b" ")
    return header + struct.pack("<I", len(f)) + rec.tobytes()


def paint_json(mesh_file, n_faces, note, occluded=None, regions=None):
    doc = {"format": "pairgrasp-paint", "version": 1, "mesh": mesh_file, "faces": int(n_faces),
           "default": "free", "comment": note}
    if occluded is not None:
        doc["occluded"] = [int(i) for i in occluded]
    if regions:
        doc["regions"] = regions
    text = json.dumps(doc, indent=2)
    # Keep number lists (points, index lists) on one line each.
    text = re.sub(r"\[\s+([-0-9.e,\s]+?)\s+\]", lambda m: "[" + re.sub(r",\s+", ", ", m.group(1)) + "]", text)
    return (text + "\n").encode("ascii")


def _centroids(v, f):
    return v.astype(np.float32).astype(np.float64)[f].mean(axis=1)


def build():
    """All output files as {relative name: bytes}, plus a summary per target."""
    out, summary = {}, {}
    box, mug, flask, holder = make_box(), make_mug(), make_flask(), make_holder()
    for name, (v, f) in (("box", box), ("mug", mug), ("flask", flask), ("holder", holder)):
        vol = check_mesh(name, v, f)
        out[f"{name}.stl"] = stl_bytes(v, f, name)
        ext = np.ptp(v, axis=0)
        summary[name] = (len(f), ext, vol)

    # box: its two bottom triangles, as an explicit list
    v, f = box
    bottom = np.flatnonzero((v[f][:, :, 2] == 0.0).all(axis=1))
    assert len(bottom) == 2
    out["box.paint.json"] = paint_json("box.stl", len(f), BOX_PAINT_NOTE, occluded=bottom)

    # The mug's and the flask's marks are whole faces, listed, as painting them in a mesh editor
    # would: the faces whose centroid (from the STL's float32 vertices) lies in the region. A paint
    # region would mark points and split the faces it crosses (docs/cli.md).
    # mug: every face of the base plane (centroids below 1 mm)
    v, f = mug
    c = _centroids(v, f)
    out["mug.paint.json"] = paint_json("mug.stl", len(f), MUG_PAINT_NOTE, occluded=np.flatnonzero(c[:, 2] <= 0.001))

    # flask: the lip (centroids at or above FLASK_OCCLUDED_ABOVE) and the mouth opening (centroids
    # within a cylinder 0.5 mm wider than the mouth, from 1 mm below its floor to the top)
    v, f = flask
    c = _centroids(v, f)
    rm, zm = FLASK["mouth_radius"], FLASK["height"] - FLASK["mouth_depth"]
    r0, z0, z1 = round(rm + 0.0005, 6), round(zm - 0.001, 6), FLASK["height"]
    mouth = (np.hypot(c[:, 0], c[:, 1]) <= r0) & (c[:, 2] >= z0) & (c[:, 2] <= z1)
    occluded = np.flatnonzero((c[:, 2] >= FLASK_OCCLUDED_ABOVE) | mouth)
    out["flask.paint.json"] = paint_json("flask.stl", len(f), FLASK_PAINT_NOTE, occluded=occluded)
    return out, summary


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent.parent / "models" / "targets")
    ap.add_argument("--check", action="store_true", help="fail if the files on disk differ")
    args = ap.parse_args(argv)
    files, summary = build()
    for name, (nf, ext, vol) in summary.items():
        print(f"{name:6s} {nf:6d} faces  extent {ext[0]:.4f} x {ext[1]:.4f} x {ext[2]:.4f} m  "
              f"volume {vol * 1e6:.2f} cm^3")
    stale = []
    for rel, data in files.items():
        path = args.out / rel
        if args.check:
            if not path.exists() or path.read_bytes() != data:
                stale.append(rel)
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
    if stale:
        sys.exit(f"out of date: {', '.join(stale)} (run scripts/make_targets.py)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
