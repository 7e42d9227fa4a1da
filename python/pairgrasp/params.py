"""The planner's parameters (:class:`PlanParams`), checked field by field."""
from __future__ import annotations

import math
import numbers
from dataclasses import asdict, dataclass, fields
from typing import Optional, Tuple

import numpy as np

from . import _core

__all__ = ["PlanParams", "with_overrides"]


@dataclass
class PlanParams:
    """Parameters of :class:`Planner` (metres, radians).

    Attributes:
        schedule: ``"grid"`` (exhaustive) or ``"fast"`` (coarse-to-fine with early rejection).
        step: sampling step (rad) of every angular DOF; None: the hand's ``dof_step``. Linear DOFs
            keep the hand's step.
        edge: unit-facet edge h (m); None: 5 mm, or 1/15 of the target's smallest extent if
            smaller, or coarser when the pair budget requires it (:func:`pairgrasp.suggest_edge`).
        d_max: largest stored pair distance (m); None: the largest distance between two samples
            of the hand's constellations over its DOF range, plus h.
        max_pairs: pair budget of the index.
        max_pairs_per_cell: pairs kept per cell of the feature space (0: every pair). The pairs of a
            flat face, a sphere or two parallel faces share a few feature cells; only about this many
            of each are stored and matched, and a pose's votes count the kept pairs (docs/planner.md).
        max_faces: a target with more faces is simplified to about this many before it is
            tessellated (quadric edge collapse, :func:`pairgrasp.simplify.simplify_mesh`), within a
            measured error bound of h / 4, the default penetration tolerance (recorded in the result's ``inputs.target_simplified``);
            None: never.
        constellation: ``"per_link"`` (the paper's one sample per active link), ``"area"`` (samples
            ``spacing`` apart over the active surfaces), ``"antipodal"`` (a parallel jaw's two pads on
            the target's antipodal pairs, docs/planner.md) or ``"auto"``: antipodal for a parallel
            jaw (two per-link samples facing each other), else per-link unless every per-link pair
            is antipodal or there are fewer than 3 per-link samples, then area.
        spacing: area-sample spacing (m); None: the smallest multiple of h giving at most
            ``max_area_samples`` samples at mid-range.
        max_area_samples: see ``spacing``.
        poses_per_sample: aligned poses per DOF sample that become candidates (None: the
            schedule's, 3 for ``grid`` and 6 for ``fast``).
        min_match_fraction: early rejection threshold, relative to the best sample of the first
            grid (the fraction of a sample's gripper pairs that match a target pair).
        reject: apply the early rejection (None: only for ``fast``).
        coarse_factor: ``fast``: the coarse grid's step in fine steps (every ``coarse_factor``-th
            value, and the upper limit when it lies more than half a coarse step beyond the last).
        refine: ``fast``: coarse samples whose fine-grid neighbourhoods are sampled.
        refine_rounds: ``fast``: rounds of refinement; each round samples the neighbourhoods of
            the ``refine`` best samples so far that were not centres yet.
        min_force_closure_rate, max_poses_per_sample: ``fast``: while a smaller fraction than
            ``min_force_closure_rate`` of the evaluated candidates is force-closure after the
            refinement, the next-ranked aligned pose of every coarse sample becomes a candidate
            too, one rank at a time, up to ``max_poses_per_sample`` poses per sample: a target where
            force closure is rare gets more pose hypotheses from the alignments already made.
        depth_tolerance: penetration tolerated (m); None: h / 4.
        gap: contact gap (m).
        field_cell: cell edge of the grasp checker's distance fields (m); None: h / 5 but at least
            1 mm (1 mm at the default 5 mm edge and on small targets, coarser when h is coarser).
            A parallel jaw's antipodal search builds no fields (it is checked exactly).
        max_field_memory: budget of those fields (GB), checked on an estimate before they are
            built: a target over it is refused at once, naming this field.
        backoff: largest back-off along the approach axis when settling (m); None: the hand's
            reach (the largest distance of a constellation sample from the wrist) / 2.
        max_evaluations: candidates closed and scored at most, best Q_A first within each chunk
            (None: all).
        chunk: DOF samples aligned, settled and evaluated together; grasps come out chunk by chunk
            (results do not depend on the thread count, they do on the chunk).
        time_limit: seconds after which no further chunk is searched and no further grasp is
            fine-tuned (an anytime plan for on-line use; None: no limit). The chunk under way, the
            ranking and the final scoring of the returned grasps still finish, and samples left
            out are counted as ``skipped``. A plan that hits the limit depends on the machine's
            speed, so it is not reproducible the way a plan without one is.
        fine_tune: how many of the best grasps are fine-tuned.
        fine_tune_iterations: trials per fine-tuned grasp.
        contacts_per_link: while searching, epsilon is computed from at most this many contacts per
            link (:func:`pairgrasp.reduce_contacts`, a lower bound); the returned grasps are scored
            again with every contact. None or 0: every contact throughout (slower by ~10x on the
            Barrett hand, whose links report patches of ~100 contacts).
        mu, edges: friction coefficient and friction-pyramid edges. The planner built with ``mu``
            indexes only the free faces that can hold a contact of a force-closure grasp at it within
            the hand's contact span (:func:`pairgrasp.graspable_faces`), and refuses a target with
            none; ``Planner.plan(mu=...)`` may lower it, not raise it.
        rank: how the returned grasps are ordered. ``"load"`` (the default): of the
            ``max(top, 10)`` best distinct grasps by epsilon, rank 1 is the force-closure grasp
            whose contacts resist a pure force at the centre of mass best along their worst of
            +-x, +-y, +-z (:func:`pairgrasp.load_resistance`, then the search's epsilon), among
            those whose fingers close into the surface and are pushed back
            (:func:`pairgrasp.closing_push`: opposition and drive >= 0.5) when any, and the
            others follow in the epsilon ranking's order; in the physics check (docs/physics.md)
            its rank-1 grasp held more often than the other rankings'. ``"enclosure"``: the same
            pool led by the force-closure grasp with the most hand links in contact.
            ``"epsilon"``: the paper's ranking (force closure, then epsilon).
            ``"robust"``: the ``max(top, 10)`` best distinct
            grasps by epsilon are closed and scored again at ``robust_samples`` perturbations each (wrist
            N(0, 1 mm) per axis and N(0, 1 degree) about a random axis, friction uniform within
            ±20% of ``mu``: :func:`pairgrasp.robust_quality`) and the ``top`` are returned by
            probability of force closure, then the lower quartile of epsilon (the pool does not
            shrink with ``top``, so the first grasps do not depend on ``top``).
        robust_samples: perturbations per grasp of the robust ranking.
        top: grasps returned.
        seed: seed of the fine-tuning.
        threads: worker threads (0: every core).
    """

    schedule: str = "fast"
    step: Optional[float] = None
    edge: Optional[float] = None
    d_max: Optional[float] = None
    max_pairs: int = 20_000_000
    max_pairs_per_cell: int = 512
    max_faces: Optional[int] = 100_000
    constellation: str = "auto"
    spacing: Optional[float] = None
    max_area_samples: int = 24
    poses_per_sample: Optional[int] = None
    min_match_fraction: float = 0.15
    reject: Optional[bool] = None
    coarse_factor: int = 3
    refine: int = 6
    refine_rounds: int = 1
    min_force_closure_rate: float = 0.05
    max_poses_per_sample: int = 12
    depth_tolerance: Optional[float] = None
    gap: float = 0.001
    field_cell: Optional[float] = None
    max_field_memory: float = 2.0
    backoff: Optional[float] = None
    max_evaluations: Optional[int] = None
    chunk: int = 128
    time_limit: Optional[float] = None
    fine_tune: int = 5
    fine_tune_iterations: int = 20
    contacts_per_link: Optional[int] = 4
    mu: float = 0.5
    edges: int = 8
    rank: str = _core.DEFAULT_RANK
    robust_samples: int = 8
    top: int = 10
    seed: int = 0
    threads: int = 0

    def validate(self) -> None:
        """Raises ValueError naming the first bad field. The fields the C++ options carry are
        checked by C++ (PlannerOptions and PlanOptions, the same messages as from C++); the others,
        the Python schedule's, here."""
        if self.schedule not in ("grid", "fast"):
            raise ValueError(f"schedule: expected 'grid' or 'fast', got {self.schedule!r}")
        for name in ("min_match_fraction", "min_force_closure_rate"):
            v = getattr(self, name)
            if not (isinstance(v, numbers.Real) and not isinstance(v, bool) and 0.0 <= v <= 1.0):
                raise ValueError(f"{name}: expected a number in [0, 1], got {v!r}")
        if self.time_limit is not None:
            _positive("time_limit", self.time_limit)
        _positive("max_field_memory", self.max_field_memory)
        if self.poses_per_sample is not None:
            _integer("poses_per_sample", self.poses_per_sample, 1)
        for name, low in (("coarse_factor", 1), ("refine", 0), ("refine_rounds", 0)):
            _integer(name, getattr(self, name), low)
        if self.max_faces is not None:
            _integer("max_faces", self.max_faces, 4)
        if self.reject is not None and not isinstance(self.reject, bool):
            raise ValueError(f"reject: expected True, False or None, got {self.reject!r}")
        _core.check_planner_options(**self.planner_options())
        _core.check_plan_options(**self.search_options())

    def planner_options(self) -> dict:
        """The fields fixed when a planner is built, as :class:`pairgrasp.GraspPlanner` keywords (C++
        PlannerOptions)."""
        return dict(edge=self.edge, d_max=self.d_max, max_pairs=self.max_pairs,
                    max_pairs_per_cell=self.max_pairs_per_cell, constellation=self.constellation,
                    spacing=self.spacing, max_area_samples=self.max_area_samples,
                    depth_tolerance=self.depth_tolerance, gap=self.gap, backoff=self.backoff,
                    field_cell=self.field_cell, max_field_bytes=self.max_field_memory * 1e9, mu=self.mu,
                    threads=self.threads)

    def search_options(self) -> dict:
        """The fields of one plan, as :class:`pairgrasp.GraspSearch` keywords (C++ PlanOptions)."""
        # Only the fast schedule's coarse samples keep poses for deepening (GraspSearch.add_samples).
        return dict(poses_per_sample=self._first_poses(), max_poses_per_sample=self.max_poses_per_sample, chunk=self.chunk, step=self.step,
                    backoff=self.backoff, top=self.top, fine_tune=self.fine_tune,
                    fine_tune_iterations=self.fine_tune_iterations, seed=self.seed, mu=self.mu, edges=self.edges,
                    contacts_per_link=self.contacts_per_link, max_evaluations=self.max_evaluations,
                    rank=self.rank, robust_samples=self.robust_samples)

    def poses(self) -> Tuple[int, int]:
        """(poses per sample, poses per coarse sample at most) of this schedule."""
        first = self._first_poses()
        return first, (max(first, self.max_poses_per_sample) if self.schedule == "fast" else first)

    def _first_poses(self):
        return self.poses_per_sample if self.poses_per_sample is not None else (6 if self.schedule == "fast" else 3)


def _positive(name, value, allow_zero=False):
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(float(value))
    if not ok or float(value) < 0.0 or (not allow_zero and float(value) == 0.0):
        raise ValueError(f"{name}: expected a finite number {'>=' if allow_zero else '>'} 0, got {value!r}")


def _integer(name, value, low):
    if isinstance(value, bool) or not isinstance(value, (numbers.Integral, np.integer)) or value < low:
        raise ValueError(f"{name}: expected an integer >= {low}, got {value!r}")


def with_overrides(cls, params, overrides: dict, what: str):
    """A validated copy of the parameter dataclass ``params`` (None: the defaults) with the fields in
    ``overrides`` replaced; ValueError for a field ``cls`` does not have."""
    out = cls(**asdict(params)) if params is not None else cls()
    names = {f.name for f in fields(cls)}
    for k, v in overrides.items():
        if k not in names:
            raise ValueError(f"unknown {what} parameter {k!r}")
        setattr(out, k, v)
    out.validate()
    return out
