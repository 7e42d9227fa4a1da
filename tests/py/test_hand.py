"""Hands from Python: loading, forward kinematics against hand-computed trigonometry from the
Barrett model's stated dimensions, limits, constellations, and clear errors for bad spec files."""
import json
import math
import os
import pathlib
import threading

import numpy as np
import pytest

import pairgrasp as pg

ROOT = pathlib.Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
BARRETT = MODELS / "barrett" / "barrett.json"
JAW = MODELS / "parallel_jaw" / "parallel_jaw.json"

# Barrett BH8-28x dimensions as stated in models/README.md (metres, radians).
PALM_TOP, BASE_X, KNUCKLE, KNUCKLE_H = 0.075, 0.025, 0.050, 0.020
PROX, DIST, REST = 0.070, 0.055, math.radians(42.0)
PROX_HALF_THICK, DIST_HALF_THICK, WIDTH, PALM_R = 0.009, 0.008, 0.025, 0.048


def finger_by_hand(finger, spread, flex):
    """Proximal joint, fingertip and inner normals of one finger, from the dimensions alone."""
    base = {1: (BASE_X, 0, PALM_TOP), 2: (-BASE_X, 0, PALM_TOP), 3: (0, 0, PALM_TOP)}[finger]
    yaw = {1: -spread, 2: spread, 3: math.pi}[finger]
    u = np.array([-math.sin(yaw), math.cos(yaw), 0.0])   # radial: knuckle axis -> proximal joint
    z = np.array([0.0, 0.0, 1.0])
    joint = np.array(base) + KNUCKLE * u + KNUCKLE_H * z
    phi = flex + REST + flex / 3.0
    d1 = math.cos(flex) * z - math.sin(flex) * u      # curls towards the palm centre (-u)
    d2 = math.cos(phi) * z - math.sin(phi) * u
    dist_joint = joint + PROX * d1
    n1 = -(math.cos(flex) * u + math.sin(flex) * z)
    n2 = -(math.cos(phi) * u + math.sin(phi) * z)
    return dict(joint=joint, tip=dist_joint + DIST * d2,
                prox_sample=joint + PROX / 2 * d1 + PROX_HALF_THICK * n1, prox_normal=n1,
                dist_sample=dist_joint + DIST / 2 * d2 + DIST_HALF_THICK * n2, dist_normal=n2)


@pytest.fixture(scope="module")
def barrett():
    return pg.load_hand(str(BARRETT))


@pytest.fixture(scope="module")
def jaw():
    return pg.load_hand(JAW)   # a pathlib.Path works too


def test_barrett_attributes(barrett):
    h = barrett
    assert h.name == "barrett_bh8_28x"
    assert h.dof_names == ["spread", "f1_flex", "f2_flex", "f3_flex"]
    assert isinstance(h.dof_lower, np.ndarray) and h.dof_lower.shape == (4,)
    np.testing.assert_allclose(h.dof_lower, [0, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(h.dof_upper, [math.pi, 2.44, 2.44, 2.44], atol=1e-12)
    np.testing.assert_allclose(h.dof_step, [0.25] * 4)
    assert h.wrist_link == "bh_palm"
    np.testing.assert_allclose(h.approach, [0, 0, 1])
    with pytest.warns(DeprecationWarning, match="root_to_wrist"):   # the hand is rooted at its wrist
        np.testing.assert_allclose(h.root_to_wrist, np.eye(4))
    assert h.link_names[0] == h.wrist_link
    assert len(h.joint_names) == 8
    assert [l.name for l in h.links if l.active] == [
        "bh_palm", "bh_f1_prox", "bh_f1_dist", "bh_f2_prox", "bh_f2_dist", "bh_f3_prox", "bh_f3_dist"]
    palm = h.links[h.link_index("bh_palm")]
    faces = np.asarray(palm.mesh.faces)
    verts = np.asarray(palm.mesh.vertices)
    assert palm.active_faces.dtype.kind == "i" and len(palm.active_faces) > 0
    # The palm's active faces are its top: every corner at z = 0.075.
    np.testing.assert_allclose(verts[faces[palm.active_faces]][..., 2], PALM_TOP, atol=1e-9)
    assert set(h.link_names) >= {l.name for l in h.links}
    assert h.dofs[1].joints[0].joint == "bh_j12" and not h.dofs[1].linear


@pytest.mark.parametrize("dofs", [[0, 0, 0, 0], [math.pi / 2, 1.0, 0.5, 2.0], [math.pi, 2.44, 1.2, 0.3],
                                  [0.7, 0.3, 2.2, 1.5]])
def test_fingertips_match_hand_computation(barrett, dofs):
    tf = barrett.link_transforms(np.array(dofs))
    assert set(tf) == set(barrett.link_names)
    for f in (1, 2, 3):
        ref = finger_by_hand(f, dofs[0], dofs[f])
        T = tf[f"bh_f{f}_dist"]
        assert T.shape == (4, 4)
        tip = T[:3, :3] @ [0, 0, DIST] + T[:3, 3]
        np.testing.assert_allclose(tip, ref["tip"], atol=1e-9)
        np.testing.assert_allclose(tf[f"bh_f{f}_prox"][:3, 3], ref["joint"], atol=1e-9)


def test_mimic_and_mirror(barrett):
    rng = np.random.default_rng(3)
    for _ in range(10):
        d = np.r_[rng.uniform(0, math.pi), rng.uniform(0, 2.44, 3)]
        q = barrett.joint_values(d)
        assert list(q) == barrett.joint_names
        for f in (1, 2, 3):
            assert q[f"bh_j{f}3"] == pytest.approx(q[f"bh_j{f}2"] / 3, abs=1e-12)
        assert q["bh_j11"] == pytest.approx(-d[0]) and q["bh_j21"] == pytest.approx(d[0])
    tf = barrett.link_transforms([math.pi / 2, 1.1, 1.1, 0.4])
    for part in ("knuckle", "prox", "dist"):
        a = tf[f"bh_f1_{part}"] @ [0.003, 0.01, 0.02, 1]
        b = tf[f"bh_f2_{part}"] @ [-0.003, 0.01, 0.02, 1]
        np.testing.assert_allclose(a[:3], b[:3] * [-1, 1, 1], atol=1e-12)


def test_bad_dof_vectors(barrett):
    with pytest.raises(ValueError, match=r"spread.*outside its limits \[0, 3.14159"):
        barrett.link_transforms([3.5, 0, 0, 0])
    with pytest.raises(ValueError, match="f2_flex.*not finite"):
        barrett.joint_values([0, 0, float("nan"), 0])
    with pytest.raises(ValueError, match="f2_flex.*not finite"):
        barrett.joint_values([0, 0, float("nan"), 0], clamp=True)
    with pytest.raises(ValueError, match="dofs: expected 4, got 3"):
        barrett.constellation([0, 0, 0])
    with pytest.raises(ValueError, match="1-D"):
        barrett.link_transforms(np.zeros((4, 1)))
    with pytest.raises(ValueError, match="f3_flex"):
        barrett.constellation([0, 0, 0, -0.2], mode="area")
    # clamp=True holds values at their limits
    a = barrett.joint_values([4.0, -1.0, 3.0, 1.0], clamp=True)
    b = barrett.joint_values([math.pi, 0.0, 2.44, 1.0])
    assert a == pytest.approx(b, abs=1e-15)


def test_per_link_constellation(barrett):
    d = np.array([1.0, 1.2, 0.4, 2.3])
    c = barrett.constellation(d, mode="per_link")
    assert len(c) == 7 and c.points.shape == (7, 3) and c.normals.shape == (7, 3)
    assert not c.points.flags.writeable   # a read-only view of the C++ result
    np.testing.assert_allclose(np.linalg.norm(c.normals, axis=1), 1.0, atol=1e-12)
    assert c.links[0] == "bh_palm"
    assert [barrett.links[i].name for i in c.link_index] == c.links
    np.testing.assert_allclose(c.points[0], [0, 0, PALM_TOP], atol=1e-7)
    np.testing.assert_allclose(c.normals[0], [0, 0, 1], atol=1e-12)
    for f in (1, 2, 3):
        ref = finger_by_hand(f, d[0], d[f])
        np.testing.assert_allclose(c.points[2 * f - 1], ref["prox_sample"], atol=1e-7)
        np.testing.assert_allclose(c.normals[2 * f - 1], ref["prox_normal"], atol=1e-7)
        np.testing.assert_allclose(c.points[2 * f], ref["dist_sample"], atol=1e-7)
        np.testing.assert_allclose(c.normals[2 * f], ref["dist_normal"], atol=1e-7)
    with pytest.raises(ValueError, match="mode"):
        barrett.constellation(d, mode="perlink")


def _distance_to_triangles(p, tris):
    """Brute-force distance from point p to each triangle (T,3,3)."""
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    h = np.einsum("ij,ij->i", p - a, n)
    q = p - h[:, None] * n
    inside = np.ones(len(tris), bool)
    for x, y in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(y - x, q - x), n) >= -1e-15
    d = np.where(inside, np.abs(h), np.inf)
    for x, y in ((a, b), (b, c), (c, a)):
        e = y - x
        t = np.clip(np.einsum("ij,ij->i", p - x, e) / np.einsum("ij,ij->i", e, e), 0, 1)
        d = np.minimum(d, np.linalg.norm(x + t[:, None] * e - p, axis=1))
    return d


def test_area_constellation(barrett):
    d = [0.8, 0.9, 1.6, 0.4]
    poses = barrett.link_poses(d)
    area = 12 * PALM_R ** 2 * math.sin(2 * math.pi / 24) + 3 * WIDTH * (PROX + DIST)
    counts = []
    for spacing in (0.01, 0.005):
        c = barrett.constellation(d, mode="area", spacing=spacing)
        counts.append(len(c))
        assert 0.5 * area / spacing ** 2 < len(c) < 4 * area / spacing ** 2
        assert set(c.links) == {l.name for l in barrett.links if l.active}
        for i in range(0, len(c), 7):
            link = barrett.links[c.link_index[i]]
            T = poses[c.link_index[i]]
            p = T[:3, :3].T @ (c.points[i] - T[:3, 3])
            tris = np.asarray(link.mesh.vertices)[np.asarray(link.mesh.faces)[link.active_faces]]
            assert _distance_to_triangles(p, tris).min() < 1e-9
    assert 3.0 < counts[1] / counts[0] < 5.5
    for bad in (0.0, -0.01, float("nan")):
        with pytest.raises(ValueError, match="spacing"):
            barrett.constellation(d, mode="area", spacing=bad)


def test_constellation_from_threads(barrett):
    d = [0.3, 0.5, 0.6, 0.7]
    out = [None] * 4

    def work(k):
        out[k] = barrett.constellation(d, mode="area", spacing=0.006).points.copy()

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for k in range(1, 4):
        np.testing.assert_array_equal(out[k], out[0])


def test_parallel_jaw(jaw):
    assert jaw.dof_names == ["opening"]
    np.testing.assert_allclose([jaw.dof_lower[0], jaw.dof_upper[0]], [0.0, 0.08], atol=1e-12)
    assert jaw.dofs[0].linear
    for q in (0.0, 0.02, 0.08):
        c = jaw.constellation([q])
        assert c.links == ["pj_left_finger", "pj_right_finger"]
        np.testing.assert_allclose(c.normals, [[1, 0, 0], [-1, 0, 0]], atol=1e-12)   # facing each other
        np.testing.assert_allclose(c.points, [[-q / 2, 0, 0.095], [q / 2, 0, 0.095]], atol=1e-7)
    q = jaw.joint_values([0.06])
    assert q == pytest.approx({"pj_left_joint": 0.03, "pj_right_joint": 0.03})
    with pytest.raises(ValueError, match=r"opening.*\[0, 0.08\] m"):
        jaw.joint_values([0.09])


# ------------------------------------------------------------------ spec and URDF errors

def _barrett_spec(tmp_path, edit=None, name="spec.json"):
    spec = json.loads(BARRETT.read_text())
    spec["urdf"] = str(MODELS / "barrett" / "bh8_28x.urdf")
    spec["package_paths"] = [str(MODELS)]
    if edit:
        edit(spec)
    p = tmp_path / name
    p.write_text(json.dumps(spec))
    return p


@pytest.mark.parametrize("edit, needle", [
    (lambda s: s.pop("wrist_link"), "wrist_link: missing field"),
    (lambda s: s.update(approach="up"), "approach: expected an array of 3 numbers"),
    (lambda s: s["dofs"][2]["joints"][0].update(joint="x"), "dofs[2].joints[0].joint: no joint 'x' in bh8_28x.urdf"),
    (lambda s: s["active_surfaces"][3].update(link="nope"), "active_surfaces[3].link: no link 'nope'"),
    (lambda s: s["active_surfaces"][0].update(box={"min": [1, 1, 1], "max": [2, 2, 2]}),
     "active_surfaces[0]: selects no face of link 'bh_palm'"),
    (lambda s: s["dofs"][1].update(lower=2.0, upper=1.0), "dofs[1].lower: lower limit 2 is greater than upper limit 1"),
    (lambda s: s["dofs"][0].update(step=0), "dofs[0].step: must be positive"),
    (lambda s: s["dofs"][0].update(step="big"), "dofs[0].step: expected a number, got a string"),
    (lambda s: s.update(urdf="missing.urdf"), "urdf: no such file"),
])
def test_spec_field_errors(tmp_path, edit, needle):
    spec = _barrett_spec(tmp_path, edit)
    with pytest.raises(pg.FileError) as e:
        pg.load_hand(spec)
    assert str(spec) in str(e.value)
    assert needle in str(e.value)
    assert isinstance(e.value, RuntimeError)


SMALL_URDF = """<robot name="small">
  <link name="palm"><collision><geometry><box size="0.04 0.04 0.02"/></geometry></collision></link>
  <link name="finger"><collision><geometry><mesh filename="{uri}"/></geometry></collision></link>
  <joint name="j" type="revolute"><parent link="palm"/><child link="finger"/><origin xyz="0 0 0.01"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="1.5" effort="1" velocity="1"/></joint>
</robot>
"""
SMALL_SPEC = {"urdf": "small.urdf", "wrist_link": "palm", "approach": [0, 0, 1],
              "dofs": [{"name": "flex", "joints": [{"joint": "j"}]}],
              "active_surfaces": [{"link": "finger", "normal_cone": {"axis": [0, -1, 0], "half_angle_deg": 10}}]}


def _small(tmp_path, uri, spec=None):
    (tmp_path / "small.urdf").write_text(SMALL_URDF.format(uri=uri))
    p = tmp_path / "small.json"
    p.write_text(json.dumps(spec or SMALL_SPEC))
    return p


def test_package_uri_resolution(tmp_path):
    spec = _small(tmp_path, "package://barrett/meshes/bh_finger_prox.stl")
    with pytest.raises(pg.FileError, match=r"small\.urdf: link 'finger': cannot resolve 'package://barrett/"):
        pg.load_hand(spec)
    h = pg.load_hand(spec, package_paths=[str(MODELS)])
    z = np.asarray(h.links[h.link_index("finger")].mesh.vertices)[:, 2]
    assert z.max() == pytest.approx(PROX, abs=1e-7)
    # the spec's own search path, relative to the spec file
    rel = os.path.relpath(MODELS, tmp_path)
    spec2 = _small(tmp_path, "package://barrett/meshes/bh_finger_prox.stl", dict(SMALL_SPEC, package_paths=[rel]))
    assert pg.load_hand(spec2).dof_names == ["flex"]


def test_missing_and_malformed_files(tmp_path):
    spec = _small(tmp_path, "meshes/nothing.stl")
    with pytest.raises(pg.FileError, match=r"nothing\.stl: mesh of link 'finger'.*not found"):
        pg.load_hand(spec)
    (tmp_path / "small.urdf").write_text("<robot name='x'><link name='a'>")
    with pytest.raises(pg.FileError, match=r"small\.urdf: malformed URDF"):
        pg.load_hand(spec)
    with pytest.raises(pg.FileError, match="hand spec file not found"):
        pg.load_hand(tmp_path / "absent.json")
    (tmp_path / "bad.json").write_text("{")
    with pytest.raises(pg.FileError, match=r"bad\.json: invalid JSON"):
        pg.load_hand(tmp_path / "bad.json")


def _joint_motion(j, q):
    """4x4 motion of a joint at value q about / along its axis (Rodrigues), independent of the library's FK."""
    T = np.eye(4)
    a = np.asarray(j.axis, float)
    if j.type == pg.JointType.prismatic:
        T[:3, 3] = q * a
    elif j.type != pg.JointType.fixed:
        K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
        T[:3, :3] = np.eye(3) + math.sin(q) * K + (1 - math.cos(q)) * K @ K
    return T


@pytest.mark.parametrize("spec", [BARRETT, JAW])
def test_joints_rebuild_forward_kinematics(spec):
    h = pg.load_hand(spec)
    joints = h.joints
    assert [j.child_link for j in joints] == h.link_names[1:]            # one parent joint per non-root link
    assert [j.name for j in joints if j.type != pg.JointType.fixed] == h.joint_names
    rng = np.random.default_rng(3)
    for _ in range(5):
        dofs = rng.uniform(h.dof_lower, h.dof_upper)
        q = h.joint_values(dofs)
        pose = {h.link_names[0]: np.eye(4)}            # the wrist link is the hand's root
        for j in joints:
            pose[j.child_link] = pose[j.parent_link] @ j.origin @ _joint_motion(j, q.get(j.name, 0.0))
        T = h.link_transforms(dofs)
        for name, M in pose.items():
            np.testing.assert_allclose(M, T[name], atol=1e-12)


def test_barrett_joint_facts(barrett):
    by = {j.name: j for j in barrett.joints}
    assert len(by) == 9 and sum(j.type == pg.JointType.fixed for j in by.values()) == 1   # finger 3's knuckle
    j12, j13 = by["bh_j12"], by["bh_j13"]
    assert (j12.parent_link, j12.child_link) == ("bh_f1_knuckle", "bh_f1_prox")
    np.testing.assert_allclose(j12.origin[:3, 3], [0.0, KNUCKLE, KNUCKLE_H], atol=1e-12)
    np.testing.assert_allclose(j12.axis, [1, 0, 0])
    assert (j12.lower, j12.upper, j12.effort, j12.velocity) == (0.0, 2.44, 5.0, 1.0)
    assert j12.mimic_joint == "" and j13.mimic_joint == "bh_j12"
    assert j13.multiplier == pytest.approx(1 / 3) and j13.offset == 0.0
    assert not barrett.inertial("bh_palm").present                     # the bundled URDF has no <inertial>
    with pytest.raises(ValueError, match="no link 'nope'"):
        barrett.inertial("nope")


def test_urdf_inertial_read(tmp_path):
    urdf = SMALL_URDF.format(uri="package://barrett/meshes/bh_finger_prox.stl").replace(
        '<link name="palm">', '<link name="palm"><inertial><origin xyz="0.01 0 0.002" rpy="0 0 1.5707963267948966"/>'
        '<mass value="0.25"/><inertia ixx="1e-4" ixy="1e-6" ixz="0" iyy="2e-4" iyz="0" izz="3e-4"/></inertial>')
    (tmp_path / "small.urdf").write_text(urdf)
    spec = tmp_path / "small.json"
    spec.write_text(json.dumps(SMALL_SPEC))
    h = pg.load_hand(spec, package_paths=[str(MODELS)])
    i = h.inertial("palm")
    assert i.present and i.mass == 0.25
    np.testing.assert_allclose(i.frame[:3, 3], [0.01, 0, 0.002])
    np.testing.assert_allclose(i.frame[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-12)
    np.testing.assert_allclose(i.inertia, [[1e-4, 1e-6, 0], [1e-6, 2e-4, 0], [0, 0, 3e-4]])
    assert not h.inertial("finger").present
