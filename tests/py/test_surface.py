"""Unit facets, pair features and the PairIndex, checked against NumPy computations."""
import concurrent.futures
import gc
import pathlib
import re

import numpy as np
import pytest

import pairgrasp as pg

MODELS = pathlib.Path(__file__).resolve().parents[2] / "models"
TARGETS = ["box", "mug", "flask"]


# ---------------------------------------------------------------- meshes from dimensions
def box_mesh(a, b, c):
    v = np.array([[(k & 1) * a, ((k >> 1) & 1) * b, ((k >> 2) & 1) * c] for k in range(8)], float)
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    f = [t for q in quads for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]
    return pg.make_mesh(v, np.array(f), "box")


def fan_cylinder(r, h, seg):
    """Closed cylinder whose caps are fans of slivers around the centre."""
    t = 2 * np.pi * np.arange(seg) / seg
    ring = np.c_[r * np.cos(t), r * np.sin(t)]
    v = np.vstack([np.c_[ring, np.zeros(seg)], np.c_[ring, np.full(seg, h)], [[0, 0, 0], [0, 0, h]]])
    k = np.arange(seg)
    k1 = (k + 1) % seg
    bottom, top = 2 * seg, 2 * seg + 1
    f = np.vstack([np.c_[k, k1, k1 + seg], np.c_[k, k1 + seg, k + seg],
                   np.c_[np.full(seg, bottom), k1, k], np.c_[np.full(seg, top), k + seg, k1 + seg]])
    return pg.make_mesh(v, f, "fan_cylinder")


def icosphere(r, level):
    t = (1 + 5 ** 0.5) / 2
    v = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
         [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    v = [np.array(p, float) / np.linalg.norm(p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    for _ in range(level):
        mid = {}

        def m(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                p = v[a] + v[b]
                v.append(p / np.linalg.norm(p))
                mid[key] = len(v) - 1
            return mid[key]

        f = [g for (a, b, c) in f for g in ((a, m(a, b), m(c, a)), (b, m(b, c), m(a, b)), (c, m(c, a), m(b, c)),
                                             (m(a, b), m(b, c), m(c, a)))]
    return pg.make_mesh(r * np.array(v), np.array(f), "icosphere")


def face_geometry(mesh):
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    length = np.linalg.norm(cross, axis=1)
    return 0.5 * length, cross / length[:, None]


def cv(x):
    return np.std(x) / np.mean(x)


def check_facets(mesh, facets, paint=None):
    area, normal = face_geometry(mesh)
    ids = np.asarray(facets.face_ids)
    assert len(facets) == len(ids) > 0
    assert np.allclose(np.linalg.norm(facets.normals, axis=1), 1, atol=1e-12)
    assert np.abs(facets.normals - normal[ids]).max() < 1e-12
    # centres on the source face's plane
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    assert np.abs(np.sum((facets.points - v[f[ids, 0]]) * normal[ids], axis=1)).max() < 1e-12
    assert abs(facets.areas.sum() - area.sum()) <= 1e-9 * area.sum()
    assert np.all(facets.areas > 0)
    expected_free = np.ones(len(ids), bool) if paint is None else np.asarray(paint)[ids]
    assert np.array_equal(facets.free, expected_free)


# ---------------------------------------------------------------- tessellation
@pytest.mark.parametrize("name", TARGETS)
def test_bundled_targets_even_areas_with_paint(name):
    mesh = pg.load_mesh(str(MODELS / "targets" / f"{name}.stl"))
    paint = pg.load_paint(str(MODELS / "targets" / f"{name}.paint.json"), mesh)
    extent = np.ptp(np.asarray(mesh.vertices), axis=0).max()
    facets = pg.tessellate(mesh, extent / 40, free=paint)
    check_facets(mesh, facets, paint)
    assert cv(facets.areas) <= 0.3
    area, _ = face_geometry(mesh)
    free_area = area[np.asarray(paint, bool)].sum()
    assert facets.areas[facets.free].sum() == pytest.approx(free_area, rel=1e-9)


@pytest.mark.parametrize("make", [lambda: box_mesh(0.1, 0.06, 0.04), lambda: fan_cylinder(0.03, 0.1, 96),
                                  lambda: icosphere(0.05, 0), lambda: icosphere(0.05, 3)],
                         ids=["box", "fan_cylinder", "icosahedron", "icosphere"])
def test_shapes_even_areas(make):
    mesh = make()
    facets = pg.tessellate(mesh, 0.006)
    check_facets(mesh, facets)
    assert cv(facets.areas) <= 0.3
    assert facets.edge == 0.006
    # about one facet per (sqrt(3)/2) h^2
    expected = face_geometry(mesh)[0].sum() / (np.sqrt(3) / 2 * 0.006 ** 2)
    assert 0.75 * expected < len(facets) < 1.25 * expected


def test_fan_caps_keep_their_area():
    mesh = fan_cylinder(0.03, 0.1, 96)
    facets = pg.tessellate(mesh, 0.005)
    cap = 0.5 * 96 * 0.03 ** 2 * np.sin(2 * np.pi / 96)
    top = facets.normals[:, 2] > 0.999
    assert facets.areas[top].sum() == pytest.approx(cap, rel=1e-12)
    assert cv(facets.areas[top]) <= 0.3


def test_deterministic_and_views():
    mesh = icosphere(0.04, 2)
    a, b = pg.tessellate(mesh, 0.006), pg.tessellate(mesh, 0.006)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.areas, b.areas)
    assert not a.points.flags.writeable
    assert np.shares_memory(a.points, a.points[:])
    assert np.shares_memory(a.areas, a.areas) and a.points.base is not None
    pts = a.points
    expected = np.array(pts)
    del a
    gc.collect()
    assert np.array_equal(pts, expected)  # the view keeps the facets alive


def test_tessellate_bad_input():
    mesh = box_mesh(0.1, 0.1, 0.1)
    for edge in (0.0, -0.01, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="edge"):
            pg.tessellate(mesh, edge)
    with pytest.raises(ValueError, match="free: expected 12 values, got 5"):
        pg.tessellate(mesh, 0.01, free=np.ones(5, bool))
    with pytest.raises(ValueError, match="free"):
        pg.tessellate(mesh, 0.01, free=np.full(12, 2))
    with pytest.raises(ValueError, match=r"smallest edge that fits is about ([0-9.e-]+) m") as err:
        pg.tessellate(mesh, 0.0005, max_facets=1000)
    fit = float(re.search(r"fits is about ([0-9.e-]+) m", str(err.value)).group(1))
    assert len(pg.tessellate(mesh, fit, max_facets=1000)) <= 1000


# ---------------------------------------------------------------- features
def reference_features(P, N, i, j):
    """Eq. 9-12 term by term: beta_ij = n_i.(p_i - p_j)/d, beta_ji = n_j.(p_j - p_i)/d."""
    dv = P[i] - P[j]
    d = np.linalg.norm(dv, axis=1)
    return np.c_[d, np.sum(N[i] * N[j], 1), np.sum(N[i] * dv, 1) / d + np.sum(N[j] * -dv, 1) / d]


def sphere_cloud(n, seed, radius=0.05):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    P = radius * d * (1 + 0.05 * rng.normal(size=(n, 1)))
    N = d + 0.3 * rng.normal(size=(n, 3))
    return P, N / np.linalg.norm(N, axis=1, keepdims=True)


def test_pair_feature_definition_and_symmetry():
    P, N = sphere_cloud(200, 1)
    i, j = np.triu_indices(200, 1)
    e = pg.pair_feature(P[i], N[i], P[j], N[j])
    assert np.abs(e - reference_features(P, N, i, j)).max() < 1e-12
    assert np.array_equal(e, pg.pair_feature(P[j], N[j], P[i], N[i]))  # symmetric, bit for bit
    assert np.allclose(pg.pair_feature([0, 0, 0], [1, 0, 0], [0.03, 0.04, 0], [0, 1, 0]), [0.05, 0, 0.2])
    assert np.array_equal(pg.pair_feature([1, 1, 1], [1, 0, 0], [1, 1, 1], [0, 1, 0]), [0, 0, 0])
    with pytest.raises(ValueError):
        pg.pair_feature([0, 0, 0], [2, 0, 0], [1, 0, 0], [0, 1, 0])
    with pytest.raises(ValueError):
        pg.pair_feature([0, 0], [1, 0, 0], [1, 0, 0], [0, 1, 0])


# ---------------------------------------------------------------- pair index
def brute_pairs(P, d_max, free=None):
    """Sorted keys i * N + j of the pairs i < j with d <= d_max (both free)."""
    i, j = np.triu_indices(len(P), 1)
    keep = np.linalg.norm(P[i] - P[j], axis=1) <= d_max
    if free is not None:
        keep &= free[i] & free[j]
    return i[keep].astype(np.int64) * len(P) + j[keep]


def pair_keys(idx, n):
    pairs = np.asarray(idx.pairs).astype(np.int64)
    return np.sort(pairs[:, 0] * n + pairs[:, 1])


def check_queries(idx, rng, count=80):
    feats = np.asarray(idx.features)
    base = np.array([0.0025, 0.05, 0.05])
    for q in range(count):
        c = feats[rng.integers(len(feats))].astype(float)
        kind = q % 5
        if kind == 0:
            tol = base * np.exp(rng.normal())
            c = c + rng.normal(size=3) * tol
        elif kind == 1:
            tol = np.zeros(3)
        elif kind == 2:
            tol = base
            c = c + [10.0, 5.0, 9.0]
        elif kind == 3:
            tol = np.full(3, 1e6)
        else:  # a stored feature right on a face of the box
            tol = base * np.exp(rng.normal())
            c[q % 3] += tol[q % 3] * (1 if q % 2 else -1)
        got = idx.query(c, tol)
        brute = np.nonzero(np.all(np.abs(feats - c) <= tol, axis=1))[0]
        assert got.dtype == np.int64
        assert np.array_equal(got, brute), f"kind {kind}"  # same set, in increasing order
        assert idx.count(c, tol) == len(brute)
        if kind == 1:
            assert len(brute) >= 1
        if kind == 2:
            assert len(brute) == 0
        if kind == 3:
            assert len(brute) == len(idx)


@pytest.mark.parametrize("d_max", [0.01, 0.04, 0.2])
def test_index_pairs_features_queries_vs_brute_force(d_max):
    P, N = sphere_cloud(500, 2)
    idx = pg.PairIndex(P, N, d_max=d_max)
    pairs = np.asarray(idx.pairs)
    assert pairs.dtype == np.int32 and idx.features.dtype == np.float32
    assert np.array_equal(pair_keys(idx, len(P)), brute_pairs(P, d_max))
    assert len(idx) == len(pairs) == pg.count_pairs(P, d_max)
    assert np.all(pairs[:, 0] < pairs[:, 1])
    ref = reference_features(P, N, pairs[:, 0], pairs[:, 1])
    assert np.abs(idx.features - ref).max() < 1e-6
    assert idx.d_max == d_max
    check_queries(idx, np.random.default_rng(3))


def test_index_on_real_facets():
    mesh = pg.load_mesh(str(MODELS / "targets" / "mug.stl"))
    paint = pg.load_paint(str(MODELS / "targets" / "mug.paint.json"), mesh)
    facets = pg.tessellate(mesh, 0.008, free=paint)
    assert not facets.free.all()
    idx = pg.PairIndex(facets.points, facets.normals, d_max=0.06, free=facets.free)
    assert np.array_equal(pair_keys(idx, len(facets)), brute_pairs(facets.points, 0.06, facets.free))
    assert np.array_equal(idx.free, facets.free)
    check_queries(idx, np.random.default_rng(4), count=60)


def random_rotation(rng):
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


@pytest.mark.parametrize("seed", range(4))
def test_features_invariant_under_rigid_motion(seed):
    rng = np.random.default_rng(seed)
    P, N = sphere_cloud(300, 10 + seed)
    a = pg.PairIndex(P, N, d_max=0.05)
    R, t = random_rotation(rng), rng.normal(size=3)
    b = pg.PairIndex(P @ R.T + t, N @ R.T, d_max=0.05)
    def by_pair(idx):
        pairs = np.asarray(idx.pairs).astype(np.int64)
        order = np.argsort(pairs[:, 0] * 300 + pairs[:, 1])
        return pairs[order], np.asarray(idx.features)[order]

    (pa, fa), (pb, fb) = by_pair(a), by_pair(b)
    assert np.array_equal(pa, pb)
    assert np.abs(fa - fb).max() < 2e-6


def test_views_are_zero_copy_and_keep_the_index_alive():
    P, N = sphere_cloud(100, 5)
    idx = pg.PairIndex(P, N, d_max=0.1)
    assert np.shares_memory(idx.features, idx.features) and not idx.pairs.flags.writeable
    f = idx.features
    expected = np.array(f)
    del idx
    gc.collect()
    assert np.array_equal(f, expected)


def test_spacing_nbytes_and_small_cases():
    x, y = np.meshgrid(np.arange(30) * 0.004, np.arange(20) * 0.004)
    P = np.c_[x.ravel(), y.ravel(), np.zeros(600)]
    N = np.tile([0.0, 0.0, 1.0], (600, 1))
    idx = pg.PairIndex(P, N, d_max=0.01)
    assert idx.spacing == pytest.approx(0.004, abs=1e-12)
    assert 28 * len(idx) <= idx.nbytes <= 34 * len(idx) + 49 * 600 + 4096
    one = pg.PairIndex(P[:1], N[:1], d_max=0.01)
    assert len(one) == 0 and one.pairs.shape == (0, 2) and one.features.shape == (0, 3)
    assert len(one.query([0.0, 0.0, 0.0], [1.0, 1.0, 1.0])) == 0
    none = pg.PairIndex(P, N, d_max=0.01, free=np.zeros(600, bool))
    assert len(none) == 0


def test_budget_refusal_names_what_fits():
    P, N = sphere_cloud(1000, 6)
    with pytest.raises(ValueError, match="499500 pairs") as err:
        pg.PairIndex(P, N, d_max=0.2, max_pairs=100_000)
    fit = int(re.search(r"about (\d+) facets would fit", str(err.value)).group(1))
    assert fit * (fit - 1) // 2 <= 100_000 < (fit + 2) * (fit + 1) // 2
    assert len(pg.PairIndex(P[:fit], N[:fit], d_max=0.2, max_pairs=100_000)) <= 100_000


def test_suggest_edge_and_build_target_index():
    mesh = icosphere(0.05, 3)
    edge = pg.suggest_edge(mesh, d_max=0.2, max_pairs=200_000)
    facets = pg.tessellate(mesh, edge)
    assert pg.count_pairs(facets.points, 0.2) <= 200_000
    finer = pg.tessellate(mesh, edge / 1.05)
    assert pg.count_pairs(finer.points, 0.2) > 200_000
    target = pg.build_target_index(mesh, d_max=0.2, max_pairs=200_000)
    assert target.facets.edge == edge and len(target.index) == pg.count_pairs(facets.points, 0.2)
    fixed = pg.build_target_index(mesh, edge=0.01, d_max=0.05)
    assert fixed.facets.edge == 0.01 and fixed.index.d_max == 0.05


def test_index_bad_input():
    P, N = sphere_cloud(10, 7)
    with pytest.raises(ValueError, match="points: expected shape"):
        pg.PairIndex(P[:, :2], N)
    with pytest.raises(ValueError, match="normals"):
        pg.PairIndex(P, N[:9])
    with pytest.raises(ValueError, match="normals: row 0"):
        pg.PairIndex(P, 2 * N)
    bad = P.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="points: row 3"):
        pg.PairIndex(bad, N)
    for d in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="d_max"):
            pg.PairIndex(P, N, d_max=d)
    with pytest.raises(ValueError, match="free: expected 10 values, got 3"):
        pg.PairIndex(P, N, free=np.ones(3, bool))
    idx = pg.PairIndex(P, N)
    with pytest.raises(ValueError, match="feature"):
        idx.query([0.0, 0.0], [1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="tolerance"):
        idx.query([0.0, 0.0, 0.0], [1.0, -1.0, 1.0])
    with pytest.raises(ValueError, match="center"):
        idx.query([np.nan, 0.0, 0.0], [1.0, 1.0, 1.0])


def test_concurrent_builds_agree():
    """Builds run without the GIL on several Python threads and give identical indexes."""
    P, N = sphere_cloud(1500, 8)
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        a, b = pool.map(lambda _: pg.PairIndex(P, N, d_max=0.05, threads=1), range(2))
    assert np.array_equal(a.pairs, b.pairs) and np.array_equal(a.features, b.features)


# ---------------------------------------------------------------- thinning of dense feature cells
CELL_ORIGIN = np.array([0.0, -1.0, -2.0])  # (d, n_i.n_j, beta) at the corner of the first cell


def cell_keys(features, cell, d_max):
    """The flat cell number of each feature, by the cell grid PairIndexOptions::cell documents: cells of
    `cell` from (0, -1, -2) over d in [0, d_max], n_i.n_j in [-1, 1], beta in [-2, 2], clamped at the ends."""
    inv = 1.0 / np.asarray(cell, float)
    dims = np.floor(np.array([d_max, 2.0, 4.0]) * inv).astype(np.int64) + 1
    c = np.floor((np.asarray(features, np.float32).astype(float) - CELL_ORIGIN) * inv).astype(np.int64)
    c = np.clip(c, 0, dims - 1)
    return (c[:, 0] * dims[1] + c[:, 1]) * dims[2] + c[:, 2]


def plane_grid(n, step):
    x, y = np.meshgrid(np.arange(n) * step, np.arange(n) * step)
    P = np.c_[x.ravel(), y.ravel(), np.zeros(n * n)]
    return P, np.tile([0.0, 0.0, 1.0], (n * n, 1))


@pytest.mark.parametrize("cap", [50, 400])
def test_thinning_keeps_a_share_of_each_dense_cell_and_weighs_it(cap):
    """On a plane every pair has n_i.n_j = 1 and beta = 0, so the pairs differ by distance alone and
    a few cells hold them all. Against a NumPy histogram of every pair's cell: each stored pair
    carries ceil(c / cap) of its cell of c pairs (1 when c <= cap), the pairs kept are a subset of all,
    each dense cell keeps about c / w of its pairs, and the weights add up to the pairs found."""
    P, N = plane_grid(40, 0.004)
    d_max = 0.05
    full = pg.PairIndex(P, N, d_max=d_max)
    ref = reference_features(P, N, full.pairs[:, 0], full.pairs[:, 1])
    assert np.abs(full.features - ref).max() < 1e-6
    thin = pg.PairIndex(P, N, d_max=d_max, max_pairs_per_cell=cap)
    assert thin.max_pairs_per_cell == cap and full.max_pairs_per_cell == 0 and full.thin_cell is None
    h = thin.spacing
    assert thin.thin_cell == pytest.approx((0.5 * h, 0.1, 0.1))  # the aligner's default tolerance box
    assert thin.pairs_found == len(full) == pg.count_pairs(P, d_max)

    keys_all = cell_keys(full.features, thin.thin_cell, d_max)
    cells, counts = np.unique(keys_all, return_counts=True)
    expected_w = dict(zip(cells.tolist(), np.where(counts > cap, -(-counts // cap), 1).tolist()))
    assert counts.max() > 4 * cap  # the plane's cells are dense: this case thins

    n = len(P)
    full_keys = np.asarray(full.pairs).astype(np.int64) @ [n, 1]
    thin_keys = np.asarray(thin.pairs).astype(np.int64) @ [n, 1]
    assert np.isin(thin_keys, full_keys).all() and len(np.unique(thin_keys)) == len(thin)
    tk = cell_keys(thin.features, thin.thin_cell, d_max)
    w = thin.weights
    assert w.dtype == np.int64 and len(w) == len(thin)
    assert np.array_equal(w, [expected_w[k] for k in tk.tolist()])
    for cell, c in zip(cells, counts):
        kept = int(np.sum(tk == cell))
        wc = expected_w[int(cell)]
        if wc == 1:
            assert kept == c  # sparse cells are whole
        else:  # binomial(c, 1 / wc): within five standard deviations of c / wc
            mean = c / wc
            assert abs(kept - mean) <= 5 * np.sqrt(mean) + 1
    assert len(thin) < 0.5 * len(full)
    # unbiased: each cell's weighted count has mean c and variance c (w - 1); within five deviations
    wc = np.array([expected_w[int(c)] for c in cells])
    assert abs(w.sum() - thin.pairs_found) <= 5 * np.sqrt(np.sum(counts * (wc - 1))) + 1
    # the stored features are still the pairs' own
    ref = reference_features(P, N, thin.pairs[:, 0], thin.pairs[:, 1])
    assert np.abs(thin.features - ref).max() < 1e-6
    assert thin.nbytes < full.nbytes
    check_queries(thin, np.random.default_rng(cap), count=40)


def test_thinning_off_or_above_every_cell_stores_every_pair():
    P, N = sphere_cloud(800, 12)
    full = pg.PairIndex(P, N, d_max=0.05)
    off = pg.PairIndex(P, N, d_max=0.05, max_pairs_per_cell=0)
    assert np.array_equal(full.pairs, off.pairs) and np.array_equal(full.features, off.features)
    assert np.all(full.weights == 1) and full.pairs_found == len(full)
    high = pg.PairIndex(P, N, d_max=0.05, max_pairs_per_cell=len(full))  # no cell holds more
    assert np.array_equal(pair_keys(high, 800), pair_keys(full, 800)) and np.all(high.weights == 1)


def test_thinning_weights_sum_and_determinism_on_a_varied_cloud():
    """A noisy sphere's pairs spread over many cells: the weighted count stays within a few per cent of
    the pairs found, and the kept pairs do not depend on the number of threads (a hash of the pair
    chooses them, not the build's order)."""
    P, N = sphere_cloud(3000, 13)
    one = pg.PairIndex(P, N, d_max=0.03, max_pairs_per_cell=20, cell=(0.004, 0.2, 0.2), threads=1)
    two = pg.PairIndex(P, N, d_max=0.03, max_pairs_per_cell=20, cell=(0.004, 0.2, 0.2), threads=2)
    assert one.thin_cell == pytest.approx((0.004, 0.2, 0.2))
    assert np.array_equal(one.pairs, two.pairs) and np.array_equal(one.weights, two.weights)
    assert one.pairs_found == pg.count_pairs(P, 0.03)
    assert len(one) < 0.7 * one.pairs_found
    assert abs(one.weights.sum() - one.pairs_found) < 0.03 * one.pairs_found


def test_thinning_bad_input():
    P, N = sphere_cloud(50, 14)
    with pytest.raises(ValueError, match="max_pairs_per_cell"):
        pg.PairIndex(P, N, max_pairs_per_cell=-1)
    for cell in ((0.0, 0.1, 0.1), (0.001, -0.1, 0.1), (np.nan, 0.1, 0.1), (np.inf, 0.1, 0.1)):
        with pytest.raises(ValueError, match="cell"):
            pg.PairIndex(P, N, max_pairs_per_cell=10, cell=cell)
    with pytest.raises(ValueError, match="cell"):
        pg.PairIndex(P, N, max_pairs_per_cell=10, cell=(0.1, 0.1))
