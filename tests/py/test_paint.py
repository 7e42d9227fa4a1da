"""Bundled targets and paint files through the Python API: pairgrasp.load_mesh, load_paint,
save_paint, apply_regions, PaintRegion. Expected values come from the dimensions documented in
models/README.md, computed here independently of the meshes."""
import json
import math
from pathlib import Path

import numpy as np
import pytest

import pairgrasp as pg

TARGETS = Path(__file__).resolve().parents[2] / "models" / "targets"


def load(name):
    return pg.load_mesh(str(TARGETS / f"{name}.stl"))


def centroids(m):
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    return v[f].mean(axis=1)


def areas(m):
    t = np.asarray(m.vertices)[np.asarray(m.faces)]
    return 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)


def polygon_factor(n):
    return n / (2 * math.pi) * math.sin(2 * math.pi / n)


@pytest.fixture(scope="module")
def meshes():
    return {n: load(n) for n in ("box", "mug", "flask")}


@pytest.fixture(scope="module")
def cube():
    """Unit cube [0,1]^3, two triangles per side, outward winding."""
    v = np.array([[i & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], float)
    f = np.array([[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
                  [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]], np.int32)
    m = pg.make_mesh(v, f, "cube")
    assert np.array_equal(np.asarray(m.faces), f)  # clean input: faces kept as given
    return m


# ----------------------------------------------------------------------------- targets

def test_targets_are_closed_hand_sized_on_the_floor_with_increasing_face_counts(meshes):
    counts = []
    for name in ("box", "mug", "flask"):
        m = meshes[name]
        v = np.asarray(m.vertices)
        assert m.closed, name
        assert m.volume > 0, name
        ext = np.ptp(v, axis=0)
        assert 0.02 < ext.max() < 0.5, (name, ext)
        assert abs(v[:, 2].min()) < 1e-7, name
        # every face of the file kept: the binary STL header holds the triangle count
        header = (TARGETS / f"{name}.stl").read_bytes()[80:84]
        assert len(m.faces) == int.from_bytes(header, "little"), name
        counts.append(len(m.faces))
    assert counts == sorted(counts) and len(set(counts)) == 3, counts


def test_box_volume_is_the_product_of_its_sides(meshes):
    assert meshes["box"].volume == pytest.approx(0.06 * 0.06 * 0.12, rel=1e-3)


def flask_radius(z):
    """Outer radius at heights z from the documented profile (fillets solved here)."""
    rb, rn, zs, fb, fs, b, h = 0.040, 0.014, 0.100, 0.006, 0.040, 0.003, 0.150
    # unit normal of the cone line, pointing out of the solid
    n = np.array([zs, rb - rn]) / math.hypot(zs, rb - rn)
    # base fillet centre (cr, fb): distance fb from the cone line, inside
    cr = rb - fb * (1 + n[1]) / n[0]
    z1 = fb + fb * n[1]
    # shoulder fillet centre (rn + fs, cz): distance fs from the cone line, outside
    cz = zs + fs * (1 - n[0]) / n[1]
    z2 = cz - fs * n[1]
    z = np.asarray(z, float)
    return np.select(
        [z <= z1, z <= z2, z <= cz, z <= h - 2 * b],
        [cr + np.sqrt(np.clip(fb**2 - (z - fb) ** 2, 0, None)),
         rb + (rn - rb) * z / zs,
         rn + fs - np.sqrt(np.clip(fs**2 - (z - cz) ** 2, 0, None)),
         np.full_like(z, rn)],
        rn + np.sqrt(np.clip(b**2 - (z - (h - b)) ** 2, 0, None)))


def test_flask_volume_matches_its_revolved_profile(meshes):
    n = 200_000
    z = (np.arange(n) + 0.5) * (0.150 / n)
    solid = np.sum(math.pi * flask_radius(z) ** 2) * (0.150 / n)
    mouth = math.pi * 0.010**2 * 0.025
    expected = polygon_factor(80) * (solid - mouth)
    assert meshes["flask"].volume == pytest.approx(expected, rel=0.005)


def test_mug_volume_matches_a_grid_estimate_of_its_shape(meshes):
    s = 0.0005
    x = np.arange(-0.042 + s / 2, 0.086, s)
    y = np.arange(-0.042 + s / 2, 0.042, s)
    X, Y = np.meshgrid(x, y, indexing="ij")
    R = np.hypot(X, Y)
    count = 0
    for z in np.arange(s / 2, 0.105, s):
        body = (R <= 0.040) & (z <= 0.100)
        handle = np.hypot(np.hypot(X - 0.050, z - 0.050) - 0.028, Y) <= 0.006
        cavity = (R < 0.0355) & (z > 0.006)
        rim = np.hypot(R - 0.03775, z - 0.100) <= 0.003
        count += np.count_nonzero(((body | handle) & ~cavity) | rim)
    expected = count * s**3
    assert meshes["mug"].volume == pytest.approx(expected, rel=0.01)
    assert meshes["mug"].volume < 0.5 * math.pi * 0.04**2 * 0.1  # hollow


# ----------------------------------------------------------------------------- bundled paint

def test_flask_paint_occludes_the_neck_top_and_only_there(meshes):
    m = meshes["flask"]
    free = pg.load_paint(str(TARGETS / "flask.paint.json"), m)
    assert free.dtype == np.bool_ and free.shape == (len(m.faces),)
    c = centroids(m)
    r = np.hypot(c[:, 0], c[:, 1])
    occ = ~free
    assert occ.sum() > 0
    assert (c[occ, 2] >= 0.12).all()            # occluded only at the neck top
    assert free[c[:, 2] < 0.12].all()           # everything lower, the base included, is free
    assert occ[c[:, 2] >= 0.140].all()          # the whole lip
    assert occ[(r < 0.0101) & (c[:, 2] >= 0.124)].all()  # the mouth
    assert free[(c[:, 2] < 0.140) & (r > 0.0101)].all()  # the neck's outside below the lip
    a = areas(m)
    # by hand: mouth wall + floor + top annulus + bead (Pappus) + neck strip 0.140..0.144
    expected = (2 * math.pi * 0.010 * 0.025 + math.pi * 0.010**2 + math.pi * (0.014**2 - 0.010**2)
                + 2 * math.pi * 0.003 * (math.pi * 0.014 + 2 * 0.003) + 2 * math.pi * 0.014 * 0.004)
    assert 0.99 * expected < a[occ].sum() < 1.05 * expected


@pytest.mark.parametrize("name,base", [("box", 0.06 * 0.06),
                                       ("mug", 0.5 * 64 * 0.04**2 * math.sin(2 * math.pi / 64))])
def test_box_and_mug_paint_occlude_the_face_they_stand_on(meshes, name, base):
    m = meshes[name]
    free = pg.load_paint(str(TARGETS / f"{name}.paint.json"), m)
    on_floor = (np.asarray(m.vertices)[np.asarray(m.faces)][:, :, 2] == 0.0).all(axis=1)
    assert np.array_equal(free, ~on_floor)
    assert areas(m)[~free].sum() == pytest.approx(base, rel=1e-3)


# ----------------------------------------------------------------------------- regions

def test_regions_mark_centroids_in_order(cube):
    c = centroids(cube)
    half = pg.apply_regions(cube, [pg.PaintRegion.halfspace([0, 0, 0.5], [0, 0, -2], "occluded")])
    assert np.array_equal(half, c[:, 2] > 0.5) and half.sum() == 6
    # dicts in the paint-file form work too; later regions override earlier ones
    both = pg.apply_regions(cube, [
        {"shape": "halfspace", "point": [0, 0, 0.5], "normal": [0, 0, -1], "mark": "occluded"},
        {"shape": "box", "min": [-1, -1, -1], "max": [2, 2, 0], "mark": "free", "comment": "floor"}])
    assert both.sum() == 8 and both[0] and both[1]
    start = np.zeros(12, bool)
    start[0] = True
    sph = pg.apply_regions(cube, [pg.PaintRegion.sphere([1, 0.5, 0.5], 0.5, True)], start)
    assert np.flatnonzero(sph).tolist() == [0, 10, 11]
    cyl = pg.apply_regions(cube, [{"shape": "cylinder", "start": [0.5, 0.5, -1], "end": [0.5, 0.5, 0.5],
                                   "radius": 0.3, "mark": "occluded"}])
    assert np.flatnonzero(~cyl).tolist() == [0, 1]
    r = pg.PaintRegion.cylinder([0, 0, 0], [0, 0, 1], 0.1, "free")
    assert r.contains([0.05, 0, 0.5]) and not r.contains([0.05, 0, 1.01]) and not r.contains([0.2, 0, 0.5])
    assert pg.PaintRegion.from_dict(r.to_dict()).to_dict() == r.to_dict()


@pytest.mark.parametrize("make,needle", [
    (lambda: pg.PaintRegion.sphere([0, 0, 0], 0.0), "radius"),
    (lambda: pg.PaintRegion.sphere([0, 0, math.nan], 1.0), "center"),
    (lambda: pg.PaintRegion.halfspace([0, 0, 0], [0, 0, 0]), "normal"),
    (lambda: pg.PaintRegion.box([0, 0, 1], [1, 1, 0]), "min"),
    (lambda: pg.PaintRegion.cylinder([0, 0, 1], [0, 0, 1], 0.1), "end"),
    (lambda: pg.PaintRegion.sphere([0, 0, 0], 1.0, "hidden"), "mark"),
    (lambda: pg.PaintRegion.from_dict({"shape": "cone", "mark": "free"}), "region.shape"),
    (lambda: pg.PaintRegion.from_dict({"shape": "sphere", "center": [0, 0], "radius": 1, "mark": "free"}),
     "region.center"),
    (lambda: pg.PaintRegion.from_dict({"shape": "sphere", "center": [0, 0, 0], "radius": "1", "mark": "free"}),
     "region.radius"),
    (lambda: pg.PaintRegion.from_dict({"shape": "sphere", "center": [0, 0, 0], "radius": 1}), "region.mark"),
    (lambda: pg.PaintRegion.from_dict({"shape": "box", "min": [0, 0, 0], "max": [1, 1, 1], "radius": 1,
                                       "mark": "free"}), "region.radius: unknown key"),
])
def test_bad_regions_raise_value_error_naming_the_field(make, needle):
    with pytest.raises(ValueError, match=needle.replace(".", r"\.")):
        make()


def test_apply_regions_checks_its_arguments(cube):
    with pytest.raises(ValueError, match="start: expected 12, got 3"):
        pg.apply_regions(cube, [], np.ones(3, bool))
    with pytest.raises(ValueError, match=r"regions\[1\]\.radius"):
        pg.apply_regions(cube, [pg.PaintRegion.box([0, 0, 0], [1, 1, 1]),
                                {"shape": "sphere", "center": [0, 0, 0], "radius": -1, "mark": "free"}])
    with pytest.raises(ValueError, match=r"regions\[0\]"):
        pg.apply_regions(cube, [42])


# ----------------------------------------------------------------------------- files

@pytest.mark.parametrize("p_free", [0.9, 0.5, 0.1, 1.0])
def test_save_then_load_gives_the_same_mask(meshes, tmp_path, p_free):
    m = meshes["mug"]
    rng = np.random.default_rng(11)
    mask = rng.random(len(m.faces)) < p_free
    mask[3] = True
    path = tmp_path / "mug.paint.json"
    pg.save_paint(path, m, mask)  # os.PathLike and str both work
    back = pg.load_paint(str(path), m)
    assert np.array_equal(back, mask)
    doc = json.loads(path.read_text())
    assert doc["format"] == "pairgrasp-paint" and doc["faces"] == len(m.faces)
    listed = doc.get("occluded", doc.get("free"))
    assert len(listed) == min(mask.sum(), (~mask).sum())  # the smaller side is listed


def test_save_rejects_bad_masks(cube, tmp_path):
    with pytest.raises(ValueError, match="free_mask: expected 12, got 11"):
        pg.save_paint(str(tmp_path / "a.json"), cube, np.ones(11, bool))
    with pytest.raises(ValueError, match="no free face"):
        pg.save_paint(str(tmp_path / "b.json"), cube, np.zeros(12, bool))
    with pytest.raises(pg.FileError, match="cannot open for writing"):
        pg.save_paint(str(tmp_path / "missing" / "c.json"), cube, np.ones(12, bool))


HEAD = '"format": "pairgrasp-paint", "version": 1, "faces": 12'


@pytest.mark.parametrize("body,field", [
    ("", "file: not valid JSON"),
    ("[1]", "file: expected a JSON object"),
    ('{"version": 1, "faces": 12}', "format: missing"),
    ('{"format": "other", "version": 1, "faces": 12}', "format: expected"),
    ('{"format": "pairgrasp-paint", "version": 7, "faces": 12}', "version: unsupported version 7"),
    ('{"format": "pairgrasp-paint", "version": 1}', "faces: missing"),
    ('{"format": "pairgrasp-paint", "version": 1, "faces": 5120}', "faces: the paint is for a mesh of 5120 faces"),
    ("{" + HEAD + ', "occluders": []}', "occluders: unknown key"),
    ("{" + HEAD + ', "default": "maybe"}', "default: expected"),
    ("{" + HEAD + ', "occluded": [0, 12]}', r"occluded\[1\]: face index 12 is out of range"),
    ("{" + HEAD + ', "free": [-3]}', r"free\[0\]: face index -3 is out of range"),
    ("{" + HEAD + ', "free": [true]}', r"free\[0\]: expected an integer"),
    ("{" + HEAD + ', "free": [1], "occluded": [1]}', r"occluded\[0\]: face 1 is listed as both"),
    ("{" + HEAD + ', "regions": [{"shape": "torus", "mark": "free"}]}', r"regions\[0\]\.shape: unknown shape"),
    ("{" + HEAD + ', "regions": [{"shape": "sphere", "center": [0, 0, 0], "radius": 0, "mark": "free"}]}',
     r"regions\[0\]\.radius: must be > 0"),
    ("{" + HEAD + ', "regions": [{"shape": "halfspace", "point": [0, 0, 0], "normal": [0, 0, 0], '
     '"mark": "free"}]}', r"regions\[0\]\.normal: must be non-zero"),
    ("{" + HEAD + ', "regions": [{"shape": "box", "min": [0, 0, 0], "max": [1, 1], "mark": "free"}]}',
     r"regions\[0\]\.max: expected 3 numbers"),
    ("{" + HEAD + ', "regions": [{"shape": "box", "min": [0, 0, 0], "max": [1, 1, 1]}]}', r"regions\[0\]\.mark: missing"),
    ("{" + HEAD + ', "regions": [{"shape": "sphere", "center": [0, 0, NaN], "radius": 1, "mark": "free"}]}',
     "file: not valid JSON"),
])
def test_each_bad_paint_field_raises_file_error_naming_it(cube, tmp_path, body, field):
    path = tmp_path / "bad.paint.json"
    path.write_text(body)
    with pytest.raises(pg.FileError, match=field) as info:
        pg.load_paint(str(path), cube)
    assert str(info.value).startswith(str(path))
    assert isinstance(info.value, RuntimeError)


def test_missing_paint_file_is_a_file_error(cube, tmp_path):
    with pytest.raises(pg.FileError, match="cannot open"):
        pg.load_paint(str(tmp_path / "nope.json"), cube)


@pytest.mark.parametrize("extra", [
    ', "default": "occluded"',
    ', "occluded": [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]',
    ', "regions": [{"shape": "halfspace", "point": [0, 0, -5], "normal": [0, 0, 1], "mark": "occluded"}]',
])
def test_a_paint_with_no_free_face_is_refused(cube, tmp_path, extra):
    path = tmp_path / "none.paint.json"
    path.write_text("{" + HEAD + extra + "}")
    with pytest.raises(ValueError, match="paint leaves no free face"):
        pg.load_paint(str(path), cube)


def test_a_paint_for_another_mesh_is_refused(meshes):
    with pytest.raises(pg.FileError, match="faces"):
        pg.load_paint(str(TARGETS / "flask.paint.json"), meshes["mug"])
