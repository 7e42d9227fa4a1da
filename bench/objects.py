"""A fixed set of third-party objects with a dev/test split.

    python bench/objects.py                 # table: name, split, scale, extents, height at rest, closed
    python bench/objects.py --split test    # one split only
    python bench/objects.py --regenerate    # rewrite objects.txt from CANDIDATES by the rules below

The meshes are files of the ``pybullet_data`` package (``pip install pybullet``), made by others
and not repaired here. ``objects.txt`` beside this file is the list: one object per line, its path
relative to ``pybullet_data.getDataPath()``, its scale, its split and its name. The list is fixed
data; the rules below only say where its numbers came from (``--regenerate`` applies them again).

Which files: the single-object meshes of the package (the mug, the duck's and the teddy's convex
pieces, the bunny, the ball, the Lego brick, the torus, the toy blocks, the domino, a cube, a slab,
a sphere and the parts of the differential gear), and every 16th of ``random_urdfs/NNN/NNN.obj``
in sorted order (000, 016, ..., 992) plus 005. Left out: planes, terrains, cloth, heightmaps,
robots and their links, furniture (tables, the shelf), trays and arenas, duplicates (``duck.obj``,
``lego_vhacd.obj``, ``mug_col.obj``, ``urdf/mug.obj``, ``textured_sphere_smooth.obj``, the Jenga
block, a unit cube that only its URDF scales unevenly), and any file that fails to load with
``trimesh.load(path, force="mesh")`` or loads empty.

Scale: a mesh whose largest extent is already within 5-20 cm keeps its own scale (1). Any other is
scaled so that its largest extent becomes ``8 + 8 * u`` cm, ``u = int(sha1(path)[4:8]) / 2**32`` (bytes
4-7 of the SHA-1 of the relative path, big-endian), a size in [8, 16) cm that is fixed per file. So
the random URDF objects, under 5 cm tall at their URDF scale, are tall enough to stand on a table,
and the files in millimetres or at a metre's size become hand-sized.

Split: the first byte of ``sha1(relative path)`` even = ``dev``, odd = ``test``; the objects
already used to tune the planner are ``dev`` whatever their hash (``TUNED``).

``export(obj, out_dir, rest_on_table)`` writes the scaled mesh as STL in metres: at rest on z = 0 in
its most likely resting pose (``trimesh.poses.compute_stable_poses``, one sample, no noise, the
pose of highest probability; the identity when that fails), centred in x and y; or free-floating,
its bounding box centred at the origin. The resting pose uses the solid's centre of mass for a
closed mesh and the convex hull's for an open one (whose own "centre of mass" is not defined).
"""
from __future__ import annotations

import argparse
import hashlib
import os
import sys
import warnings
from dataclasses import dataclass
from typing import List, Optional

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
LIST_FILE = os.path.join(HERE, "objects.txt")
SPLITS = ("dev", "test")

# Already used to tune the planner: dev whatever their hash.
TUNED = frozenset({
    "objects/mug.obj",
    "duck_vhacd.obj",
    "teddy2_VHACD_CHs.obj",
    "bunny.obj",
    "random_urdfs/000/000.obj",
    "random_urdfs/005/005.obj",
})

# The scale rule's bounds (m).
KEEP_MIN, KEEP_MAX = 0.05, 0.20
SIZE_MIN, SIZE_MAX = 0.08, 0.16

NAMED = [
    "objects/mug.obj",
    "duck_vhacd.obj",
    "teddy2_VHACD_CHs.obj",
    "bunny.obj",
    "soccerball.obj",
    "lego/lego.obj",
    "torus/torus_textured.obj",
    "toys/cube.obj",
    "toys/cylinder.obj",
    "toys/prism.obj",
    "toys/shape_sorter.obj",
    "domino/domino.obj",
    "cube.obj",
    "stone.obj",
    "sphere_smooth.obj",
    "differential/diff_arm.stl",
    "differential/diff_carrier.stl",
    "differential/diff_carrier_cover.stl",
    "differential/diff_leftshaft.stl",
    "differential/diff_motor_cover.stl",
    "differential/diff_pinion.stl",
    "differential/diff_rightshaft.stl",
    "differential/diff_ring.stl",
    "differential/diff_side.stl",
    "differential/diff_spider.stl",
    "differential/diff_spider_shaft.stl",
    "differential/diff_stand.stl",
]
RANDOM_EVERY = 16
CANDIDATES = NAMED + sorted({f"random_urdfs/{i:03d}/{i:03d}.obj" for i in list(range(0, 1000, RANDOM_EVERY)) + [5]})


@dataclass(frozen=True)
class Object:
    name: str
    path: str      # absolute
    scale: float
    split: str
    rel: str = ""  # relative to the pybullet_data root


def data_root() -> str:
    import pybullet_data

    return pybullet_data.getDataPath()


def _sha1(rel_path: str) -> bytes:
    return hashlib.sha1(rel_path.encode("utf-8")).digest()


def split_of(rel_path: str) -> str:
    """``dev`` or ``test`` for a path relative to the pybullet_data root (the tuned objects are dev)."""
    rel_path = rel_path.replace(os.sep, "/")
    if rel_path in TUNED:
        return "dev"
    return "dev" if _sha1(rel_path)[0] % 2 == 0 else "test"


def target_size(rel_path: str) -> float:
    """The largest extent (m) a mesh outside 5-20 cm is scaled to: in [8, 16) cm, from the path's hash."""
    u = int.from_bytes(_sha1(rel_path)[4:8], "big") / 2.0 ** 32
    return SIZE_MIN + (SIZE_MAX - SIZE_MIN) * u


def scale_for(rel_path: str, largest_extent: float) -> float:
    if KEEP_MIN <= largest_extent <= KEEP_MAX:
        return 1.0
    return target_size(rel_path) / largest_extent


def name_of(rel_path: str) -> str:
    parts = rel_path.replace(os.sep, "/").split("/")
    stem = os.path.splitext(parts[-1])[0]
    if parts[0] == "random_urdfs":
        return f"random_{stem}"
    if parts[0] in ("objects", "differential", "domino", "lego", "torus") or len(parts) == 1:
        return {"duck_vhacd": "duck", "teddy2_VHACD_CHs": "teddy", "torus_textured": "torus"}.get(stem, stem)
    return f"{parts[0]}_{stem}"


def load_mesh(path: str, scale: float = 1.0):
    """The file as one trimesh.Trimesh, scaled; vertices merged by position (as an STL reads back)."""
    import trimesh

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = trimesh.load(path, force="mesh")
    if not isinstance(m, trimesh.Trimesh) or len(m.faces) == 0:
        raise ValueError(f"{path}: no triangles")
    mesh = trimesh.Trimesh(vertices=np.asarray(m.vertices, float) * scale, faces=np.asarray(m.faces), process=True)
    if len(mesh.faces) == 0:
        raise ValueError(f"{path}: no triangles")
    return mesh


def load_objects(split: Optional[str] = None, list_file: str = LIST_FILE) -> List[Object]:
    """The objects of ``objects.txt`` (all, or those of ``split``: ``"dev"`` or ``"test"``)."""
    if split not in (None, "all") and split not in SPLITS:
        raise ValueError(f"split must be one of {SPLITS} or None, not {split!r}")
    root = data_root()
    out = []
    with open(list_file) as f:
        for line in f:
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            rel, scale, sp, name = line.split()
            if split in (None, "all") or sp == split:
                out.append(Object(name=name, path=os.path.join(root, rel), scale=float(scale), split=sp, rel=rel))
    return out


def resting_transform(mesh) -> np.ndarray:
    """The 4x4 transform of ``mesh``'s most likely resting pose on a plane z = const (identity if that fails)."""
    import trimesh

    try:
        hull = mesh.convex_hull
        com = mesh.center_mass if mesh.is_watertight and mesh.is_volume else hull.center_mass
        inside = np.all(np.einsum("ij,ij->i", com - hull.triangles_center, hull.face_normals) < 0)
        if not inside:
            com = hull.center_mass
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            transforms, probs = trimesh.poses.compute_stable_poses(mesh, center_mass=com, n_samples=1, seed=0)
        if len(transforms) == 0:
            return np.eye(4)
        return np.asarray(transforms[int(np.argmax(probs))], float)
    except Exception:
        return np.eye(4)


def placed_mesh(obj: Object, rest_on_table: bool):
    """The scaled mesh at rest on z = 0 (centred in x, y) or free-floating (bounding box centred at 0)."""
    mesh = load_mesh(obj.path, obj.scale)
    if rest_on_table:
        mesh.apply_transform(resting_transform(mesh))
        lo, hi = mesh.bounds
        mesh.apply_translation([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]])
    else:
        mesh.apply_translation(-mesh.bounds.mean(axis=0))
    return mesh


def export(obj: Object, out_dir: str, rest_on_table: bool) -> str:
    """Write the object as an STL in metres (see the module's docstring) and return its path."""
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, f"{obj.name}_{'rest' if rest_on_table else 'free'}.stl")
    mesh = placed_mesh(obj, rest_on_table)
    tmp = f"{path}.{os.getpid()}.tmp"
    mesh.export(tmp, file_type="stl")
    os.replace(tmp, path)
    return path


def height_at_rest(obj: Object) -> float:
    """The object's height (m) in its resting pose."""
    lo, hi = placed_mesh(obj, True).bounds
    return float(hi[2] - lo[2])


HEADER = """\
# Third-party objects for bench/bench_scenes.py: files of the pybullet_data package, paths relative
# to pybullet_data.getDataPath(). Columns: path, scale, split, name.
#
# Scale: a mesh whose largest extent is within 5-20 cm keeps its own scale (1); any other is scaled so
# that its largest extent becomes 8 + 8*u cm, u = (bytes 4-7 of sha1(path), big-endian) / 2^32.
# Split: first byte of sha1(path) even = dev, odd = test; the objects already used for tuning
# (objects/mug.obj, duck_vhacd.obj, teddy2_VHACD_CHs.obj, bunny.obj, random_urdfs/000/000.obj,
# random_urdfs/005/005.obj) are dev whatever the hash.
# The numbers are fixed data; bench/objects.py --regenerate applies the rules again.
"""


def regenerate(list_file: str = LIST_FILE) -> List[str]:
    """Apply the rules to CANDIDATES and write ``list_file``; return the lines written."""
    root = data_root()
    lines, skipped = [], []
    for rel in CANDIDATES:
        try:
            mesh = load_mesh(os.path.join(root, rel))
        except Exception as e:
            skipped.append(f"{rel}: {e}")
            continue
        s = scale_for(rel, float(mesh.extents.max()))
        lines.append(f"{rel:36s} {s:<15.9g} {split_of(rel):4s} {name_of(rel)}")
    with open(list_file, "w") as f:
        f.write(HEADER + "\n" + "\n".join(lines) + "\n")
    for s in skipped:
        print(f"skipped {s}", file=sys.stderr)
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--split", choices=["dev", "test", "all"], default="all")
    ap.add_argument("--regenerate", action="store_true", help="rewrite objects.txt from CANDIDATES by the rules")
    args = ap.parse_args(argv)
    if args.regenerate:
        print(f"{len(regenerate())} objects written to {os.path.relpath(LIST_FILE)}")
    objs = load_objects(None if args.split == "all" else args.split)
    print(f"{'name':22s} {'split':5s} {'scale':>10s} {'extents (cm)':>20s} {'rest h (cm)':>11s} closed")
    for o in objs:
        mesh = load_mesh(o.path, o.scale)
        ext = "x".join(f"{100 * e:.1f}" for e in mesh.extents)
        h = height_at_rest(o)
        print(f"{o.name:22s} {o.split:5s} {o.scale:10.4g} {ext:>20s} {100 * h:11.1f} {'yes' if mesh.is_watertight else 'no'}")
    counts = {s: sum(o.split == s for o in objs) for s in SPLITS}
    print(" ".join(f"{s}: {n}" for s, n in counts.items()) + f"  total: {len(objs)}")


if __name__ == "__main__":
    main()
