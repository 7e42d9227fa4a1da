"""pairgrasp.load_mesh / make_mesh / Mesh, checked against hand-computed facts.

Mesh files are written by the tests into a temporary directory.
"""
import gc
import itertools
import math
import os
import pathlib
import struct

import numpy as np
import pytest

import pairgrasp as pg


# ----------------------------------------------------------------------------- test geometry

def box(size, lo=(0.0, 0.0, 0.0)):
    """Axis-aligned box [lo, lo+size]: 8 corners (index = x + 2y + 4z bits), 12 outward triangles."""
    size, lo = np.asarray(size, float), np.asarray(lo, float)
    v = np.array([[(i >> a) & 1 for a in range(3)] for i in range(8)], float) * size + lo
    faces = []
    for axis in range(3):
        u, w = (axis + 1) % 3, (axis + 2) % 3
        for side in (0, 1):
            q = [(side << axis) | (bu << u) | (bw << w) for bu, bw in ((0, 0), (1, 0), (1, 1), (0, 1))]
            n = np.cross(v[q[1]] - v[q[0]], v[q[2]] - v[q[0]])
            if (n[axis] > 0) != (side == 1):
                q[1], q[3] = q[3], q[1]
            faces += [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    return v, np.array(faces, np.int64)


def icosphere(levels, radius=1.0, centre=(0.0, 0.0, 0.0)):
    t = (1 + 5 ** 0.5) / 2
    v = [np.array(p, float) / np.linalg.norm(p) for p in
         [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
          (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
         (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5),
         (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(levels):
        cache, g = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                p = v[a] + v[b]
                v.append(p / np.linalg.norm(p))
                cache[key] = len(v) - 1
            return cache[key]

        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            g += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = g
    return np.array(v) * radius + np.asarray(centre, float), np.array(f, np.int64)


def write_binary_stl(path, v, f, header=b"pairgrasp test"):
    rec = np.zeros(len(f), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    rec["n"] = n / np.linalg.norm(n, axis=1, keepdims=True)
    rec["v"] = tri
    with open(path, "wb") as out:
        out.write(header.ljust(80, b"\0"))
        out.write(np.uint32(len(f)).tobytes())
        out.write(rec.tobytes())


def write_ascii_stl(path, v, f):
    lines = ["solid test"]
    for tri in v[f]:
        lines += ["facet normal 0 0 0", "outer loop"] + ["vertex %.17g %.17g %.17g" % tuple(p) for p in tri]
        lines += ["endloop", "endfacet"]
    pathlib.Path(path).write_text("\n".join(lines + ["endsolid test", ""]))


def write_obj(path, v, f):
    text = "".join("v %.17g %.17g %.17g\n" % tuple(p) for p in v) + "".join("f %d %d %d\n" % tuple(t + 1) for t in f)
    pathlib.Path(path).write_text(text)


def write_ply(path, v, f):
    head = ("ply\nformat ascii 1.0\nelement vertex %d\nproperty double x\nproperty double y\nproperty double z\n"
            "element face %d\nproperty list uchar int vertex_indices\nend_header\n" % (len(v), len(f)))
    body = "".join("%.17g %.17g %.17g\n" % tuple(p) for p in v) + "".join("3 %d %d %d\n" % tuple(t) for t in f)
    pathlib.Path(path).write_text(head + body)


def write_dae(path, v, f, up_axis="Z_UP", unit='meter="1"', nodes=(np.eye(4),)):
    unit_tag = "<unit %s/>" % unit if unit else ""
    node_xml = "".join(
        '<node id="n%d"><matrix>%s</matrix><instance_geometry url="#g"/></node>'
        % (i, " ".join(repr(float(x)) for x in np.asarray(m).ravel())) for i, m in enumerate(nodes))
    pathlib.Path(path).write_text(f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset>{unit_tag}<up_axis>{up_axis}</up_axis></asset>
  <library_geometries><geometry id="g"><mesh>
    <source id="p"><float_array id="pa" count="{v.size}">{" ".join(repr(float(x)) for x in v.ravel())}</float_array>
      <technique_common><accessor source="#pa" count="{len(v)}" stride="3">
        <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
      </accessor></technique_common></source>
    <vertices id="vx"><input semantic="POSITION" source="#p"/></vertices>
    <triangles count="{len(f)}"><input semantic="VERTEX" source="#vx" offset="0"/>
      <p>{" ".join(str(int(i)) for i in f.ravel())}</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s">{node_xml}</visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
""")


def sorted_rows(a):
    a = np.asarray(a)
    return a[np.lexsort(a.T[::-1])]


def check_box(m, size, lo, rel=1e-6):
    size, lo = np.asarray(size, float), np.asarray(lo, float)
    scale = size.max()
    assert m.vertices.shape == (8, 3) and m.faces.shape == (12, 3)
    assert m.closed
    assert m.volume == pytest.approx(np.prod(size), rel=rel)
    assert m.area == pytest.approx(2 * (size[0] * size[1] + size[1] * size[2] + size[2] * size[0]), rel=rel)
    np.testing.assert_allclose(m.center_of_mass, lo + size / 2, atol=rel * scale)
    np.testing.assert_allclose(m.bounds, [lo, lo + size], atol=rel * scale)
    # outward: every face normal points away from the centre
    centre = lo + size / 2
    d = np.einsum("ij,ij->i", m.face_normals(), m.vertices[m.faces[:, 0]] - centre)
    assert (d > 0).all()


# ----------------------------------------------------------------------------- formats

@pytest.mark.parametrize("writer", [write_binary_stl, write_ascii_stl])
def test_stl_cube_welds_to_eight_vertices(tmp_path, writer):
    side, lo = 0.1, (0.3, -0.2, 0.05)
    v, f = box([side] * 3, lo)
    writer(tmp_path / "cube.stl", v, f)
    m = pg.load_mesh(str(tmp_path / "cube.stl"))
    check_box(m, [side] * 3, lo)
    assert m.volume == pytest.approx(side ** 3, rel=1e-6)
    assert m.area == pytest.approx(6 * side ** 2, rel=1e-6)
    assert m.cleanup.welded_vertices == 36 - 8
    assert m.cleanup.as_dict() == dict(welded_vertices=28, unused_vertices=0, degenerate_faces=0,
                                       duplicate_faces=0, flipped_faces=0)
    assert m.source == str(tmp_path / "cube.stl")


def test_load_mesh_accepts_pathlike(tmp_path):
    v, f = box([0.01, 0.02, 0.03])
    write_binary_stl(tmp_path / "b.stl", v, f)
    check_box(pg.load_mesh(tmp_path / "b.stl"), [0.01, 0.02, 0.03], [0, 0, 0])
    check_box(pg.load_mesh(os.fsencode(tmp_path / "b.stl")), [0.01, 0.02, 0.03], [0, 0, 0])
    with pytest.raises(TypeError):
        pg.load_mesh(3.5)


def test_collada_z_up_matches_stl(tmp_path):
    size, lo = (0.1, 0.2, 0.3), (0.05, -0.4, 0.7)  # asymmetric, off the origin: a turn would show
    v, f = box(size, lo)
    write_binary_stl(tmp_path / "b.stl", v, f)
    write_dae(tmp_path / "b.dae", v, f, "Z_UP", 'name="meter" meter="1"')
    a, b = pg.load_mesh(tmp_path / "b.stl"), pg.load_mesh(tmp_path / "b.dae")
    np.testing.assert_allclose(sorted_rows(a.vertices), sorted_rows(b.vertices), atol=1e-6)
    check_box(b, size, lo)


def test_collada_centimetres_scaled_not_rotated(tmp_path):
    v, f = box((10, 20, 30))  # centimetres in the file
    node = np.eye(4)
    node[:3, 3] = (1, 2, 3)
    write_dae(tmp_path / "cm.dae", v, f, "Z_UP", 'name="centimeter" meter="0.01"', [node])
    m = pg.load_mesh(tmp_path / "cm.dae")
    check_box(m, (0.1, 0.2, 0.3), (0.01, 0.02, 0.03))
    # what assimp alone would give (Y-up turn: (x, y, z) -> (x, z, -y)) is not what we get
    assert not np.allclose(m.bounds, [[0.01, 0.03, -0.22], [0.11, 0.33, -0.02]])


def test_obj_and_ply_load(tmp_path):
    size, lo = (0.04, 0.05, 0.06), (0.01, 0.02, -0.03)
    v, f = box(size, lo)
    write_obj(tmp_path / "b.obj", v, f)
    write_ply(tmp_path / "b.ply", v, f)
    check_box(pg.load_mesh(tmp_path / "b.obj"), size, lo)
    check_box(pg.load_mesh(tmp_path / "b.ply"), size, lo)


def test_scale_loads_millimetres_as_metres(tmp_path):
    v, f = box((100, 200, 300), (10, -20, 30))
    write_binary_stl(tmp_path / "mm.stl", v, f)
    m = pg.load_mesh(tmp_path / "mm.stl", scale=0.001)
    check_box(m, (0.1, 0.2, 0.3), (0.01, -0.02, 0.03))
    assert m.volume == pytest.approx(0.006, rel=1e-6)
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="scale"):
            pg.load_mesh(tmp_path / "mm.stl", scale=bad)


def write_ply_binary(path, v, polys, endian=">"):
    """Binary PLY (big-endian by default) with polygons and an extra per-vertex property."""
    fmt = "binary_big_endian" if endian == ">" else "binary_little_endian"
    head = ("ply\nformat %s 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
            "property uchar quality\nelement face %d\nproperty list uchar uint vertex_indices\nend_header\n"
            % (fmt, len(v), len(polys)))
    body = b"".join(struct.pack(endian + "fffB", *p, 9) for p in v)
    body += b"".join(struct.pack(endian + "B%dI" % len(q), len(q), *q) for q in polys)
    pathlib.Path(path).write_bytes(head.encode() + body)


def test_binary_ply_with_quads(tmp_path):
    size, lo = np.array([0.03, 0.02, 0.01]), np.array([0.1, 0.1, 0.1])
    v, f = box(size, lo)
    quads = [[f[i][0], f[i][1], f[i][2], f[i + 1][2]] for i in range(0, 12, 2)]  # (q0 q1 q2) (q0 q2 q3)
    for endian in "<>":
        write_ply_binary(tmp_path / "q.ply", v, quads, endian)
        check_box(pg.load_mesh(tmp_path / "q.ply"), size, lo)


def test_malformed_ply_and_collada_raise_file_error(tmp_path):
    v, f = box((1, 1, 1))
    write_ply(tmp_path / "ok.ply", v, f)
    text = (tmp_path / "ok.ply").read_text()
    (tmp_path / "cut_header.ply").write_text(text[:text.index("end_header")])
    _expect_file_error(tmp_path / "cut_header.ply", "end_header")
    (tmp_path / "cut_body.ply").write_text(text[:len(text) - 40])
    _expect_file_error(tmp_path / "cut_body.ply", "ends early")
    write_dae(tmp_path / "ok.dae", v, f)
    dae = (tmp_path / "ok.dae").read_text()
    (tmp_path / "letter.dae").write_text(dae.replace("<p>0 ", "<p>0 x ", 1))
    _expect_file_error(tmp_path / "letter.dae", "index list")
    (tmp_path / "nocount.dae").write_text(dae.replace(' count="24"', "", 1))
    _expect_file_error(tmp_path / "nocount.dae", "count")


# ----------------------------------------------------------------------------- orientation

@pytest.mark.parametrize("flipped", [[1, 4, 7], [0, 2, 3, 5, 6, 8, 11], list(range(12))])
def test_flipped_faces_are_turned_outward(flipped):
    size = (0.3, 0.2, 0.1)
    v, f = box(size)
    g = f.copy()
    g[flipped] = g[flipped][:, ::-1]
    m = pg.make_mesh(v, g, name="flipped")
    assert m.cleanup.flipped_faces == len(flipped)
    assert m.closed
    assert m.volume == pytest.approx(np.prod(size), rel=1e-12)
    # each face is the outward source face, as a cyclic rotation
    for got, want in zip(m.faces, f):
        assert any(list(np.roll(want, k)) == list(got) for k in range(3))


def test_open_box_is_not_closed_and_has_surface_centroid():
    size = np.array([0.2, 0.1, 0.4])
    v, f = box(size)
    keep = ~np.all(v[f][:, :, 2] == size[2], axis=1)  # drop the two +z triangles
    m = pg.make_mesh(v, f[keep])
    assert not m.closed
    assert m.volume == 0.0
    assert m.boundary_edges == 4
    a, b, c = size
    area = a * b + 2 * a * c + 2 * b * c
    assert m.area == pytest.approx(area, rel=1e-12)
    centroid = (a * b * np.array([a / 2, b / 2, 0]) + a * c * np.array([a / 2, 0, c / 2])
                + a * c * np.array([a / 2, b, c / 2]) + b * c * np.array([0, b / 2, c / 2])
                + b * c * np.array([a, b / 2, c / 2])) / area
    np.testing.assert_allclose(m.center_of_mass, centroid, atol=1e-12)


def test_icosphere_volume_within_discretisation_error():
    r, centre = 0.05, np.array([0.1, 0.2, -0.3])
    v, f = icosphere(3, r, centre)
    rng = np.random.default_rng(5)
    flip = rng.random(len(f)) < 0.5
    g = f.copy()
    g[flip] = g[flip][:, ::-1]
    m = pg.make_mesh(v, g, name="icosphere")
    assert m.closed and len(m.faces) == 1280
    assert m.cleanup.flipped_faces == flip.sum()
    # independent: pyramids from the centre (area * height / 3), and the ball bounds
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    areas = 0.5 * np.linalg.norm(n, axis=1)
    heights = np.einsum("ij,ij->i", n / (2 * areas[:, None]), tri[:, 0] - centre)
    assert (heights > 0).all()
    pyramids = (areas * heights / 3).sum()
    assert m.volume == pytest.approx(pyramids, rel=1e-12)
    assert 4 / 3 * math.pi * heights.min() ** 3 < m.volume < 4 / 3 * math.pi * r ** 3
    assert m.area == pytest.approx(areas.sum(), rel=1e-12)
    np.testing.assert_allclose(m.center_of_mass, centre, atol=1e-12)


def test_mass_properties_agree_with_trimesh():
    trimesh = pytest.importorskip("trimesh")
    v, f = icosphere(2, 0.03, (0.01, 0.0, 0.02))
    v = v * [1.0, 1.5, 0.7]  # an ellipsoid: not symmetric about every axis
    v[:, 0] += 0.01 * v[:, 1] ** 2 / 0.03  # and bent
    m = pg.make_mesh(v, f)
    t = trimesh.Trimesh(v, f, process=False)
    assert t.is_watertight
    assert m.volume == pytest.approx(t.volume, rel=1e-10)
    assert m.area == pytest.approx(t.area, rel=1e-10)
    np.testing.assert_allclose(m.center_of_mass, t.center_mass, atol=1e-12)


# ----------------------------------------------------------------------------- clean-up

def test_degenerate_and_duplicate_faces_removed_and_counted():
    v, f = box((1, 1, 1))
    v2 = np.vstack([v, [[0.5, 0, 0], [9, 9, 9]]])  # 8: on edge 0-1, 9: unused
    extra = np.array([[0, 0, 1], [0, 8, 1], np.roll(f[3], 1), f[5][::-1]])
    m = pg.make_mesh(v2, np.vstack([f, extra]), name="dirty")
    c = m.cleanup
    assert (c.degenerate_faces, c.duplicate_faces, c.unused_vertices, c.welded_vertices) == (2, 2, 2, 0)
    np.testing.assert_array_equal(m.vertices, v)
    np.testing.assert_array_equal(m.faces, f)
    assert m.closed and m.volume == pytest.approx(1.0)


def test_face_normals_and_areas():
    v, f = box((1, 2, 3))
    m = pg.make_mesh(v, f)
    n = m.face_normals()
    assert n.shape == (12, 3)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0)
    np.testing.assert_allclose(np.abs(n).max(axis=1), 1.0)
    assert m.face_areas().sum() == pytest.approx(22.0)


# ----------------------------------------------------------------------------- errors

def test_bad_arrays_raise_value_error():
    v, f = box((1, 1, 1))
    bad = f.copy()
    bad[4, 2] = 8
    with pytest.raises(ValueError, match=r"faces: face 4 has index 8 out of range \[0, 8\)"):
        pg.make_mesh(v, bad)
    bad[4, 2] = 2 ** 32  # would wrap to 0 in 32 bits
    with pytest.raises(ValueError, match="out of range"):
        pg.make_mesh(v, bad)
    bad[4, 2] = -1
    with pytest.raises(ValueError, match="out of range"):
        pg.make_mesh(v, bad, name="cube-x")
    w = v.copy()
    w[3, 1] = np.nan
    with pytest.raises(ValueError, match="vertices: vertex 3 is not finite"):
        pg.make_mesh(w, f)
    w[3, 1] = np.inf
    with pytest.raises(ValueError, match="not finite"):
        pg.make_mesh(w, f)
    with pytest.raises(ValueError, match=r"vertices: expected shape \(N, 3\), got \(8, 2\)"):
        pg.make_mesh(v[:, :2], f)
    with pytest.raises(ValueError, match=r"faces: expected shape \(F, 3\)"):
        pg.make_mesh(v, f.ravel())
    with pytest.raises(ValueError, match="integer"):
        pg.make_mesh(v, f.astype(float))
    with pytest.raises(ValueError, match="no triangles"):
        pg.make_mesh(v, np.zeros((0, 3), np.int32))
    with pytest.raises(ValueError, match="weld_tolerance"):
        pg.make_mesh(v, f, weld_tolerance=-1.0)


def _expect_file_error(path, fragment=None):
    with pytest.raises(pg.FileError) as info:
        pg.load_mesh(path)
    assert isinstance(info.value, RuntimeError)
    assert str(path) in str(info.value)
    if fragment:
        assert fragment in str(info.value)


def test_bad_files_raise_file_error_naming_the_file(tmp_path):
    _expect_file_error(tmp_path / "missing.stl", "not found")
    (tmp_path / "empty.stl").write_bytes(b"")
    _expect_file_error(tmp_path / "empty.stl", "empty")
    (tmp_path / "garbage.stl").write_bytes(np.random.default_rng(1).integers(0, 256, 333, np.uint8).tobytes())
    _expect_file_error(tmp_path / "garbage.stl")
    (tmp_path / "garbage.obj").write_text("this is not a mesh\n")
    _expect_file_error(tmp_path / "garbage.obj")
    (tmp_path / "nofacets.stl").write_text("solid t\nendsolid t\n")
    _expect_file_error(tmp_path / "nofacets.stl", "no triangles")
    v, f = box((1, 1, 1))
    v[2, 0] = np.nan
    write_binary_stl(tmp_path / "nan.stl", v, f)
    _expect_file_error(tmp_path / "nan.stl", "not finite")
    write_dae(tmp_path / "unit.dae", *box((1, 1, 1)), unit='meter="-3"')
    _expect_file_error(tmp_path / "unit.dae", "unit")


# ----------------------------------------------------------------------------- NumPy views

def test_arrays_are_read_only_views_that_keep_the_mesh_alive():
    v, f = icosphere(2)
    m = pg.make_mesh(v, f)
    a, b = m.vertices, m.vertices
    assert np.shares_memory(a, b)
    assert np.shares_memory(m.faces, m.faces)
    assert not a.flags.owndata and not m.faces.flags.owndata
    assert a.dtype == np.float64 and m.faces.dtype == np.int32
    assert a.flags.c_contiguous and m.faces.flags.c_contiguous
    with pytest.raises(ValueError):
        a[0, 0] = 1.0
    expected_v, expected_f = a.copy(), m.faces.copy()
    faces = m.faces
    del m, b
    gc.collect()
    _ = [np.ones(1000) for _ in range(100)]  # churn the allocator
    np.testing.assert_array_equal(a, expected_v)
    np.testing.assert_array_equal(faces, expected_f)


def test_repr_and_properties():
    v, f = box((0.1, 0.2, 0.3))
    m = pg.make_mesh(v, f, name="boxy")
    r = repr(m)
    assert "boxy" in r and "8 vertices" in r and "12 faces" in r and "closed" in r
    assert m.source == "boxy"
    assert m.bounds.shape == (2, 3) and m.center_of_mass.shape == (3,)
    assert "flipped_faces=0" in repr(m.cleanup)
    assert m.non_manifold_edges == 0 and m.boundary_edges == 0
