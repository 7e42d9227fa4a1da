"""Broken meshes made here, through loading, planning set-up, simplification and the physics
check's mass: a cube with a missing face, two overlapping shells, flipped and duplicated faces, a mug
1,000 times too large, a mesh far finer than the unit facets. Each is checked against a fact of its
construction (a cube's volume and inertia, the number of faces flipped, the scale it was made at)."""
import json

import numpy as np
import pytest

import pairgrasp as pg
from pairgrasp.inertia import solid_mass_properties
from pairgrasp.simplify import simplify_mesh
from test_sim import BOX, JAW, box_mesh, grasps_doc, run_cli
from test_mesh import icosphere

BARRETT = "models/barrett/barrett.json"
A = 0.06                                          # cube edge, m


def cube(centre=(0, 0, 0)):
    return box_mesh([A, A, A], centre)


def open_cube():
    V, F = cube()
    return pg.make_mesh(V, F[2:], "open_cube")    # the two triangles of the face x = -A/2 removed


def test_missing_face_loads_open_with_its_hole_counted():
    m = open_cube()
    assert not m.closed and m.boundary_edges == 4 and m.volume == 0.0


def test_flipped_and_duplicated_faces_are_repaired():
    V, F = cube()
    flipped = F.copy()
    flipped[[1, 4, 7]] = flipped[[1, 4, 7]][:, ::-1]          # 3 of the 12 faces turned inside out
    m = pg.make_mesh(V, np.vstack([flipped, F[:2], F[5:6, ::-1]]), "messy_cube")
    assert m.cleanup.duplicate_faces == 3 and len(m.faces) == 12
    assert m.closed and m.cleanup.flipped_faces == 3
    assert m.volume == pytest.approx(A ** 3, rel=1e-9)


def test_two_overlapping_shells_load_closed_and_outward():
    V1, F1 = cube()
    V2, F2 = cube(centre=(A / 2, 0, 0))                        # overlaps the first by half
    m = pg.make_mesh(np.vstack([V1, V2]), np.vstack([F1, F2[:, ::-1] + 8]), "two_shells")   # one inside out
    assert m.closed and m.cleanup.flipped_faces == 12
    assert m.volume == pytest.approx(2 * A ** 3, rel=1e-9)      # the solid counts the overlap twice


def test_overlapping_shells_take_the_mass_of_their_union():
    V1, F1 = cube()
    V2, F2 = cube(centre=(A / 2, 0, 0))
    m = pg.make_mesh(np.vstack([V1, V2]), np.vstack([F1, F2 + 8]), "two_shells")
    pieces = [V1, V2]                                           # the convex pieces are the two cubes
    props, source = solid_mass_properties(m, 1000.0, pieces)
    assert source == "convex pieces (overlapping shells)"
    assert props.mass == pytest.approx(1000.0 * 1.5 * A ** 3, rel=0.03)    # union: 1.5 cubes
    assert props.center_of_mass[0] == pytest.approx(A / 4, abs=A / 50)


def test_open_cube_takes_the_mass_and_inertia_of_the_closed_cube():
    m = open_cube()
    V, _ = cube()
    M = 1000.0 * A ** 3
    I = M * A * A / 6                                            # a solid cube about its centre
    props, src = solid_mass_properties(m, 1000.0, [V])
    assert src == "convex hull (not closed)"
    assert props.mass == pytest.approx(M, rel=1e-9) and np.allclose(props.inertia, np.eye(3) * I, atol=1e-9 * I)
    props, src = solid_mass_properties(m, 1000.0, None, mass=0.5)
    assert src == "convex hull (not closed), mass given"
    assert props.mass == 0.5 and np.allclose(props.inertia, np.eye(3) * 0.5 * A * A / 6, atol=1e-9 * I)
    with pytest.raises(ValueError, match="mass"):
        solid_mass_properties(m, 1000.0, [V], mass=-1.0)


def test_mug_1000_times_too_large_is_refused_with_the_scale_that_fixes_it():
    mug = pg.load_mesh("models/targets/mug.stl")
    big = pg.make_mesh(np.asarray(mug.vertices) * 1000.0, np.asarray(mug.faces), "mug_mm.stl")
    with pytest.raises(ValueError, match=r"millimetres\? Load it with scale=0.001 \(CLI: --scale 0.001\)") as e:
        pg.Planner(BARRETT, big)
    extent = np.ptp(np.asarray(mug.vertices), axis=0).max()
    assert f"{extent:.3g} m across" in str(e.value)
    tiny = pg.make_mesh(np.asarray(mug.vertices) / 1000.0, np.asarray(mug.faces), "mug_km.stl")
    with pytest.raises(ValueError, match=r"--scale 1000\)"):
        pg.Planner(BARRETT, tiny)


def _fine_sphere():
    V, F = icosphere(5, 0.04)                                   # 20 * 4^5 = 20,480 faces
    return pg.make_mesh(V, F, "fine_sphere"), V, F


def test_simplify_keeps_the_shape_within_its_error_bound():
    trimesh = pytest.importorskip("trimesh")
    mesh, V, F = _fine_sphere()
    small, info = simplify_mesh(mesh, 500, 0.001)
    assert info.faces_before == len(F) and info.faces == len(small.faces) < len(F) / 4 and small.closed
    # independent: trimesh's distances of the original vertices to the simplified surface
    _, d, _ = trimesh.proximity.closest_point(trimesh.Trimesh(small.vertices, small.faces), V[::7])
    assert 0 < d.max() <= info.error_bound + 1e-12 and info.error_bound <= 0.001
    assert small.volume == pytest.approx(4 / 3 * np.pi * 0.04 ** 3, rel=0.02)
    assert simplify_mesh(mesh, len(F), 0.001) == (mesh, None)    # not larger than max_faces: untouched
    same, info = simplify_mesh(mesh, 20, 1e-9)                   # no reduction stays within 1 nm
    assert same is mesh and info.faces == info.faces_before


def test_planner_simplifies_a_large_target_and_records_it():
    mesh, _, F = _fine_sphere()
    free = np.zeros(len(F), bool)
    free[np.asarray(mesh.vertices)[np.asarray(mesh.faces)].mean(axis=1)[:, 2] > 0] = True   # upper half free
    planner = pg.Planner(JAW, mesh, paint=free, max_faces=800)
    rec = planner.inputs["target_simplified"]
    assert rec["faces_before"] == len(F) and rec["faces"] == len(planner.target.faces) < len(F) / 4
    assert 0 < rec["error_bound"] <= 0.25 * planner.edge and "fast-simplification" in rec["method"]
    assert planner.inputs["target_faces"] == len(F)              # the file's faces, as simulate reloads it
    centres = np.asarray(planner.target.vertices)[np.asarray(planner.target.faces)].mean(axis=1)
    up = centres[:, 2]
    assert planner.free[up > 0.005].all() and not planner.free[up < -0.005].any()


@pytest.mark.long
def test_simplification_stays_within_the_depth_tolerance_the_planner_uses():
    # A 4 cm sphere: the planner derives a 2.7 mm edge (a fifteenth of its size), so its depth
    # tolerance is 0.67 mm, not the 1.25 mm of 5 mm facets. A depth_tolerance given (50 um, below
    # the 59 um of the reduction a 5 mm edge's bound would take) bounds it too.
    V, F = icosphere(5, 0.02)
    mesh = pg.make_mesh(V, F, "small_sphere")
    assert pg.finest_edge(mesh) == pytest.approx(0.04 / 15, rel=1e-3)
    for given in ({}, {"depth_tolerance": 5e-5}):
        planner = pg.Planner(JAW, mesh, max_faces=60, **given)
        rec = planner.inputs["target_simplified"]
        assert rec["faces"] < len(F) and rec["error_bound"] <= planner.depth_tolerance, given
        # independent: the planned surface's points (vertices, edge midpoints, face centres) against
        # the sphere itself, less the file's own chords' depth (its 0.7 mm edges: under 4 um)
        W = np.asarray(planner.target.vertices)[np.asarray(planner.target.faces)]
        points = np.concatenate([W.reshape(-1, 3), W.mean(axis=1), (W + np.roll(W, 1, axis=1)).reshape(-1, 3) / 2])
        off = np.abs(np.linalg.norm(points, axis=1) - 0.02)
        assert off.max() <= planner.depth_tolerance + 4e-6, given


@pytest.mark.slow          # CoACD decomposes the open box for its collision pieces (minutes)
def test_cli_simulates_an_open_target_and_says_where_its_mass_comes_from(tmp_path):
    pytest.importorskip("mujoco", reason="the [sim] extra")
    V, F = box_mesh([0.06, 0.06, 0.12], (0, 0, 0.06))
    keep = [k for k in range(12) if not np.all(V[F[k], 2] == 0)]  # the bottom face (z = 0) removed
    import trimesh
    path = tmp_path / "open_box.stl"
    trimesh.Trimesh(V, F[keep], process=False).export(path)
    doc = grasps_doc()
    doc["inputs"]["target"] = str(path)
    doc["inputs"]["target_faces"] = len(keep)
    g = tmp_path / "grasps.json"
    g.write_text(json.dumps(doc))
    r = run_cli("simulate", g, "--top", "1", "--no-picture")
    assert r.returncode == 0, r.stderr
    line = [x for x in r.stdout.splitlines() if x.startswith("target mass")]
    assert len(line) == 1 and "from its convex hull (not closed)" in line[0] and "--mass KG" in line[0]
    sim = json.loads(g.read_text())["simulation"]
    assert sim["target_mass_source"] == "convex hull (not closed)"
    assert sim["target_mass"] == pytest.approx(1000 * 0.06 * 0.06 * 0.12, rel=0.02)    # the closed box's
    g.write_text(json.dumps(doc))
    r = run_cli("simulate", g, "--top", "1", "--no-picture", "--mass", "0.2")
    assert r.returncode == 0, r.stderr
    assert "target mass 0.2 kg: given (--mass)" in r.stdout
    sim = json.loads(g.read_text())["simulation"]
    assert sim["target_mass"] == 0.2 and sim["target_mass_source"].endswith("mass given")
