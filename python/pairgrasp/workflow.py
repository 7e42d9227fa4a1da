"""From files to a plan folder: what `pairgrasp plan` and `pairgrasp batch` (and ``plan_batch``) share.

:func:`planner_from_files` builds a :class:`pairgrasp.Planner` from the paths a user gives (hand
spec, target mesh, paint file, occluder and obstacle meshes) and records them in the plan's
``inputs``; :func:`write_plan` writes what a plan leaves in its output folder (grasps.json and the
pictures of the best grasps); :func:`finish_outdir` moves a finished folder into place. Errors name
the command line's options (``--target: no such file: ...``), since both callers take them from it.
"""
from __future__ import annotations

import os
from typing import Callable, Dict, Optional, Sequence

import numpy as np

__all__ = ["planner_from_files", "write_plan", "finish_outdir"]


def planner_from_files(hand: str, target: str, *, paint: Optional[str] = None, occluders: Sequence[str] = (),
                       obstacles: Sequence[str] = (), viewpoints=None, support=None,
                       occluder_distance: Optional[float] = None, scale: float = 1.0,
                       names: Optional[Dict[str, str]] = None, **params):
    """The Planner of the files given (``params``: PlanParams fields). ``names`` maps a file given to
    the name grasps.json records for it (a batch task plans on copies of the files and records the
    originals); a file not in it is recorded as given.

    Raises:
        ValueError: a path that is not a file (naming its option), a bad support plane (``--support:``).
        pairgrasp.FileError: a malformed file.
    """
    import pairgrasp as pg

    occluders, obstacles = list(occluders or ()), list(obstacles or ())
    for name, path in [("--hand", hand), ("--target", target), ("--paint", paint)] + \
            [("--occluder", o) for o in occluders] + [("--obstacle", o) for o in obstacles]:
        if path is not None and not os.path.isfile(path):
            raise ValueError(f"{name}: {'not a file' if os.path.exists(path) else 'no such file'}: {path}")
    mesh = pg.load_mesh(target, scale=scale)
    views = np.asarray(viewpoints, float).reshape(-1, 3) if viewpoints is not None and len(viewpoints) else None
    try:
        planner = pg.Planner(hand, mesh, paint=paint, occluders=[pg.load_mesh(o, scale=scale) for o in occluders],
                             viewpoints=views, support=support, occluder_distance=occluder_distance,
                             obstacles=[pg.load_mesh(o, scale=scale) for o in obstacles], **params)
    except ValueError as e:
        if str(e).startswith("support:"):   # name the option as typed
            raise ValueError("--" + str(e)) from None
        if str(e).startswith("no free face left") and support is not None:
            raise ValueError(f"--support: {e}") from None
        raise
    record: Callable[[str], str] = (lambda path: names.get(path, path)) if names else (lambda path: path)
    planner.inputs["hand_spec"] = record(planner.inputs["hand_spec"])
    planner.inputs["target"] = record(target)
    if paint:
        planner.inputs["paint"] = record(paint)
    if occluders:
        planner.inputs["occluders"] = [record(o) for o in occluders]
    if obstacles:
        planner.inputs["obstacles"] = [record(o) for o in obstacles]
    if scale != 1.0:
        planner.inputs["scale"] = scale
    return planner


def finish_outdir(tmpdir: str, outdir: str):
    """Moves the files written in ``tmpdir`` into ``outdir`` (created if needed), each by rename."""
    os.makedirs(outdir, exist_ok=True)
    for name in sorted(os.listdir(tmpdir)):
        os.replace(os.path.join(tmpdir, name), os.path.join(outdir, name))


def write_plan(planner, result, folder: str, pictures: int, label: str, verify=None):
    """Writes what `plan` leaves in its output folder into ``folder``: grasps.json and a picture of
    each of the best ``pictures`` grasps (``label``: the target's name in their titles). ``verify``
    (plan --verify-top): a function (path, document) that simulates the document's best grasps and
    re-ranks them in it, returning (grasps in the new order, the table's column: (name, {planned
    rank: text})); the file is written once, at the end. Returns (number of pictures, grasps in
    their final order, that column or None)."""
    from . import render
    from .grasps_file import write_grasps

    doc = result.to_dict()
    path = os.path.join(folder, "grasps.json")
    grasps, verified = result.grasps, None
    if verify is not None:
        grasps, verified = verify(path, doc)
    names = []
    for rank, g in enumerate(grasps[:pictures], start=1):
        name = f"grasp_{rank:02d}.png"
        render.draw_planned(planner, g, os.path.join(folder, name), label)
        names.append(name)
    doc["pictures"] = names
    write_grasps(path, doc)
    return len(names), grasps, verified
