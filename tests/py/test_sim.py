"""The physics check: mass properties against analytic solids, convex pieces, the MuJoCo scene's
structure and kinematics against the hand, grasps of a box by the parallel jaw whose outcome is
physically obvious or computable by hand, and the `simulate` command's errors."""
import json
import math
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import pairgrasp as pg
from pairgrasp import sim as sim_mod
from test_mesh import icosphere                  # the mesh tests' construction

mujoco = pytest.importorskip("mujoco", reason="the [sim] extra (install_deps.sh installs it)")

ROOT = pathlib.Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
BARRETT = MODELS / "barrett" / "barrett.json"
JAW = MODELS / "parallel_jaw" / "parallel_jaw.json"
BOX = MODELS / "targets" / "box.stl"
BOX_SIZE = np.array([0.06, 0.06, 0.12])      # models/README.md: centred on the z axis, standing on z = 0


def box_mesh(size, centre=(0, 0, 0)):
    """A closed, outward-wound box: 8 vertices, 12 faces."""
    h = np.asarray(size, float) / 2
    V = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float) * h + centre
    F = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                  [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return V, F


def box_inertia(m, size):
    a, b, c = size
    return m / 12 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])


def l_prism(depth=0.01):
    """An L-shaped prism: the union of the boxes [0,2]x[0,1] and [0,1]x[1,3] (cm), extruded along z."""
    P = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 3], [0, 3]], float) * 0.01
    V = np.vstack([np.c_[P, np.zeros(6)], np.c_[P, np.full(6, depth)]])
    cap = [[0, 1, 2], [0, 2, 3], [0, 3, 5], [3, 4, 5]]            # counter-clockwise seen from +z
    F = [[a, c, b] for a, b, c in cap] + [[a + 6, b + 6, c + 6] for a, b, c in cap]
    for i in range(6):
        j = (i + 1) % 6
        F += [[i, j, j + 6], [i, j + 6, i + 6]]
    return V, np.array(F)


# ----- mass properties -----

def test_box_mass_properties_match_the_analytic_box():
    rho = 800.0
    mesh = pg.load_mesh(BOX)
    mp = pg.mass_properties(mesh, rho)                 # binary STL: single-precision vertices
    m = rho * BOX_SIZE.prod()
    assert mp.volume == pytest.approx(BOX_SIZE.prod(), rel=1e-6)
    assert mp.mass == pytest.approx(m, rel=1e-6)
    np.testing.assert_allclose(mp.center_of_mass, [0, 0, 0.06], atol=1e-8)
    np.testing.assert_allclose(mp.inertia, box_inertia(m, BOX_SIZE), rtol=1e-6, atol=1e-12)


def test_rotated_box_inertia_rotates_and_centre_moves():
    rng = np.random.default_rng(7)
    A = rng.normal(size=(3, 3))
    R, _ = np.linalg.qr(A)
    R *= np.sign(np.linalg.det(R))
    V, F = box_mesh([0.02, 0.05, 0.09])
    t = np.array([0.3, -0.2, 0.1])
    mp = pg.mass_properties((V @ R.T + t, F), 1000.0)
    m = 1000.0 * 0.02 * 0.05 * 0.09
    np.testing.assert_allclose(mp.center_of_mass, t, atol=1e-12)
    np.testing.assert_allclose(mp.inertia, R @ box_inertia(m, [0.02, 0.05, 0.09]) @ R.T, rtol=1e-9, atol=1e-14)


def test_sphere_inertia_matches_two_fifths_m_r_squared():
    r, rho = 0.04, 1000.0
    V, F = icosphere(4, r)                       # 5,120 faces: volume within 0.3% of the sphere's
    mp = pg.mass_properties((V + [0.01, 0.02, 0.03], F), rho)
    m = rho * 4 / 3 * math.pi * r ** 3
    assert mp.mass == pytest.approx(m, rel=4e-3)
    np.testing.assert_allclose(mp.center_of_mass, [0.01, 0.02, 0.03], atol=1e-9)
    np.testing.assert_allclose(mp.inertia, 0.4 * m * r * r * np.eye(3), rtol=8e-3, atol=1e-3 * 0.4 * m * r * r)


def test_non_convex_inertia_by_the_parallel_axis_theorem():
    V, F = l_prism()
    mp = pg.mass_properties((V, F), 1000.0)
    parts = [(np.array([0.02, 0.01, 0.01]), np.array([0.01, 0.005, 0.005])),
             (np.array([0.01, 0.02, 0.01]), np.array([0.005, 0.02, 0.005]))]
    masses = [1000.0 * s.prod() for s, _ in parts]
    com = sum(mi * c for mi, (_, c) in zip(masses, parts)) / sum(masses)
    I = np.zeros((3, 3))
    for mi, (s, c) in zip(masses, parts):
        d = c - com
        I += box_inertia(mi, s) + mi * (d @ d * np.eye(3) - np.outer(d, d))
    assert mp.mass == pytest.approx(sum(masses), rel=1e-12)
    np.testing.assert_allclose(mp.center_of_mass, com, atol=1e-12)
    np.testing.assert_allclose(mp.inertia, I, rtol=1e-9, atol=1e-15)


def test_mass_properties_bad_input():
    V, F = box_mesh([0.1, 0.1, 0.1])
    with pytest.raises(ValueError, match="density"):
        pg.mass_properties((V, F), 0.0)
    with pytest.raises(ValueError, match="no positive volume"):
        pg.mass_properties((V, F[:, ::-1]), 1000.0)      # inside out
    with pytest.raises(ValueError, match="not closed"):
        pg.mass_properties((V, F[:6]), 1000.0)           # open: half the faces
    with pytest.raises(ValueError, match="face indices"):
        pg.mass_properties((V, F + 8), 1000.0)


# ----- convex pieces -----

def test_convex_mesh_is_one_piece_and_l_shape_is_split(tmp_path):
    V, F = box_mesh([0.1, 0.2, 0.3])
    pieces = pg.convex_pieces((V, F), cache=str(tmp_path))
    assert len(pieces) == 1 and np.array_equal(pieces[0], V)
    assert not os.listdir(tmp_path)                      # nothing to decompose, nothing cached
    LV, LF = l_prism()
    first = pg.convex_pieces((LV, LF), cache=str(tmp_path))
    assert len(first) >= 2
    from scipy.spatial import ConvexHull
    vol = sum(ConvexHull(p).volume for p in first)
    assert vol == pytest.approx(4e-6, rel=0.05)         # the L's 4 cm² x 1 cm, not its hull's 5 cm² x 1 cm
    assert len([f for f in os.listdir(tmp_path) if f.startswith("coacd-")]) == 1
    again = pg.convex_pieces((LV, LF), cache=str(tmp_path))
    assert len(again) == len(first) and all(np.array_equal(a, b) for a, b in zip(first, again))


def test_convex_pieces_bad_input():
    V, F = box_mesh([0.1, 0.1, 0.1])
    with pytest.raises(ValueError, match="threshold"):
        pg.convex_pieces((V, F), threshold=0.0)
    with pytest.raises(ValueError, match="cannot bound a solid"):
        pg.convex_pieces((V[:3], F[:1]))


# ----- the scene -----

@pytest.fixture(scope="module")
def box():
    return pg.load_mesh(BOX)


@pytest.fixture(scope="module")
def jaw_sim(box):
    return pg.Simulator(JAW, box)


def test_scene_counts_barrett(box):
    sim = pg.Simulator(BARRETT, box)
    hand = sim.hand
    m = sim.model
    # models/README.md: 10 links, 8 moving joints (spread x2, 3 proximal, 3 distal mimics), 4 DOFs.
    assert m.nbody == 1 + 10 + 1
    assert m.njnt == 8 + 1 and m.jnt_type[-1] == mujoco.mjtJoint.mjJNT_FREE
    assert m.nu == 4
    assert m.neq == 3 + 1                                # 3 distal mimics + bh_j21 coupled to bh_j11
    eq = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, m.eq_obj1id[k]):
          (mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, m.eq_obj2id[k]), m.eq_data[k][:2]) for k in range(m.neq)}
    assert eq["bh_j13"][0] == "bh_j12"
    np.testing.assert_allclose(eq["bh_j13"][1], [0, 1 / 3])
    assert eq["bh_j21"][0] == "bh_j11"
    np.testing.assert_allclose(eq["bh_j21"][1], [0, -1])   # ratios +1 and -1 of the spread
    k = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "bh_j12")
    assert m.jnt_limited[k] and np.allclose(m.jnt_range[k], [0, 2.44])
    a = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, "dof_f1_flex")
    assert m.actuator_forcelimited[a] and np.allclose(m.actuator_forcerange[a], [-5, 5])   # URDF effort 5 N·m
    # the box is convex: one piece; the Barrett links are convex prisms: one piece each
    assert sim.counts["pieces"]["target"] == 1
    assert all(sim.counts["pieces"][link.name] == 1 for link in hand.links)
    assert sim.target_mass == pytest.approx(1000.0 * BOX_SIZE.prod())


def test_scene_kinematics_match_the_hand(jaw_sim, box):
    sim = pg.Simulator(BARRETT, box)
    for s in (sim, jaw_sim):
        h, m = s.hand, s.model
        d = mujoco.MjData(m)
        dofs = (np.asarray(h.dof_lower) * 0.3 + np.asarray(h.dof_upper) * 0.7)
        for name, v in h.joint_values(dofs).items():
            d.qpos[m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)]] = v
        mujoco.mj_kinematics(m, d)
        for name, want in h.link_transforms(dofs).items():   # the world is the wrist link's frame
            b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
            np.testing.assert_allclose(d.xpos[b], want[:3, 3], atol=1e-9)
            np.testing.assert_allclose(d.xmat[b].reshape(3, 3), want[:3, :3], atol=1e-9)
        # the equality constraints hold at the joint values the hand computes
        mujoco.mj_forward(m, d)
        assert np.abs(d.efc_pos[d.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY]).max(initial=0) < 1e-12


def test_jaw_fingers_are_split_into_convex_pieces(jaw_sim):
    pieces = jaw_sim.counts["pieces"]
    assert pieces["pj_base"] == 1
    assert pieces["pj_left_finger"] >= 2 and pieces["pj_right_finger"] >= 2   # L-shaped: pad over carriage
    assert jaw_sim.model.neq == 1 and jaw_sim.model.nu == 1


# ----- known outcomes: the parallel jaw on the box -----

# The jaw approaches from above (its approach +z turned to -z). Its base spans 0-0.050 and its pads
# 0.070-0.120 along the approach from the wrist (models/README.md): with the wrist at z = 0.175 the
# base clears the box's top (0.12) by 5 mm and the pads cover z = 0.055-0.105 of the box, around its
# centre of mass (z = 0.06).
DOWN = np.diag([1.0, -1.0, -1.0])


def jaw_pose(x=0.0, y=0.0, z=0.175):
    T = np.eye(4)
    T[:3, :3] = DOWN
    T[:3, 3] = [x, y, z]
    return T


def test_antipodal_grasp_holds(jaw_sim):
    r = jaw_sim.simulate(jaw_pose(), [0.06])           # pads on the faces x = -0.03 and x = +0.03
    assert r.success and r.outcome == "held"
    assert set(r.contact_links) == {"pj_left_finger", "pj_right_finger"}
    assert r.slip_translation < 0.002                  # held by friction: compliance only
    assert r.failed_phase is None
    assert r.start_backoff == 0.0                      # the base is 5 mm above the box: nothing to clear
    assert r.time_simulated == pytest.approx(jaw_sim.params.duration, abs=2e-3)


def test_closing_starts_from_the_palm_touching_not_overlapping(jaw_sim):
    # The jaw's base (z in [0, 0.05] of the wrist frame, moved by no closing DOF) placed 1 mm into the
    # box's top face (z = 0.12): the hand is moved back along its approach by that 1 mm (plus the
    # 0.1 mm margin) before closing, and the pads then hold the box as at the clear pose.
    r = jaw_sim.simulate(jaw_pose(z=0.12 + 0.05 - 0.001), [0.06])
    assert r.start_backoff == pytest.approx(0.0011, abs=2e-4)
    assert r.outcome == "held" and r.closing_translation < 0.002


def test_closing_on_air_drops(jaw_sim):
    r = jaw_sim.simulate(jaw_pose(x=0.2), [0.06])       # the box is 0.2 m away from the jaw
    assert not r.success and r.outcome == "dropped"
    assert r.contact_links == ()
    assert r.time_simulated < jaw_sim.params.duration  # stopped once it had fallen far


def test_touching_one_face_only_drops(jaw_sim):
    # the pads' tips press 0.2 mm into the box's top face (z = 0.12) and close over it: one face, no
    # opposing contact, so the touch pushes the box away instead of holding it
    r = jaw_sim.simulate(jaw_pose(z=0.12 + 0.12 - 0.0002), [0.03])
    assert r.outcome == "dropped"
    assert r.closing_translation > 0.005
    assert r.failed_phase == "closing"


def test_load_phases_name_the_gravity_the_profile_applies():
    # Every "hold D" phase applies gravity exactly along D (target frame); the phases follow the
    # procedure's order and durations: lift (turn_time), hold -z, 7 x (turn, hold), 3 shakes.
    p = pg.SimParams()
    axes = {"-z": (0, 0, -1), "+x": (1, 0, 0), "+y": (0, 1, 0), "-x": (-1, 0, 0), "-y": (0, -1, 0), "+z": (0, 0, 1)}
    seg = p.turn_time + p.hold_time
    assert pg.load_phase(p, 0.5 * p.turn_time) == "lift"
    names = []
    for k in range(8):
        t = (p.turn_time + 0.5 * p.hold_time) if k == 0 else (k * seg + p.turn_time + 0.5 * p.hold_time)
        name = pg.load_phase(p, t)
        assert name.startswith("hold ")
        np.testing.assert_allclose(sim_mod.load_profile(p, t), 9.81 * np.array(axes[name[5:]]), atol=1e-9)
        names.append(name[5:])
        if k:
            assert pg.load_phase(p, k * seg + 0.5 * p.turn_time) == "turn " + name[5:]
    assert names == ["-z", "+x", "+y", "-x", "-y", "+z", "+x", "-z"]
    shakes = 8 * seg
    assert [pg.load_phase(p, shakes + (i + 0.5) * p.shake_time) for i in range(3)] == ["shake x", "shake y", "shake z"]
    end = p.duration - p.close_time
    assert pg.load_phase(p, end - 1e-6) == "shake z" and pg.load_phase(p, end + 1e-6) is None
    assert sim_mod.load_profile(p, end + 1e-6) is None


def test_frictionless_grasp_drops(jaw_sim):
    assert jaw_sim.simulate(jaw_pose(), [0.06], friction=0.0).outcome == "dropped"


def test_bounded_squeeze_force_decides_the_load_held():
    # The actuator pushes the jaw's joint with at most 50 N (URDF effort); the mimic joint couples the
    # right finger, so each pad presses with 25 N and friction holds at most 2 * 0.5 * 25 = 25 N. The
    # largest load is gravity plus the vertical shake, 9.81 + 5 = 14.81 m/s^2: 1.69 kg at most.
    box = pg.load_mesh(BOX)
    limit = 25.0 / 14.81 / BOX_SIZE.prod()               # density at which the box weighs 1.69 kg
    assert pg.Simulator(JAW, box, density=0.6 * limit).simulate(jaw_pose(), [0.06]).success
    heavy = pg.Simulator(JAW, box, density=1.5 * limit).simulate(jaw_pose(), [0.06])
    assert heavy.outcome == "dropped"


def slab_stl(path, z0, z1):
    """An ASCII STL of the slab [-0.2, 0.2] x [-0.2, 0.2] x [z0, z1]: a table top."""
    V, F = box_mesh([0.4, 0.4, z1 - z0], centre=(0.0, 0.0, (z0 + z1) / 2))
    lines = ["solid slab"]
    for f in F:
        a, b, c = V[f]
        n = np.cross(b - a, c - a)
        lines += [f"facet normal {n[0]:.6g} {n[1]:.6g} {n[2]:.6g}", "outer loop",
                  *[f"vertex {p[0]:.9g} {p[1]:.9g} {p[2]:.9g}" for p in (a, b, c)], "endloop", "endfacet"]
    path.write_text("\n".join(lines + ["endsolid slab"]) + "\n")
    return path


def test_obstacle_supports_the_object_while_closing_then_goes_away(tmp_path):
    # The pads' tips press on the box's top face (test_touching_one_face_only_drops): without support
    # the touch pushes the box away while the hand closes; with the plan's table under it (z <= 0) the
    # box stays put, and once the table is taken away for the load phases nothing holds it.
    doc = grasps_doc(pose=jaw_pose(z=0.12 + 0.12 - 0.0002), dof=(0.03,))
    doc["grasps"] = doc["grasps"][:1]
    path = tmp_path / "grasps.json"
    path.write_text(json.dumps(doc))
    free = pg.simulate_grasps(path, picture=False).results[0]
    doc["inputs"]["obstacles"] = [str(slab_stl(tmp_path / "table.stl", -0.02, 0.0))]
    path.write_text(json.dumps(doc))
    rep = pg.simulate_grasps(path, picture=False)
    held = rep.results[0]
    assert free.closing_translation > 0.005 and held.closing_translation < 0.001
    assert free.outcome == held.outcome == "dropped"
    # the box falls as soon as the table recedes, while gravity fades in: the lift
    assert (free.failed_phase, held.failed_phase) == ("closing", "lift")
    assert rep.counts["bodies"] == pg.Simulator(JAW, pg.load_mesh(BOX)).counts["bodies"] + 1
    assert rep.counts["pieces"]["obstacle_0"] == 1
    assert json.loads(path.read_text())["grasps"][0]["simulation"]["outcome"] == "dropped"
    # The same table as a plan's recorded support plane (`plan --support`): a box under the target
    # while the hand closes, gone for the load.
    del doc["inputs"]["obstacles"]
    doc["inputs"]["support"] = {"point": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0]}
    path.write_text(json.dumps(doc))
    rep = pg.simulate_grasps(path, picture=False)
    assert rep.results[0].closing_translation < 0.001
    assert (rep.results[0].outcome, rep.results[0].failed_phase) == ("dropped", "lift")


def test_simulate_bad_values(jaw_sim):
    with pytest.raises(ValueError, match="expected 1 values|expected 1"):
        jaw_sim.simulate(jaw_pose(), [0.06, 0.0])
    with pytest.raises(ValueError, match="opening"):
        jaw_sim.simulate(jaw_pose(), [0.5])
    bad = jaw_pose()
    bad[:3, :3] *= 2
    with pytest.raises(ValueError, match="wrist_pose"):
        jaw_sim.simulate(bad, [0.06])
    with pytest.raises(ValueError, match="density"):
        pg.Simulator(JAW, pg.load_mesh(BOX), density=-1)
    with pytest.raises(ValueError, match="unknown simulation parameter"):
        pg.Simulator(JAW, pg.load_mesh(BOX), gravity=3)


# ----- the command -----

def grasps_doc(hand_spec=JAW, hand="parallel_jaw", pose=None, dof=(0.06,)):
    return {"format": "pairgrasp.grasps/1",
            "inputs": {"hand": hand, "hand_spec": str(hand_spec), "target": str(BOX), "target_faces": 12},
            "grasps": [{"rank": 1, "wrist_pose": (jaw_pose() if pose is None else pose).tolist(), "dof": list(dof),
                        "joints": {}, "epsilon": 0.1, "force_closure": True, "alignment_quality": 1.0, "votes": 3,
                        "penetration_depth": 0.0, "contacts": []},
                       {"rank": 2, "wrist_pose": jaw_pose(x=0.2).tolist(), "dof": list(dof), "joints": {},
                        "epsilon": 0.0, "force_closure": False, "alignment_quality": 0.5, "votes": 1,
                        "penetration_depth": 0.0, "contacts": []}]}


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "pairgrasp", *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT, timeout=600)


@pytest.mark.long
def test_cli_simulate_writes_outcomes(tmp_path):
    path = tmp_path / "grasps.json"
    path.write_text(json.dumps(grasps_doc()))
    r = run_cli("simulate", path, "--top", "2")
    assert r.returncode == 0, r.stderr
    doc = json.loads(path.read_text())
    sims = [g["simulation"] for g in doc["grasps"]]
    assert [s["success"] for s in sims] == [True, False]
    assert sims[1]["outcome"] == "dropped" and sims[0]["slip_translation"] < 0.002
    assert doc["simulation"]["scene"]["actuators"] == 1 and doc["simulation"]["parameters"]["friction"] == 0.5
    assert (tmp_path / "simulation.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "held 1/2" in r.stdout
    assert pg.load_grasps(path).grasps[0].rank == 1      # still a valid grasps file
    # --top 1 simulates only the first grasp
    path.write_text(json.dumps(grasps_doc()))
    assert run_cli("simulate", path, "--top", "1", "--no-picture").returncode == 0
    doc = json.loads(path.read_text())
    assert "simulation" in doc["grasps"][0] and "simulation" not in doc["grasps"][1]


def _error(r):
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pairgrasp: error: "), r.stderr
    return lines[0]


def test_cli_simulate_errors(tmp_path):
    assert "no such file" in _error(run_cli("simulate", tmp_path / "absent.json"))
    bad = tmp_path / "grasps.json"
    bad.write_text('{"format": "pairgrasp.grasps/1", "grasps": [{"rank": 1}]}')
    assert "grasps[0]: missing 'wrist_pose'" in _error(run_cli("simulate", bad))
    bad.write_text("{not json")
    assert "not valid JSON" in _error(run_cli("simulate", bad))
    # planned for the jaw, simulated with the Barrett hand
    bad.write_text(json.dumps(grasps_doc()))
    msg = _error(run_cli("simulate", bad, "--hand", BARRETT))
    assert "planned for hand 'parallel_jaw', not 'barrett_bh8_28x'" in msg
    # a file that names the Barrett hand but carries a 1-DOF grasp
    bad.write_text(json.dumps(grasps_doc(hand_spec=BARRETT, hand="barrett_bh8_28x")))
    assert "grasps[0].dof: expected 4 values for hand barrett_bh8_28x, got 1" in _error(run_cli("simulate", bad))
    bad.write_text(json.dumps(grasps_doc()))
    before = bad.read_text()
    assert "--top" in _error(run_cli("simulate", bad, "--top", "0"))
    assert "--top" in _error(run_cli("simulate", bad, "--top", "x"))
    doc = grasps_doc()
    doc["inputs"]["target"] = str(tmp_path / "gone.stl")
    bad.write_text(json.dumps(doc))
    assert "inputs.target: no such file" in _error(run_cli("simulate", bad))
    assert bad.read_text() == json.dumps(doc) and not (tmp_path / "simulation.png").exists()   # nothing written
    bad.write_text(before)


def test_cli_simulate_without_mujoco(tmp_path):
    path = tmp_path / "grasps.json"
    path.write_text(json.dumps(grasps_doc()))
    code = ("import sys; sys.modules['mujoco'] = None; import pairgrasp.cli as c; "
            f"sys.exit(c.main(['simulate', {str(path)!r}]))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert "pip install .[sim]" in _error(r)
    assert "simulation" not in path.read_text()


# ----- perturbed trials and simulation in the loop -----

@pytest.mark.slow
def test_perturbed_trials_and_verification_rerank_by_outcome(tmp_path):
    # Rank 1 closes on air (dropped whatever the errors); rank 2 is the antipodal grasp, which holds
    # under every trial's errors: 1 mm and 1 degree move the pads within the 60 mm faces, and the
    # heaviest box (1500 kg/m^3: 0.65 kg, 9.6 N under 14.81 m/s^2) stays below what the least friction
    # holds (2 * 0.4 * 25 N = 20 N).
    doc = grasps_doc()
    doc["grasps"] = [dict(doc["grasps"][1], rank=1), dict(doc["grasps"][0], rank=2)]
    path = tmp_path / "grasps.json"
    path.write_text(json.dumps(doc))
    r = run_cli("simulate", path, "--trials", "3", "--seed", "2", "--no-picture")
    assert r.returncode == 0, r.stderr
    assert "held 3/6" in r.stdout
    sims = [g["simulation"] for g in json.loads(path.read_text())["grasps"]]
    assert [s["success_rate"] for s in sims] == [0.0, 1.0]
    for s in sims:
        assert len(s["trials"]) == 3 and s["outcome"] == s["trials"][0]["outcome"]
        assert s["trials"][0]["friction"] is None and s["trials"][0]["wrist_offset"] == [0.0, 0.0, 0.0]
        for t in s["trials"][1:]:
            assert 0.4 <= t["friction"] <= 0.6 and 500 <= t["density"] <= 1500
            assert 0 < np.linalg.norm(t["wrist_offset"]) < 0.006 and 0 < t["wrist_rotation"] < math.radians(5)
    assert all(t["outcome"] == "dropped" for t in sims[0]["trials"])
    # simulation in the loop: the grasp that held comes first, with its planned rank
    assert pg.verify_grasps(path, top=2, trials=2, seed=2) == [2, 1]
    out = json.loads(path.read_text())
    assert [(g["rank"], g["planned_rank"]) for g in out["grasps"]] == [(1, 2), (2, 1)]
    assert out["verification"] == {"top": 2, "check": "trials", "trials": 2, "seed": 2, "planned_ranks": [2, 1]}
    assert pg.load_grasps(path).grasps[0].epsilon == 0.1
    # the lift check, on the plan's order: the closing on air lets the object fall as gravity fades in
    # (dropped: beyond 5 x 10 mm within the lift's 0.25 s, where free fall would take it ~0.15 m); the
    # antipodal grasp holds it within the 10 mm threshold
    path.write_text(json.dumps(doc))
    assert pg.verify_grasps(path, top=2, check="lift") == [2, 1]
    out = json.loads(path.read_text())
    assert out["verification"] == {"top": 2, "check": "lift", "planned_ranks": [2, 1]}
    held, air = (g["lift_check"] for g in out["grasps"])
    assert held["outcome"] == "held" and held["moved"] < 0.01 and held["contact_links"]
    assert air["outcome"] == "dropped" and air["moved"] > 0.05 and air["contact_links"] == []
    assert held["moved"] == pytest.approx(held["closing_translation"] + held["lift_translation"], abs=2e-9)
    with pytest.raises(ValueError, match="check: expected one of trials, lift"):
        pg.verify_grasps(path, top=2, check="load")


def test_simulate_until_stops_the_procedure_after_the_closing_or_the_lift():
    sim = pg.Simulator(JAW, BOX)
    doc = grasps_doc()
    g = doc["grasps"][0]
    T, q = np.asarray(g["wrist_pose"]), np.asarray(g["dof"])
    p = sim.params
    closing = sim.simulate(T, q, until=0.0)
    assert closing.time_simulated == pytest.approx(p.close_time) and closing.slip_translation == 0.0
    lift = sim.simulate(T, q, until=p.turn_time)
    assert lift.time_simulated == pytest.approx(p.close_time + p.turn_time, abs=2 * p.timestep)
    assert lift.closing_translation == pytest.approx(closing.closing_translation, abs=1e-9)   # deterministic
    for bad in (-0.1, math.nan, "0.2"):
        with pytest.raises(ValueError, match="until: expected a finite number >= 0"):
            sim.simulate(T, q, until=bad)


@pytest.mark.slow
def test_plan_verify_top_simulates_and_reranks(tmp_path, monkeypatch, capsys):
    from pairgrasp import cli, grasps_file

    io = {"write": 0, "read": 0}   # the plan is simulated in memory: grasps.json is written once, never read
    write, read = grasps_file.write_grasps, grasps_file.load_grasps
    monkeypatch.setattr(grasps_file, "write_grasps", lambda *a: (io.__setitem__("write", io["write"] + 1), write(*a))[1])
    monkeypatch.setattr(grasps_file, "load_grasps", lambda *a, **k: (io.__setitem__("read", io["read"] + 1),
                                                                    read(*a, **k))[1])
    def plan(out, *options):   # the jaw on the box: the command's output and the grasps.json it wrote
        code = cli.main([str(a) for a in ("plan", "--hand", JAW, "--target", BOX, "--edge", "0.008", "--seed", "1",
                                          "--quiet", *options, "-o", out)])
        r = capsys.readouterr()
        assert code == 0, r.err
        return r, json.loads((out / "grasps.json").read_text())

    out = tmp_path / "plan"
    paint = ("--paint", MODELS / "targets" / "box.paint.json")
    r, doc = plan(out, *paint, "--top", "3", "--pictures", "1", "--verify-top", "2", "--trials", "2")
    assert io == {"write": 1, "read": 0}
    g = doc["grasps"]
    assert [x["rank"] for x in g] == list(range(1, len(g) + 1))
    assert doc["verification"]["top"] == 2 and doc["verification"]["trials"] == 2
    assert sorted(x["planned_rank"] for x in g[:2]) == [1, 2]
    rates = [x["simulation"]["success_rate"] for x in g[:2]]
    assert rates == sorted(rates, reverse=True) and all(len(x["simulation"]["trials"]) == 2 for x in g[:2])
    assert all("simulation" not in x for x in g[2:])
    assert doc["inputs"]["hand_spec"] == str(JAW) and doc["pictures"] == ["grasp_01.png"]
    assert "held" in r.out.splitlines()[1]
    # --verify lift: the cheap check, its column, its record; --verify alone is refused
    r, doc = plan(out, *paint, "--top", "3", "--pictures", "0", "--verify-top", "3", "--verify", "lift")
    assert doc["verification"]["check"] == "lift" and "trials" not in doc["verification"]
    moved = [x["lift_check"]["moved"] for x in doc["grasps"]]
    assert moved == sorted(moved) and all("simulation" not in x for x in doc["grasps"])
    assert "moved" in r.out.splitlines()[1] and " mm (planned " in r.out
    # on a table: the planner splits the box's 12 faces where the table covers them, and the check
    # simulates the file's target (inputs.target) with the table under it
    r, doc = plan(tmp_path / "table", "--support", "--top", "2", "--pictures", "0", "--verify-top", "2", "--verify", "lift")
    assert doc["inputs"]["support"] and doc["inputs"]["free_surface"]["faces"] > doc["inputs"]["target_faces"] == 12
    assert doc["verification"]["check"] == "lift" and all("lift_check" in g for g in doc["grasps"][:2])
    code = cli.main([str(a) for a in ("plan", "--hand", JAW, "--target", BOX, "--verify", "lift", "-o", tmp_path / "x")])
    assert code != 0 and capsys.readouterr().err.strip() == "pairgrasp: error: --verify: only with --verify-top K"
    assert not (tmp_path / "x").exists()
