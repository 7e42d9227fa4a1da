"""What a plan returns: the ranked :class:`Grasp` objects, the evaluated :class:`Candidate` records
and the :class:`PlanResult` with its grasps.json document."""
from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass
from typing import Dict, List, Optional, Tuple

import numpy as np

from .params import PlanParams

__all__ = ["Grasp", "Candidate", "PlanResult"]


@dataclass(frozen=True, eq=False)
class Grasp:
    """One planned grasp.

    Attributes:
        rank: 1 for the best.
        wrist_pose: (4,4) wrist frame in the target frame (m).
        dofs: (D,) closed DOF values, in the hand's DOF order.
        joints: {joint name: value} of every moving joint (mimics applied).
        epsilon, volume, force_closure: Ferrari-Canny quality of the contacts on free faces.
        alignment_quality: Q_A of the alignment the grasp came from.
        votes: rotation votes of that alignment.
        penetration_depth: largest penetration depth of the hand (m), within the tolerance.
        contact_points, contact_normals: (C,3) contacts and outward target normals.
        contact_links: link of each contact.
        sample: (D,) the DOF sample that was aligned.
        aligned_pose: (4,4) the aligned wrist pose before settling.
        backoff: distance the wrist backed off along the approach axis (m).
        fine_tuned: the grasp is a fine-tuning trial better than the planned one.
        force_closure_probability, robust_epsilon: the robust ranking's measures
            (:func:`pairgrasp.robust_quality`): the fraction of perturbed closings that are
            force-closure and the lower quartile of their epsilons; None when the plan ranked by
            epsilon.
        load_resistance: the least pure force at the centre of mass, per unit total normal force,
            that the contacts can exert along the six load directions
            (:func:`pairgrasp.load_resistance`); None in a grasps file written before it was recorded.
        opposition, drive: how squarely the contacts a closing DOF does not move push back against
            its push on the object, and how squarely it closes into the surface, each the least over
            the closing DOFs, in [-1, 1] (:func:`pairgrasp.closing_push`); None in a file written
            before they were recorded.
    """

    rank: int
    wrist_pose: np.ndarray
    dofs: np.ndarray
    joints: Dict[str, float]
    epsilon: float
    volume: float
    force_closure: bool
    alignment_quality: float
    votes: int
    penetration_depth: float
    contact_points: np.ndarray
    contact_normals: np.ndarray
    contact_links: Tuple[str, ...]
    sample: np.ndarray
    aligned_pose: np.ndarray
    backoff: float
    fine_tuned: bool
    force_closure_probability: Optional[float] = None
    robust_epsilon: Optional[float] = None
    load_resistance: Optional[float] = None
    opposition: Optional[float] = None
    drive: Optional[float] = None

    def to_dict(self) -> dict:
        """JSON-ready dictionary (the grasps.json schema)."""
        d = {
            "rank": self.rank,
            "wrist_pose": _round(self.wrist_pose),
            "dof": _round(self.dofs),
            "joints": {k: _round(v) for k, v in self.joints.items()},
            "epsilon": _round(self.epsilon),
            "volume": _round(self.volume),
            "force_closure": bool(self.force_closure),
            "alignment_quality": _round(self.alignment_quality),
            "votes": int(self.votes),
            "penetration_depth": _round(self.penetration_depth),
            "contacts": [{"point": _round(p), "normal": _round(n), "link": link}
                         for p, n, link in zip(self.contact_points, self.contact_normals, self.contact_links)],
            "sample": _round(self.sample),
            "aligned_pose": _round(self.aligned_pose),
            "backoff": _round(self.backoff),
            "fine_tuned": bool(self.fine_tuned),
        }
        if self.force_closure_probability is not None:
            d["force_closure_probability"] = _round(self.force_closure_probability)
            d["robust_epsilon"] = _round(self.robust_epsilon)
        if self.load_resistance is not None:
            d["load_resistance"] = _round(self.load_resistance)
        if self.opposition is not None:
            d["opposition"] = _round(self.opposition)
        if self.drive is not None:
            d["drive"] = _round(self.drive)
        return d


@dataclass(frozen=True)
class Candidate:
    """An evaluated candidate (for Figure 8): its sample index, Q_A, votes and outcome, and ``time``:
    seconds from the start of :meth:`Planner.plan` until its evaluation finished (index excluded)."""

    sample_index: int
    alignment_quality: float
    votes: int
    epsilon: float
    force_closure: bool
    settled: str  # "aligned" or "adjusted" (settling in candidates.hpp: kept as aligned, or moved least)
    time: float = 0.0

    @property
    def sample(self) -> int:
        """Deprecated name of ``sample_index`` (a grasp's ``sample`` is its DOF vector); warns."""
        warnings.warn("Candidate.sample is deprecated: use Candidate.sample_index", DeprecationWarning, stacklevel=2)
        return self.sample_index


@dataclass
class PlanResult:
    """What :meth:`Planner.plan` returns.

    Attributes:
        grasps: ranked grasps (at most ``params.top``), best first.
        candidates: every evaluated candidate, in evaluation order.
        timings: seconds per stage.
        counts: unit facets, stored pairs, DOF samples (scheduled, rejected, aligned), candidates
            (aligned poses, settled, evaluated), force-closure grasps.
        edge, d_max: the unit-facet edge and pair distance used (m).
        constellation, spacing: the constellation mode and spacing used.
        params: the parameters (defaults resolved).
        inputs: file names and hand/target summaries.
    """

    grasps: List[Grasp]
    candidates: List[Candidate]
    timings: Dict[str, float]
    counts: Dict[str, int]
    edge: float
    d_max: float
    constellation: str
    spacing: Optional[float]
    params: PlanParams
    inputs: dict

    @property
    def best_epsilon(self) -> float:
        return max((g.epsilon for g in self.grasps), default=0.0)

    def to_dict(self) -> dict:
        """The grasps.json document (timings under the top-level key ``timings``)."""
        return {
            "format": "pairgrasp.grasps/1",
            "inputs": self.inputs,
            # Every parameter but threads, which changes how the plan runs, not what it finds.
            "parameters": {**{k: v for k, v in asdict(self.params).items() if k != "threads"},
                           "poses_per_sample": self.params.poses()[0],
                           "edge": _round(self.edge), "d_max": _round(self.d_max),
                           "constellation": self.constellation,
                           "spacing": None if self.spacing is None else _round(self.spacing)},
            "counts": dict(self.counts),
            "timings": {k: round(v, 4) for k, v in self.timings.items()},
            "grasps": [g.to_dict() for g in self.grasps],
        }


def _round(x, digits: int = 9):
    """Floats rounded to `digits` decimals (nm / nrad), arrays to nested lists."""
    if isinstance(x, np.ndarray):
        return np.round(x.astype(float), digits).tolist()
    return round(float(x), digits)
