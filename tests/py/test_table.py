"""Objects on a table and partly covered: the free surface per patch against an independent computation
(sampled points, trimesh distances), the support plane against a table mesh, Barrett grasps that clear
the support (distance of the posed link meshes to the plane, computed here), and what grasps.json and
the CLI record."""
import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest
import trimesh

import pairgrasp as pg
from pairgrasp import view
from independent import link_meshes, to_trimesh

ROOT = pathlib.Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
BOX = MODELS / "targets" / "box.stl"        # 6 x 6 x 12 cm, standing on z = 0
HOLDER = MODELS / "targets" / "holder.stl"  # a palm, two fingers and a thumb around the box's top
BARRETT = MODELS / "barrett" / "barrett.json"


def table_mesh(z=0.0, half=0.3, thick=0.02):
    return trimesh.creation.box(extents=(2 * half, 2 * half, thick)).apply_translation((0, 0, z - thick / 2))


def as_mesh(t: trimesh.Trimesh, name):
    return pg.make_mesh(np.asarray(t.vertices, float), np.asarray(t.faces, np.int64), name)


def patch_samples(tm: trimesh.Trimesh, n=7):
    """(F, n, 3): the corners, edge midpoints and centroid of every face (barycentric, computed here)."""
    bary = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [.5, .5, 0], [0, .5, .5], [.5, 0, .5], [1 / 3, 1 / 3, 1 / 3]])
    return np.einsum("sk,fkd->fsd", bary[:n], tm.triangles)


def free_area(surface):
    tm = to_trimesh(surface.mesh)
    return float(tm.area_faces[np.asarray(surface.free, bool)].sum())


def test_holder_occlusion_matches_trimesh_distances_at_patch_resolution():
    target, holder = pg.load_mesh(str(BOX)), pg.load_mesh(str(HOLDER))
    d, res = 0.005, 0.0025
    s = pg.free_surface(target, occluders=[holder], distance=d, resolution=res, threads=1)
    assert s.split_faces > 0 and s.resolution <= res
    tm = to_trimesh(s.mesh)
    assert tm.is_watertight and abs(tm.volume - to_trimesh(target).volume) < 1e-12
    # Distance of each patch's sample points to the holder's surface, by trimesh (an R-tree, exact per triangle).
    pts = patch_samples(tm)
    q = trimesh.proximity.ProximityQuery(to_trimesh(holder))
    _, dist, _ = q.on_surface(pts.reshape(-1, 3))
    dist = dist.reshape(len(tm.faces), -1)
    free = np.asarray(s.free, bool)
    # A free patch has no sample point within the distance; an occluded one lies within the distance
    # plus its own size of the holder (the closest point of the face is within the distance).
    assert (dist[free] > d - 1e-9).all()
    edge = np.max(np.linalg.norm(tm.triangles - np.roll(tm.triangles, 1, axis=1), axis=2), axis=1)
    small = ~free & (edge <= res + 1e-12)
    assert (dist[small].min(axis=1) <= d + res + 1e-9).all()
    # Every sample point of the whole mesh more than d + res from the holder lies on a free patch, and
    # the holder covers a real part of the box, not all of it.
    far = dist.min(axis=1) > d + res
    assert free[far].all()
    assert 0.05 < 1 - free_area(s) / tm.area < 0.6


@pytest.mark.long
def test_support_plane_and_table_mesh_give_the_same_free_surface():
    target = pg.load_mesh(str(BOX))
    plane = pg.support_plane(True, target)
    assert np.allclose(plane.point[2], 0.0) and np.allclose(plane.normal, (0, 0, 1))
    by_plane = pg.free_surface(target, support=plane, resolution=0.0025, threads=1)
    table = as_mesh(table_mesh(), "table")
    by_mesh = pg.free_surface(target, occluders=[table], resolution=0.0025, threads=1)
    assert free_area(by_plane) == pytest.approx(free_area(by_mesh), abs=1e-9)
    # The box's 12 triangles run from the table up: split, the sides above 5 mm + 2.5 mm free.
    tm = to_trimesh(by_plane.mesh)
    z = tm.triangles[:, :, 2]
    free = np.asarray(by_plane.free, bool)
    assert (z.min(axis=1)[free] > 0.005).all()
    assert free[z.min(axis=1) > 0.0075].all()
    # The same through the planner: both ways plan on the same free surface (the table mesh splits the
    # bottom more finely, where it lies on two table triangles, but frees nothing more).
    hand = pg.load_hand(str(BARRETT))
    a = pg.Planner(hand, str(BOX), support=True)
    b = pg.Planner(hand, str(BOX), occluders=[table], obstacles=[table])
    for p in (a, b):
        tm = to_trimesh(p.target)
        assert tm.area_faces[p.free].sum() == pytest.approx(free_area(by_plane), abs=1e-9)
    # Settling lifts the hand out of the same plane: given, or recognised as the table mesh's top face.
    for p in (a, b):
        assert p.checker.support.height((0, 0, 0.01)) == pytest.approx(0.01, abs=1e-12)
    assert pg.SupportPlane.under(a.target, as_mesh(table_mesh(z=-0.01), "low")) is None
    (name, box), = a.core.obstacles
    assert name == "support" and np.asarray(box.vertices)[:, 2].max() == pytest.approx(0.0, abs=1e-12)


@pytest.fixture(scope="module")
def barrett_on_table():
    hand = pg.load_hand(str(BARRETT))
    planner = pg.Planner(hand, str(BOX), support=True)
    return hand, planner, planner.plan(top=5, seed=1)


@pytest.mark.long
def test_barrett_grasps_on_a_table_hold_and_clear_it(barrett_on_table):
    hand, planner, result = barrett_on_table
    assert result.grasps, "no grasp of the box standing on a table"
    assert any(g.force_closure for g in result.grasps)
    for g in result.grasps:
        # Independently: no vertex of any posed link goes below the table (a plane: the lowest
        # point of a mesh is a vertex), and the grasp touches only free (side or top) surface.
        for name, m in link_meshes(hand, g.wrist_pose, g.dofs).items():
            assert m.vertices[:, 2].min() > -1e-4, f"grasp {g.rank}: {name} goes {-m.vertices[:, 2].min():.4f} m into the table"
        pts = np.asarray(g.contact_points, float)
        assert (pts[:, 2] > 0.005 - 1e-3).all(), f"grasp {g.rank} touches the covered strip"


@pytest.mark.long
def test_support_recorded_and_read_back(barrett_on_table, tmp_path):
    hand, planner, result = barrett_on_table
    path = tmp_path / "box.grasps.json"
    pg.write_grasps(path, result.to_dict())
    doc = json.loads(path.read_text())
    inputs = doc["inputs"]
    assert inputs["support"]["normal"] == [0.0, 0.0, 1.0] and inputs["support"]["point"][2] == 0.0
    assert inputs["occluder_distance"] == 0.005
    # the 8 side faces touch the table along an edge, so the mark changes across each of them; the
    # top and bottom faces are cut only where a neighbour's split edge runs
    assert 8 <= inputs["free_surface"]["split_faces"] <= 12
    assert inputs["free_faces"] == int(planner.free.sum())
    gf = pg.load_grasps(str(path))
    assert len(gf.grasps) == len(result.grasps)
    scene = view.load_scene(str(path), hand=hand, target=str(BOX))
    names = [p.name for p in scene.parts]
    assert "support" in names


@pytest.mark.slow
def test_cli_support_and_table_mesh_plan_alike(tmp_path):
    table = tmp_path / "table.stl"
    table_mesh().export(table)
    runs = {}
    for name, extra in {"support": ["--support"], "mesh": ["--obstacle", str(table), "--occluder", str(table)]}.items():
        out = tmp_path / name
        r = subprocess.run([sys.executable, "-m", "pairgrasp", "plan", "--hand", str(BARRETT), "--target", str(BOX),
                            "--top", "3", "--seed", "1", "--pictures", "0", "--quiet", *extra, "-o", str(out)],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        runs[name] = json.loads((out / "grasps.json").read_text())
    a, b = runs["support"], runs["mesh"]
    assert "support" in a["inputs"] and "support" not in b["inputs"]
    assert a["inputs"]["free_surface"]["resolution"] == b["inputs"]["free_surface"]["resolution"]
    assert any(g["force_closure"] for g in a["grasps"]) and any(g["force_closure"] for g in b["grasps"])


def test_settling_lifts_the_hand_out_of_the_support_or_drops_it():
    """A grasp from above whose open fingers reach 3 cm into the table is lifted straight up by what
    the posed link meshes (trimesh, here) reach below it, plus the contact gap; one that would need
    more than the largest back-off is dropped before closing."""
    hand = pg.load_hand(str(BARRETT))
    planner = pg.Planner(hand, str(BOX), support=True)
    pipe = pg.CandidatePipeline(planner.checker, edge=planner.edge, backoff=planner.backoff)
    dofs = np.zeros(len(hand.dof_names))           # fingers straight, along the approach
    a = np.asarray(hand.approach, float)
    # The wrist turned so that the approach points down (-z), 15 cm beside the box: only the table is there.
    v = np.cross(a, (0, 0, -1.0))
    ang = np.arccos(np.clip(np.dot(a, (0, 0, -1.0)), -1, 1))
    R = trimesh.transformations.rotation_matrix(ang, v)[:3, :3] if np.linalg.norm(v) > 1e-9 else np.eye(3)
    poses = []
    for below in (0.03, planner.backoff + 0.02):
        T = np.eye(4)
        T[:3, :3] = R
        low = min(m.vertices[:, 2].min() for m in link_meshes(hand, T, dofs).values())
        T[0, 3] = 0.15
        T[2, 3] = -below - low                       # the lowest vertex `below` m under the table
        poses.append(T)
    rep = pipe.process([pg.AlignedCandidate(T, dofs, sample_index=k, alignment_quality=1.0, votes=1) for k, T in enumerate(poses)])
    assert rep["settled"] == 1
    (c,) = pipe.evaluated()
    assert c.sample_index == 0 and c.settled == "adjusted" and c.backoff == 0.0
    lifted = np.asarray(c.start_pose)
    assert np.allclose(lifted[:3, :3], poses[0][:3, :3]) and np.allclose(lifted[:2, 3], poses[0][:2, 3])
    gap = 0.001  # the contact gap it clears the table by
    assert lifted[2, 3] - poses[0][2, 3] == pytest.approx(0.03 + gap, abs=1e-9)
    low = min(m.vertices[:, 2].min() for m in link_meshes(hand, lifted, c.start_dofs).values())
    assert low == pytest.approx(gap, abs=1e-9)
