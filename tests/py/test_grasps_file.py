"""grasps.json read back: a round trip of a real plan, and every malformed field named."""
import copy
import json
import pathlib

import numpy as np
import pytest

import pairgrasp as pg

MODELS = pathlib.Path(__file__).resolve().parents[2] / "models"
JAW = MODELS / "parallel_jaw" / "parallel_jaw.json"
BOX = MODELS / "targets" / "box.stl"


@pytest.fixture(scope="module")
def planned():
    planner = pg.Planner(str(JAW), str(BOX), edge=0.008, top=3, seed=2, fine_tune=1, fine_tune_iterations=4)
    return planner, planner.plan(progress=False)


@pytest.fixture()
def written(planned, tmp_path):
    _, result = planned
    path = tmp_path / "grasps.json"
    pg.write_grasps(path, result.to_dict())
    return path, result


def test_round_trip_keeps_every_grasp(written, planned):
    path, result = written
    f = pg.load_grasps(path, hand=planned[0].hand)
    assert len(f.grasps) == len(result.grasps) > 0
    for a, b in zip(result.grasps, f.grasps):
        assert a.rank == b.rank and a.force_closure == b.force_closure and a.votes == b.votes
        np.testing.assert_allclose(b.wrist_pose, a.wrist_pose, atol=1e-9)  # written to 1e-9
        np.testing.assert_allclose(b.dofs, a.dofs, atol=1e-9)
        np.testing.assert_allclose(b.contact_points, a.contact_points, atol=1e-9)
        assert b.contact_links == a.contact_links
        assert b.epsilon == pytest.approx(a.epsilon, abs=1e-9)
    assert f.counts == result.counts
    assert f.parameters["seed"] == 2


def test_read_back_contacts_give_the_written_epsilon(written, planned):
    """An independent use of what was read: epsilon recomputed from the contacts in the file."""
    path, _ = written
    planner = planned[0]
    g = pg.load_grasps(path).grasps[0]
    q = pg.grasp_quality(g.contact_points, g.contact_normals, planner.center, planner.radius)
    assert q.epsilon == pytest.approx(g.epsilon, rel=1e-6, abs=1e-8)


def test_write_is_atomic_and_refuses_nan(tmp_path):
    path = tmp_path / "g.json"
    with pytest.raises(ValueError):
        pg.write_grasps(path, {"format": pg.GRASPS_FORMAT, "grasps": [], "x": float("nan")})
    assert not path.exists() and not (tmp_path / "g.json.part").exists()


def _edit(doc, keys, value):
    d = copy.deepcopy(doc)
    node = d
    for k in keys[:-1]:
        node = node[k]
    if value is _DELETE:
        del node[keys[-1]]
    else:
        node[keys[-1]] = value
    return d


_DELETE = object()
_ROT90 = [[0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]


@pytest.mark.parametrize("keys, value, needle", [
    (["format"], "something/2", "format"),
    (["grasps"], {}, "grasps: expected a list"),
    (["grasps", 0, "wrist_pose"], [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "grasps[0].wrist_pose"),
    (["grasps", 0, "wrist_pose"], [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "not a rotation"),
    (["grasps", 0, "wrist_pose"], [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]], "not a rotation"),
    (["grasps", 0, "wrist_pose", 0, 3], "x", "grasps[0].wrist_pose"),
    (["grasps", 0, "dof"], [0.01, 0.02], "expected 1 values"),
    (["grasps", 0, "dof"], [0.5], "outside"),
    (["grasps", 0, "dof"], [True], "boolean"),
    (["grasps", 0, "epsilon"], -1, "grasps[0].epsilon"),
    (["grasps", 0, "epsilon"], "big", "grasps[0].epsilon"),
    (["grasps", 0, "force_closure"], 1, "force_closure"),
    (["grasps", 0, "votes"], 2.5, "votes"),
    (["grasps", 0, "rank"], 0, "rank"),
    (["grasps", 0, "contacts", 0, "normal"], [0, 0, 2], "unit"),
    (["grasps", 0, "contacts", 0, "point"], [0, 0], "contacts[0].point"),
    (["grasps", 0, "contacts", 0, "link"], 7, "link"),
    (["grasps", 0, "joints"], [1, 2], "joints"),
    (["grasps", 0, "contacts"], _DELETE, "missing 'contacts'"),
    (["grasps", 0, "aligned_pose"], _ROT90[:3], "aligned_pose"),
])
def test_malformed_fields_are_named(written, planned, tmp_path, keys, value, needle):
    path, _ = written
    doc = json.loads(path.read_text())
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(_edit(doc, keys, value)))
    with pytest.raises(pg.FileError) as e:
        pg.load_grasps(bad, hand=planned[0].hand)
    assert "bad.json" in str(e.value) and needle in str(e.value)


@pytest.mark.parametrize("text, needle", [
    ("", "not valid JSON"),
    ('{"format": "pairgrasp.grasps/1", "grasps": [', "line 1"),
    ('{"format": "pairgrasp.grasps/1", "grasps": [], "x": NaN}', "NaN"),
    ("[1, 2]", "expected a JSON object"),
    ("[" * 100000, "JSON"),
])
def test_unreadable_files(tmp_path, text, needle):
    p = tmp_path / "g.json"
    p.write_text(text)
    with pytest.raises(pg.FileError, match="g.json") as e:
        pg.load_grasps(p)
    assert needle in str(e.value)


def test_missing_and_binary_files(tmp_path):
    with pytest.raises(pg.FileError, match="nope.json"):
        pg.load_grasps(tmp_path / "nope.json")
    p = tmp_path / "b.json"
    p.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(pg.FileError, match="UTF-8"):
        pg.load_grasps(p)
