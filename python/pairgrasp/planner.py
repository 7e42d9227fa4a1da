"""The grasp planner: the whole pipeline of the method in one call.

:class:`Planner` is the scheduler. It builds a C++ :class:`pairgrasp.GraspPlanner` once (the
parameters resolved from the hand and the target, the target's unit facets and pair index, the
aligner and the grasp checker), decides which DOF samples of the hand to align (the schedules,
early rejection, refinement, deepening, the time limit), and hands each chunk of aligned
candidates to the C++ :class:`pairgrasp.CandidatePipeline`, which settles each pose out of
penetration, closes the fingers onto contact, scores the contacts on free faces (Ferrari-Canny
epsilon) on the library's thread pool, and at the end fine-tunes the best grasps and ranks them.
The parameters are :class:`pairgrasp.PlanParams` (``params.py``); what a plan returns is in
``results.py``. ``pairgrasp.plan_samples`` runs a given list of samples the same way from C++.

Stages (the keys of :attr:`PlanResult.timings`):

``index``
    Tessellate the target at the unit-facet edge ``h`` and index its free pairs with d <= d_max.
``schedule``
    The DOF samples. ``grid`` is the paper's exhaustive even grid (every DOF sampled every ``step``);
    ``fast`` is coarse-to-fine: a grid ``coarse_factor`` times coarser, then the fine-grid
    neighbours of the ``refine`` most promising coarse samples. Both reject, before alignment, the
    samples whose gripper pair features find target pairs for a smaller fraction of the gripper
    pairs than ``min_match_fraction`` times the best sample of the first grid (the separability of
    the paper's Figure 7): such a sample cannot collect the votes of a good alignment. The threshold
    is relative because the attainable fraction depends on the target: a box's pairs have normals
    at 0, 90 or 180 degrees only and match at most ~70% of the Barrett hand's pairs, a mug's match
    nearly all. The default threshold is low (0.15) because the fraction predicts grasp quality
    weakly: the box's best grid grasps come from samples at 0.2-0.4 of the best fraction. The grid
    uses the same rejection only when ``reject`` is set.
``align``
    The three-pass alignment of every kept sample (all cores); the best ``poses_per_sample`` poses
    of each become candidates (3 on the grid, 6 on ``fast``). Where force closure is rare,
    ``fast`` then *deepens*: while under ``min_force_closure_rate`` of the evaluated candidates
    are force-closure, the next-ranked pose of every coarse sample becomes a candidate too, one
    rank at a time up to ``max_poses_per_sample``. The extra poses come from alignments already
    made; Q_A hardly orders epsilon (Figure 8), so on a target like the mug, where ~1% of the
    candidates close, the poses below the first few are where the good grasps are.
``settle`` (C++, ``candidates.hpp``)
    A candidate is kept as aligned when it does not penetrate (depth within ``depth_tolerance``, no
    occluded face, no obstacle). Otherwise it is *adjusted* with the least change to the aligned
    grasp: the wrist backs off along the hand's approach axis until the links no closing DOF moves
    (the Barrett palm and knuckles, which stand 20 mm above the palm's active face) are clear, at
    most ``backoff`` metres, then each finger that still penetrates opens just enough. The aligned
    pose fixes the approach line, roll and spread, and the aligned finger shape is kept where it
    fits; a 0.25 rad grid point puts a fingertip up to ~30 mm from where it would touch, so the
    fingers are closed onto contact in the next stage anyway. A candidate still pruned is dropped.
``evaluate`` (C++)
    Candidates that settle to the same pose (within ``h``, ~3 degrees and half a DOF step) are
    evaluated once. Each is closed onto contact, checked and scored (:func:`pairgrasp.evaluate_grasp`)
    on the library's thread pool; the search skips the hull volume.
``fine_tune`` (C++)
    The ``fine_tune`` best distinct grasps are refined by :func:`pairgrasp.fine_tune` (its trials on
    the thread pool), and the grasps that may be returned are scored again with every contact.
``robust`` (C++, ``rank="robust"``)
    The ``max(top, 10)`` best distinct grasps by epsilon are closed and scored again at
    ``robust_samples`` perturbations each (:func:`pairgrasp.robust_quality`: wrist N(0, 1 mm) and
    N(0, 1 degree), friction within ±20% of ``mu``), and the ``top`` most robust are returned.

Ranking (``rank="epsilon"``, the paper's): force closure first, then epsilon, then Q_A, then votes.
Q_A says how well the hand's shape matched the surface before closing, and the planned candidates
show only a weak relation between the two (Figure 8, ``docs/experiments.md``), so Q_A breaks ties
and orders grasps that are not force-closure. The highest epsilon is often a grasp on the edge of
where it works: ``rank="robust"`` orders the final grasps by the probability of force closure
under pose and friction error, then the lower quartile of epsilon, then as above. The default,
``rank="load"``, returns the epsilon ranking's grasps but leads with the force-closure grasp of
the ten best that resists gravity best along its worst axis (:func:`pairgrasp.load_resistance`:
the largest pure force at the centre of mass along +-x, +-y, +-z that its contacts can exert),
among those whose fingers close into the surface and are pushed back (:func:`pairgrasp.closing_push`);
``rank="enclosure"`` leads with the one with the most hand links in contact. In the physics check
(docs/physics.md) the load ranking's rank-1 grasp held more often than any other ranking's.

Everything is deterministic for a given seed and thread count independent: alignment merges votes
in a fixed order, candidates are processed in sample order, and the fine-tuning of the grasp of
rank k uses ``seed + k``.
"""
from __future__ import annotations

import itertools
import math
import os
import sys
import time
import warnings
from dataclasses import asdict, fields
from typing import List, Optional, Sequence

import numpy as np

from . import _core
from .checks import warn_if_large, warn_if_open
from .params import PlanParams, with_overrides
from .results import Candidate, Grasp, PlanResult, _round
from .simplify import simplify_mesh

__all__ = ["PlanParams", "Grasp", "Candidate", "PlanResult", "Planner", "dof_axes", "dof_grid"]

# The fields the constructor uses to build the index and the checker; plan() cannot change them.
_BUILD_FIELDS = frozenset({"edge", "d_max", "max_pairs", "max_pairs_per_cell", "max_faces", "constellation", "spacing", "depth_tolerance",
                           "gap", "field_cell", "max_field_memory", "max_area_samples", "threads"})


def dof_axes(lower: Sequence[float], upper: Sequence[float], step: Sequence[float]) -> List[np.ndarray]:
    """Per-DOF sample values: lower, lower + step, ..., and upper (a last, shorter step when the range
    is not a multiple of the step). A DOF with lower == upper or step 0 has one value. The grid's
    samples are their Cartesian product (C++ ``dof_grid``)."""
    return [np.array(v, float) for v in _core._dof_axes(np.asarray(lower, float).reshape(-1),
                                                         np.asarray(upper, float).reshape(-1),
                                                         np.asarray(step, float).reshape(-1))]


def dof_grid(lower: Sequence[float], upper: Sequence[float], step: Sequence[float]) -> List[np.ndarray]:
    """Deprecated name of :func:`dof_axes` (the per-DOF values, not the grid's samples as C++
    ``dof_grid`` returns); warns (DeprecationWarning) and will be removed in the next release."""
    warnings.warn("pairgrasp.dof_grid is deprecated: use dof_axes (it returns per-DOF values; dof_grid goes in the "
                  "next release)", DeprecationWarning, stacklevel=2)
    return dof_axes(lower, upper, step)


class Progress:
    """A one-line progress bar on stderr, drawn only when stderr is a terminal (or forced)."""

    def __init__(self, enabled: Optional[bool]):
        self.enabled = sys.stderr.isatty() if enabled is None else bool(enabled)
        self.label, self.total, self.done, self.last = "", 0, 0, 0.0

    def start(self, label: str, total: int):
        self.label, self.total, self.done = label, max(int(total), 1), 0
        self._draw(force=True)

    def advance(self, n: int = 1):
        self.done += n
        self._draw()

    def finish(self):
        if self.enabled and self.label:
            self.done = self.total
            self._draw(force=True)
            sys.stderr.write("\n")
            sys.stderr.flush()
        self.label = ""

    def _draw(self, force=False):
        if not self.enabled:
            return
        now = time.monotonic()
        if not force and now - self.last < 0.1:
            return
        self.last = now
        frac = min(self.done / self.total, 1.0)
        bar = "#" * int(30 * frac)
        sys.stderr.write(f"\r{self.label:<10s} [{bar:<30s}] {self.done}/{self.total}")
        sys.stderr.flush()


def as_mesh(value, name):
    """`value` as a :class:`pairgrasp.Mesh`: a Mesh as is, a path loaded; ValueError naming `name` else."""
    if isinstance(value, _core.Mesh):
        return value
    if isinstance(value, (str, os.PathLike)):
        return _core.load_mesh(os.fspath(value))
    raise ValueError(f"{name}: expected a Mesh or a mesh file path, got {type(value).__name__}")


def support_plane(support, target) -> Optional["_core.SupportPlane"]:
    """The :class:`pairgrasp.SupportPlane` a ``support`` argument names for ``target``: None (no
    support), True or ``"auto"`` (the horizontal plane through the target's lowest point), a number
    (the horizontal plane at that height, m), a (point, normal) pair, or a SupportPlane. ValueError
    ("support: ...") for anything else or a non-finite plane."""
    if support is None or support is False:
        return None
    if isinstance(support, _core.SupportPlane):
        return support
    if support is True or (isinstance(support, str) and support == "auto"):
        return _core.SupportPlane.below(target)
    if isinstance(support, (int, float, np.floating, np.integer)) and not isinstance(support, bool):
        z = float(support)
        if not math.isfinite(z):
            raise ValueError(f"support: expected a finite height (m), got {support!r}")
        return _core.SupportPlane((0.0, 0.0, z), (0.0, 0.0, 1.0))
    try:
        point, normal = support
        return _core.SupportPlane(np.asarray(point, float).reshape(3), np.asarray(normal, float).reshape(3))
    except (TypeError, ValueError) as e:
        if str(e).startswith("support:"):
            raise
        raise ValueError(f"support: expected True, 'auto', a height (m), (point, normal) or a SupportPlane, "
                         f"got {support!r}") from None


class Planner:
    """Plans grasps of one hand on one target.

    Args:
        hand: a :class:`pairgrasp.Hand` or the path of a hand spec.
        target: a :class:`pairgrasp.Mesh` or the path of a mesh (metres).
        paint: free-face mask: a paint file path or an (F,) bool array (None: every face free).
        occluders: meshes (or paths) in the target frame; the surface within ``occluder_distance`` of
            one (or of the support) is occluded, decided per patch of half the unit-facet edge
            (:func:`pairgrasp.free_surface`), so ``target`` and ``free`` are the given mesh with faces
            split where the mark changes.
        viewpoints: (V,3) points (m); only the surface seen from one of them stays free.
        obstacles: meshes (or paths) the hand must not touch (a table, the hand holding the target).
        support: the plane the target rests on (:func:`support_plane`: True for the horizontal plane
            through its lowest point): an obstacle and an occluder at once.
        params: :class:`PlanParams`; keyword arguments override its fields.

    The target index, aligner and grasp checker are built once, in the constructor; :meth:`plan`
    may be called again with other schedules (``plan(schedule="grid")``).

    ``target`` is the mesh planned on (simplified, and split where the free surface changes);
    ``given_target`` is the mesh as given, the one grasps.json's ``inputs.target`` names.

    Raises:
        ValueError: bad parameters, an empty free set, a pair budget the target exceeds.
        pairgrasp.FileError: unreadable files.
    """

    def __init__(self, hand, target, paint=None, occluders=(), viewpoints=None, obstacles=(),
                 params: Optional[PlanParams] = None, occluder_distance: float = 0.005, support=None, **overrides):
        t0 = time.perf_counter()
        self.params = with_overrides(PlanParams, params, overrides, "planner")
        p = self.params
        self.hand = hand if isinstance(hand, _core.Hand) else _core.load_hand(os.fspath(hand))
        given = self.given_target = as_mesh(target, "target")
        self.inputs = {"hand": self.hand.name, "hand_spec": os.fspath(hand) if not isinstance(hand, _core.Hand)
                       else self.hand.spec_path,
                       "target": os.fspath(target) if not isinstance(target, _core.Mesh) else "<mesh>",
                       "target_faces": int(len(given.faces))}
        face_paint, regions = self._paint(paint, given)
        mesh, face_paint = self._simplified(given, face_paint)
        occ = [as_mesh(o, "occluder") for o in occluders]
        if occ:
            self.inputs["occluders"] = [os.fspath(o) if not isinstance(o, _core.Mesh) else "<mesh>" for o in occluders]
        vp = None
        if viewpoints is not None:
            vp = np.asarray(viewpoints, float).reshape(-1, 3)
            self.inputs["viewpoints"] = _round(vp)
        plane = support_plane(support, given)
        if plane is not None:
            self.inputs["support"] = {"point": _round(plane.point), "normal": _round(plane.normal)}
        if occ or plane is not None:
            self.inputs["occluder_distance"] = float(occluder_distance)
        self.obstacles = [as_mesh(o, "obstacle") for o in obstacles]
        if obstacles:
            self.inputs["obstacles"] = [os.fspath(o) if not isinstance(o, _core.Mesh) else "<mesh>" for o in obstacles]
        # The parameters fixed by the index, resolved in C++ (the target's scale is checked against
        # the hand's span there before anything large is built), and the free surface at half the
        # unit-facet edge.
        options = p.planner_options()
        warn_if_open(mesh, mesh.source or self.inputs["target"])
        warn_if_large(mesh, _core.hand_span(self.hand), mesh.source or self.inputs["target"])
        try:
            self.core = _core.GraspPlanner(self.hand, mesh, face_paint, self.obstacles, regions=regions,
                                           occluders=occ, occluder_distance=float(occluder_distance),
                                           viewpoints=vp, support=plane, **options)
        except ValueError as e:
            if "paint" in self.inputs and str(e).endswith("covered by the paint"):
                raise ValueError(f"{self.inputs['paint']}: paint leaves no free face") from None
            raise
        surface = self.core.free_surface
        self.target, self.free, self.support = self.core.target, np.asarray(self.core.free, bool), plane
        self.inputs["free_faces"] = int(self.free.sum())
        if surface.split_faces:
            self.inputs["free_surface"] = {"faces": int(len(self.target.faces)), "split_faces": int(surface.split_faces),
                                           "resolution": float(surface.resolution)}
        setup = self.core.setup
        self.mode, self.edge, self.d_max = setup.mode, float(setup.edge), float(setup.d_max)
        self.spacing = float(setup.spacing) if self.mode == "area" else None
        self.depth_tolerance, self.backoff = float(setup.depth_tolerance), float(setup.backoff)
        self.tindex, self.aligner, self.checker = self.core.target_index, self.core.aligner, self.core.checker
        self.center, self.radius = self.core.reference
        self.setup_time = time.perf_counter() - t0

    # ---------------------------------------------------------------- set-up helpers

    def _paint(self, paint, mesh):
        """(per-face marks or None, regions or None) of ``paint``: a paint file or an (F,) bool array."""
        if paint is None:
            return None, None
        if isinstance(paint, (str, os.PathLike)):
            faces, regions = _core.read_paint(os.fspath(paint), mesh)
            self.inputs["paint"] = os.fspath(paint)
            return np.asarray(faces, bool), (regions or None)
        free = np.asarray(paint)
        if free.dtype != bool or free.shape != (len(mesh.faces),):
            raise ValueError(f"paint: expected a ({len(mesh.faces)},) bool mask or a paint file, "
                             f"got {free.dtype} array of shape {free.shape}")
        if not free.any():
            raise ValueError("paint: no free face left (the mask is all False)")
        return free, None

    def _simplified(self, mesh, free):
        """The target simplified when it has more than ``max_faces`` faces (recorded in
        ``inputs.target_simplified``), with the per-face paint carried over: each simplified face takes
        the mark of the original face nearest its centre."""
        p = self.params
        if p.max_faces is None:
            return mesh, free
        # Within the depth tolerance the planner will use: a quarter of the edge (the finest one it
        # may derive for this target when none is given), or the tolerance given, if smaller.
        max_error = 0.25 * (p.edge or _core.finest_edge(mesh))
        if p.depth_tolerance is not None:
            max_error = min(max_error, float(p.depth_tolerance))
        small, info = simplify_mesh(mesh, p.max_faces, max_error)
        if info is None:
            return mesh, free
        self.inputs["target_simplified"] = info.to_dict()
        if small is mesh:
            return mesh, free
        if free is not None and not free.all():
            centres = np.asarray(small.vertices)[np.asarray(small.faces)].mean(axis=1)
            free = free[np.asarray(_core.SurfaceQuery(mesh).closest(centres).faces)]
        else:
            free = None
        return small, free

    # ---------------------------------------------------------------- scheduling

    def steps(self, step: Optional[float] = None) -> np.ndarray:
        """Per-DOF sampling step: ``step`` for angular DOFs (None: the hand's), the hand's for linear ones."""
        return np.asarray(self.core.steps(0.0 if step is None else float(step)), float)

    def constellation(self, q):
        """The constellation aligned for DOF sample ``q`` (the resolved mode and spacing)."""
        return self.core.constellation(q)

    def match_fraction(self, q) -> float:
        """Fraction of the gripper pairs at DOF sample ``q`` whose feature (normals flipped) matches at
        least one target pair within the aligner's tolerance box: the early-rejection score (C++,
        ``GraspPlanner.match_fractions`` of many samples at once)."""
        return float(self.core.match_fractions(np.asarray(q, float).reshape(1, -1))[0])

    # ---------------------------------------------------------------- pipeline

    def plan(self, progress: Optional[bool] = None, **overrides) -> PlanResult:
        """Runs the schedule and returns the ranked grasps. ``overrides`` change plan-time fields of
        the parameters (schedule, step, poses_per_sample, backoff, ..., not the ones the constructor
        used to build the index and the checker: edge, d_max, max_pairs, max_faces, constellation,
        spacing, max_area_samples, depth_tolerance, gap, field_cell, max_field_memory, threads:
        changing one of those is a ValueError)."""
        p = PlanParams(**asdict(self.params))
        for k, v in overrides.items():
            if k not in {f.name for f in fields(PlanParams)}:
                raise ValueError(f"unknown planner parameter {k!r}")
            if k in _BUILD_FIELDS and v != getattr(p, k):
                raise ValueError(f"{k}: fixed when the Planner is built; build a new Planner to change it")
            setattr(p, k, v)
        p.validate()
        start = time.perf_counter()
        bar = Progress(progress)
        search = _core.GraspSearch(self.core, **p.search_options())
        timings = {"index": self.setup_time}
        counts = {"unit_facets": int(len(self.tindex.facets.points)), "stored_pairs": int(len(self.tindex.index.pairs)),
                  "rejected": 0, "aligned_samples": 0, "skipped": 0}
        scheduled_samples = [0]
        schedule_t = [0.0]
        axes = dof_axes(self.hand.dof_lower, self.hand.dof_upper, self.steps(p.step))
        reject = p.reject if p.reject is not None else (p.schedule == "fast")
        best_fraction = [None]

        def out_of_time() -> bool:
            return p.time_limit is not None and time.perf_counter() - start >= p.time_limit

        def run_stage(index_tuples, label, keep_deeper=False):
            """Aligns, settles and evaluates the grid samples at ``index_tuples`` (after early
            rejection), a chunk at a time so that a time limit stops the search between chunks."""
            t = time.perf_counter()
            qs = [np.array([axes[d][k] for d, k in enumerate(idx)]) for idx in index_tuples]
            scheduled_samples[0] += len(qs)
            keep = [True] * len(qs)
            if reject and qs:
                fractions = self.core.match_fractions(np.array(qs))
                if best_fraction[0] is None:  # the first stage (the whole grid, or fast's coarse grid)
                    best_fraction[0] = max(fractions, default=0.0)
                threshold = p.min_match_fraction * best_fraction[0]
                keep = [f >= threshold and f > 0.0 for f in fractions]
            kept = [q for q, k in zip(qs, keep) if k]
            counts["rejected"] += len(qs) - len(kept)
            schedule_t[0] += time.perf_counter() - t
            bar.start(label, len(kept))
            for b in range(0, len(kept), p.chunk):
                if out_of_time():
                    counts["skipped"] += len(kept) - b
                    break
                chunk = kept[b:b + p.chunk]
                search.add_samples(np.array(chunk), keep_deeper)
                counts["aligned_samples"] += len(chunk)
                bar.advance(len(chunk))
            bar.finish()

        shape = [len(a) for a in axes]
        if p.schedule == "grid":
            run_stage(list(itertools.product(*[range(n) for n in shape])), "grid")
        else:
            f = p.coarse_factor
            # Every f-th value, and the upper limit when it lies more than half a coarse step beyond
            # the last of them.
            coarse_axes = [sorted(set(range(0, n, f)) | ({n - 1} if 2 * ((n - 1) % f) > f else set())) for n in shape]
            coarse = list(itertools.product(*coarse_axes))
            run_stage(coarse, "coarse", keep_deeper=True)
            scheduled = set(coarse)
            centres: set = set()
            r = max(f // 2, 1)
            for _ in range(p.refine_rounds):
                # Seeds: the samples searched so far, ranked by their best candidate (the final
                # ranking's order), that have not been a centre yet; their unsampled fine-grid
                # neighbours are the next stage (a later round climbs from the best of the last).
                order = [s for s in search.ranked_samples() if s not in centres][: p.refine]
                centres.update(order)
                searched = search.samples
                fine: List[tuple] = []
                for s in order:
                    centre = tuple(int(np.argmin(np.abs(axes[d] - searched[s][d]))) for d in range(len(axes)))
                    for off in itertools.product(*[range(-r, r + 1)] * len(axes)):
                        idx = tuple(min(max(c + o, 0), n - 1) for c, o, n in zip(centre, off, shape))
                        if idx not in scheduled:
                            scheduled.add(idx)
                            fine.append(idx)
                if not fine:
                    break
                if out_of_time():
                    scheduled_samples[0] += len(fine)
                    counts["skipped"] += len(fine)
                    break
                run_stage(fine, "refine")
            # Deepening: while force closure is rare, the coarse samples' next-ranked poses, one rank
            # at a time.
            rank = -1
            while search.deepen_rank >= 0 and not out_of_time():
                if search.deepen_rank != rank:
                    rank = search.deepen_rank
                    if search.force_closure >= p.min_force_closure_rate * max(search.evaluated_count, 1):
                        break
                search.deepen(p.chunk)
        done = search.timings
        timings.update(schedule=schedule_t[0], align=done["align"], settle=done["settle"], evaluate=done["evaluate"])
        t = time.perf_counter()
        time_left = None if p.time_limit is None else p.time_limit - (t - start)
        ranked, seconds = search.finish(time_left)
        evaluated = search.evaluated()
        grasps = self._grasps(evaluated, ranked)
        timings["fine_tune"] = time.perf_counter() - t - seconds["robust"]
        timings["robust"] = seconds["robust"]
        timings["total"] = sum(timings.values())
        counts.update(search.counts)
        counts["samples"] = scheduled_samples[0]
        counts["force_closure"] = int(search.force_closure)
        records = [Candidate(sample_index=c.sample_index, alignment_quality=c.alignment_quality, votes=c.votes,
                             epsilon=float(c.evaluation.epsilon), force_closure=bool(c.evaluation.force_closure),
                             settled=c.settled, time=c.seconds) for c in evaluated]
        return PlanResult(grasps=grasps, candidates=records, timings=timings, counts=counts, edge=self.edge,
                          d_max=self.d_max, constellation=self.mode, spacing=self.spacing, params=p,
                          inputs=dict(self.inputs))

    def _grasps(self, cands, ranked) -> List[Grasp]:
        """The returned grasps as :class:`Grasp` records, with the evaluated candidates they came from."""
        grasps: List[Grasp] = []
        for g in ranked:
            c, ev, r = cands[g.candidate], g.evaluation, g.robust
            joints = {k: float(v) for k, v in self.hand.joint_values(np.asarray(ev.dofs), clamp=True).items()}
            grasps.append(Grasp(
                rank=len(grasps) + 1, wrist_pose=np.array(ev.wrist_pose), dofs=np.array(ev.dofs), joints=joints,
                epsilon=float(g.epsilon), volume=float(g.volume), force_closure=bool(g.force_closure),
                alignment_quality=float(c.alignment_quality), votes=int(c.votes), penetration_depth=float(ev.depth),
                contact_points=np.array(ev.contact_points), contact_normals=np.array(ev.contact_normals),
                contact_links=tuple(ev.contact_links), sample=np.array(c.dofs), aligned_pose=np.array(c.pose),
                backoff=float(c.backoff), fine_tuned=bool(g.fine_tuned),
                force_closure_probability=None if r is None else float(r.force_closure_probability),
                robust_epsilon=None if r is None else float(r.epsilon), load_resistance=float(g.load_resistance),
                opposition=float(g.push.opposition), drive=float(g.push.drive)))
        return grasps
