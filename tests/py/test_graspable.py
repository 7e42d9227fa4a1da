"""Where a force-closure grasp can be (pairgrasp.graspable_faces): checked against facts worked out
by hand (a 1.5 m box, a sheet, a hand-sized cube) and, on random scenes, against an independent
linear program over densely sampled normals; then the planner's refusal, end to end."""
import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import pairgrasp as pg

ROOT = pathlib.Path(__file__).resolve().parents[2]
BARRETT = ROOT / "models" / "barrett" / "barrett.json"
JAW = ROOT / "models" / "parallel_jaw" / "parallel_jaw.json"
MU = 0.5
LIMIT = np.pi / 2 - np.arctan(MU)  # 63.4 degrees: the widest cone of inward normals with no force closure


def box(extents, centre=(0, 0, 0), name="box"):
    import trimesh

    t = trimesh.creation.box(extents=extents)
    t.apply_translation(centre)
    return pg.make_mesh(np.asarray(t.vertices, float), np.asarray(t.faces, np.int64), name)


def merged(*meshes):
    vs, fs, n = [], [], 0
    for m in meshes:
        vs.append(np.asarray(m.vertices))
        fs.append(np.asarray(m.faces) + n)
        n += len(m.vertices)
    return pg.make_mesh(np.vstack(vs), np.vstack(fs).astype(np.int64), "scene")


def test_a_box_far_larger_than_the_span_has_no_graspable_face():
    """A 1.5 x 0.8 x 0.8 m box and a span of 0.27 m: opposite faces are 0.8 m apart, and at a corner the
    three inward normals lie 54.7 degrees from the diagonal (arccos(1/sqrt(3))), inside 63.4."""
    g = pg.graspable_faces(box((1.5, 0.8, 0.8)), 0.27, MU)
    assert (g.free, g.graspable) == (12, 0) and not g.faces.any()
    assert np.degrees(g.widest_cone) >= 54.7 and g.widest_cone <= g.limit + 1e-9 and g.limit < LIMIT


def test_opposite_faces_within_the_span_are_graspable():
    """The same box with a span of 1 m (opposite 0.8 m faces in reach), and a 10 cm cube with 0.27 m."""
    assert pg.graspable_faces(box((1.5, 0.8, 0.8)), 1.0, MU).graspable == 12
    assert pg.graspable_faces(box((0.1, 0.1, 0.1)), 0.27, MU).graspable == 12


def test_friction_decides_the_corner():
    """A corner's normals spread 54.7 degrees from its diagonal: hopeless at mu = 0.5 (limit 63.4), not
    at mu = 1 (limit 45: a cone of 45 degrees about each normal reaches past the plane normal to the
    diagonal)."""
    big = box((1.5, 0.8, 0.8))
    assert pg.graspable_faces(big, 0.27, 0.5).graspable == 0
    assert pg.graspable_faces(big, 0.27, 1.0).graspable == 12
    # mu = 100: 90 - atan(100) = 0.6 degrees, below the binning margin: nothing is ruled out, not
    # even a sheet whose normals are all the same.
    sheet = pg.make_mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), np.array([[0, 1, 2]]), "sheet")
    assert pg.graspable_faces(sheet, 0.27, 100.0).graspable == 1


def test_a_flat_sheet_and_a_partly_reachable_scene():
    """A lone 1 m triangle holds no force-closure grasp; a 1.5 m box with a 4 cm post standing on its top
    keeps the post's faces and the top's, and loses its bottom (0.8 m from anything opposing it)."""
    sheet = pg.make_mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), np.array([[0, 1, 2]]), "sheet")
    assert pg.graspable_faces(sheet, 0.27, MU).graspable == 0
    base = box((1.5, 0.8, 0.8))
    post = box((0.04, 0.04, 0.1), centre=(0, 0, 0.45))
    scene = merged(base, post)
    g = pg.graspable_faces(scene, 0.27, MU)
    assert g.faces[12:].all()                                   # the post
    normals = np.cross(*(np.asarray(base.vertices)[np.asarray(base.faces)][:, 1:] -
                         np.asarray(base.vertices)[np.asarray(base.faces)][:, :1]).transpose(1, 0, 2))
    bottom = normals[:, 2] < -0.5
    top = normals[:, 2] > 0.5
    assert not g.faces[:12][bottom].any() and g.faces[:12][top].all()
    # A mask: only the post free leaves the post graspable; only the bottom free, nothing.
    only_post = np.r_[np.zeros(12, bool), np.ones(12, bool)]
    assert pg.graspable_faces(scene, 0.27, MU, free=only_post).graspable == 12
    assert pg.graspable_faces(scene, 0.27, MU, free=np.r_[bottom, np.zeros(12, bool)]).graspable == 0


def _dense_samples(mesh, spacing):
    """Points on every face at `spacing` (a barycentric grid) with the face's inward normal and id."""
    V, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    P, N, I = [], [], []
    for f, (a, b, c) in enumerate(V[F]):
        n = int(max(1, np.ceil(max(np.linalg.norm(b - a), np.linalg.norm(c - b), np.linalg.norm(a - c)) / spacing)))
        ij = np.array([(i, j) for i in range(n + 1) for j in range(n + 1 - i)], float) / n
        P.append(a + ij[:, :1] * (b - a) + ij[:, 1:] * (c - a))
        m = -np.cross(b - a, c - a)
        N.append(np.repeat((m / np.linalg.norm(m))[None], len(ij), 0))
        I.append(np.full(len(ij), f))
    return np.vstack(P), np.vstack(N), np.concatenate(I)


def _widest_cone_bound(normals):
    """The half angle of a cap holding every unit vector of `normals`, from a linear program (SciPy):
    maximise t subject to v.m >= t for every m, |v_k| <= 1. The angle acos(t / |v|) bounds the smallest
    enclosing cap from above."""
    from scipy.optimize import linprog

    m = np.unique(np.round(normals, 9), axis=0)
    res = linprog(c=[0, 0, 0, -1], A_ub=np.c_[-m, np.ones(len(m))], b_ub=np.zeros(len(m)),
                  bounds=[(-1, 1)] * 3 + [(None, None)], method="highs")
    v, t = res.x[:3], res.x[3]
    return np.arccos(np.clip(t / np.linalg.norm(v), -1, 1)) if t > 0 else np.pi


@pytest.mark.parametrize("seed", range(4))
def test_every_face_left_out_is_hopeless_by_an_independent_check(seed):
    """Random scenes of boxes 0.3-1.2 m, far apart and touching; for each face graspable_faces leaves
    out, every densely sampled point of it sees (within the span, exact distances) only normals that a
    linear program fits in a cap narrower than 90 deg - atan(mu): no force-closure grasp touches it."""
    rng = np.random.default_rng(seed)
    parts = [box(rng.uniform(0.3, 1.2, 3), centre=rng.uniform(-0.8, 0.8, 3)) for _ in range(3)]
    scene = merged(*parts)
    span = float(rng.uniform(0.15, 0.35))
    g = pg.graspable_faces(scene, span, MU)
    P, N, I = _dense_samples(scene, span / 10)
    out = np.flatnonzero(~g.faces)
    assert 0 < g.graspable < len(g.faces)
    for f in out:
        for p in P[I == f][:: max(1, int(np.sum(I == f)) // 40)]:
            near = np.linalg.norm(P - p, axis=1) <= span
            assert _widest_cone_bound(N[near]) < LIMIT, (seed, f, p)


def test_bad_arguments_are_value_errors():
    m = box((0.1, 0.1, 0.1))
    for kw, word in [(dict(span=0.0), "span"), (dict(span=float("nan")), "span"), (dict(span=0.2, mu=-1), "mu"),
                     (dict(span=0.2, mu=float("inf")), "mu"), (dict(span=0.2, free=np.ones(3, bool)), "free")]:
        with pytest.raises(ValueError, match=word):
            pg.graspable_faces(m, **kw)


def test_the_planner_refuses_a_target_with_nothing_graspable_at_once(tmp_path):
    """The Barrett hand and a 1.5 m box (it planned 3.5 minutes for nothing before): a ValueError from
    the Python API naming mu, and from the CLI one `pairgrasp: error:` line, exit status 1 and nothing
    written; the jaw plans on the 10 cm cube with its setup reporting every face graspable."""
    big = box((1.5, 0.8, 0.8), name="big_box")
    with pytest.raises(ValueError, match=r"no part of the free surface can hold a force-closure grasp.*mu = 0\.5"):
        pg.Planner(str(BARRETT), big)
    path = tmp_path / "big.stl"
    import trimesh

    trimesh.creation.box(extents=(1.5, 0.8, 0.8)).export(path)
    r = subprocess.run([sys.executable, "-m", "pairgrasp", "plan", "--hand", str(BARRETT), "--target", str(path),
                        "--pictures", "0", "-o", str(tmp_path / "out")], capture_output=True, text=True, cwd=ROOT,
                       env=dict(os.environ), timeout=300)
    errors = [ln for ln in r.stderr.splitlines() if ln.startswith("pairgrasp: error:")]
    assert r.returncode != 0 and len(errors) == 1 and "force-closure" in errors[0], r.stderr
    assert not (tmp_path / "out").exists()
    setup = pg.resolve_planner(pg.load_hand(str(JAW)), box((0.1, 0.1, 0.1)))
    assert setup.free_faces == setup.graspable_faces == 12 and setup.contact_span > 0


def test_a_search_may_not_raise_the_planners_friction():
    """A plan's mu above the planner's would need surface the index left out: a ValueError naming mu;
    a lower one is served."""
    planner = pg.Planner(str(JAW), box((0.04, 0.04, 0.04)), step=0.02, top=1, fine_tune=0)
    with pytest.raises(ValueError, match="mu"):
        planner.plan(progress=False, mu=0.8)
    assert planner.plan(progress=False, mu=0.3).params.mu == 0.3
    with pytest.raises(ValueError, match="mu"):
        pg.Planner(str(JAW), box((0.04, 0.04, 0.04)), mu=-0.1)


def test_the_cli_takes_mu_and_records_it(tmp_path):
    """`plan --mu 0.3` plans with it (grasps.json's parameters); a negative mu is one error line."""
    r = subprocess.run([sys.executable, "-m", "pairgrasp", "plan", "--hand", str(JAW), "--target",
                        str(ROOT / "models" / "targets" / "box.stl"), "--mu", "0.3", "--top", "1", "--pictures", "0",
                        "--quiet", "-o", str(tmp_path / "out")], capture_output=True, text=True, cwd=ROOT,
                       env=dict(os.environ), timeout=300)
    assert r.returncode == 0, r.stderr
    assert json.loads((tmp_path / "out" / "grasps.json").read_text())["parameters"]["mu"] == 0.3
    bad = subprocess.run([sys.executable, "-m", "pairgrasp", "plan", "--hand", str(JAW), "--target",
                          str(ROOT / "models" / "targets" / "box.stl"), "--mu", "-1", "-o", str(tmp_path / "bad")],
                         capture_output=True, text=True, cwd=ROOT, env=dict(os.environ), timeout=300)
    assert bad.returncode != 0 and bad.stderr.count("pairgrasp: error:") == 1 and "--mu" in bad.stderr
