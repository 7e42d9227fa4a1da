"""atheris harness: the grasps.json reader (pairgrasp.load_grasps), with and without a hand.

Run (scripts/run_fuzz.sh does): python tests/fuzz/fuzz_grasps.py [libFuzzer flags] CORPUS_DIR...

`grasps_target(data)` is also what tests/py/test_fuzz_corpus.py replays over the committed seeds
(tests/fuzz/corpus/grasps) and regression inputs (tests/fuzz/regressions/grasps). An input must
load into grasps that keep the documented invariants or be refused with pairgrasp.FileError naming
the file; any other exception or a broken invariant is a bug (atheris records the input).
"""
import os
import pathlib
import sys
import tempfile

import numpy as np

MODELS = pathlib.Path(__file__).resolve().parents[2] / "models"
_state = {}


def _setup():
    if not _state:
        import pairgrasp

        _state["pg"] = pairgrasp
        _state["hand"] = pairgrasp.load_hand(str(MODELS / "parallel_jaw" / "parallel_jaw.json"))
        _state["dir"] = tempfile.TemporaryDirectory(prefix="pairgrasp-fuzz-")
    return _state["pg"], _state["hand"], pathlib.Path(_state["dir"].name) / "grasps.json"


def _check(f, hand, path):
    """The invariants of a GraspsFile that load_grasps returned."""
    assert f.path == str(path)
    for k, g in enumerate(f.grasps):
        where = f"grasps[{k}]"
        assert isinstance(g.rank, int) and not isinstance(g.rank, bool) and g.rank >= 1, where
        T = np.asarray(g.wrist_pose)
        assert T.shape == (4, 4) and np.isfinite(T).all(), where
        R = T[:3, :3]
        assert np.abs(R.T @ R - np.eye(3)).max() <= 1e-6 and np.linalg.det(R) > 0, where
        dofs = np.asarray(g.dofs)
        assert dofs.ndim == 1 and np.isfinite(dofs).all(), where
        if hand is not None:
            assert len(dofs) == len(hand.dof_names), where
            assert (dofs >= np.asarray(hand.dof_lower) - 1e-9).all(), where
            assert (dofs <= np.asarray(hand.dof_upper) + 1e-9).all(), where
        for name in ("epsilon", "alignment_quality", "penetration_depth"):
            v = getattr(g, name)
            assert isinstance(v, float) and np.isfinite(v) and v >= 0, (where, name)
        assert isinstance(g.force_closure, bool) and isinstance(g.votes, int), where
        P, N = np.asarray(g.contact_points), np.asarray(g.contact_normals)
        assert P.shape == N.shape == (len(g.contact_links), 3), where
        assert np.isfinite(P).all() and np.isfinite(N).all(), where
        if len(N):
            assert np.abs(np.linalg.norm(N, axis=1) - 1).max() <= 1e-6, where
        assert all(isinstance(link, str) for link in g.contact_links), where
    for section in (f.inputs, f.parameters, f.counts, f.timings):
        assert isinstance(section, dict)


def grasps_target(data: bytes) -> str:
    """Loads `data` as a grasps.json file: "loaded" or "rejected"; raises on a bug."""
    pg, hand, path = _setup()
    path.write_bytes(data)
    outcome = "loaded"
    for h in (None, hand):
        try:
            f = pg.load_grasps(path, hand=h)
        except pg.FileError as e:
            message = str(e)
            if not message.startswith(f"{path}: "):
                raise AssertionError(f"FileError not naming the file: {message}") from None
            if "\n" in message:
                raise AssertionError(f"FileError of more than one line: {message!r}") from None
            outcome = "rejected"
            continue
        _check(f, h, path)
    return outcome


def main():
    import atheris

    with atheris.instrument_imports(include=["pairgrasp"]):
        _setup()

    def one_input(data):
        grasps_target(data)

    atheris.Setup(sys.argv, one_input)
    atheris.Fuzz()


if __name__ == "__main__":
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    main()
