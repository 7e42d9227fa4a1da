"""Physics check of planned grasps: does the hand, closed on the object at the planned pose, hold it?

A static epsilon says a grasp *could* resist wrenches; this module closes the hand on the object in
MuJoCo (the ``mujoco`` package of the ``sim`` extra: ``pip install .[sim]``) and loads the grasp with
gravity along several directions and a shake, then measures how far the object moved relative to the
palm. The library imports and works without MuJoCo; only :class:`Simulator` and
:func:`simulate_grasps` need it.

The scene (:class:`Simulator`, compiled once per hand, target and obstacles):

* **Hand.** One body per link of the hand, rooted at its wrist link, which is fixed in the world: the
  simulation runs in the hand's frame (see *Loads*). Every non-fixed URDF joint is a MuJoCo hinge or
  slide joint with the URDF's axis and position limits. Each DOF of the hand spec has one position
  actuator on its first joint; the DOF's other joints and every URDF ``<mimic>`` joint follow through
  joint equality constraints (``polycoef``: q = offset + ratio q_master), which MuJoCo's own URDF
  importer would drop. The actuator's force is bounded by that joint's URDF ``effort`` (N·m or N)
  and each joint is damped by effort / velocity, so a saturated actuator closes the finger at no
  more than the URDF's velocity limit. Links collide as convex pieces (:func:`pairgrasp.convex_pieces`:
  the link mesh when it is convex, else CoACD parts, cached). Masses come from the URDF
  ``<inertial>`` when present, else from the link's solid at ``hand_density``. The hand does not
  collide with itself (the planner does not check self-collision either).
* **Target.** A free body whose mass, centre of mass and inertia tensor come from the watertight
  mesh and ``density`` (:func:`pairgrasp.mass_properties`; the convex parts overlap, so their
  volumes would overfill), or for an open mesh from its closed stand-in, its convex hull (measured:
  docs/physics.md), or from a given ``mass``; colliding as convex pieces (CoACD for
  non-convex targets).
* **Obstacles and occluders** of the plan: static (mocap) bodies of convex pieces, in the target
  frame. They take part while the hand closes and are moved away for the load phases, as when the
  object is lifted off a table or taken from the holder's hand.

The procedure (:meth:`Simulator.simulate`), times in :class:`SimParams`:

1. **Close.** The hand is placed at the wrist pose with every closing DOF opened by
   ``open_fraction`` of its range from the planned value; without gravity (the object rests as it
   was when the grasp was planned), each closing DOF is driven towards its closing limit with its
   bounded force, other DOFs (the Barrett spread) hold their planned values, for ``close_time``.
2. **Load.** Gravity is turned on along -z of the target frame (the object's "down": lifting it),
   then turned smoothly through +x, +y, -x, -y, +z and back to -z (as if the hand were turned
   through every orientation), holding each direction for ``hold_time``.
3. **Shake.** With gravity along -z, the hand is shaken along x, y and z in turn with a sinusoidal
   acceleration of amplitude ``shake_accel`` at ``shake_frequency``.

The simulation runs in the hand's frame: the hand is fixed and the loads are applied as the
gravity vector ``g - a`` (gravity minus the hand's acceleration), which is exact for a hand that
translates (the shake). For the turns it leaves out the rotating frame's terms: a 90° turn in
``turn_time`` = 0.25 s averages 6.3 rad/s, whose centrifugal acceleration omega² r is 4 m/s² at
0.1 m from the wrist, the order of the shake's 5 m/s² that every grasp then meets anyway.

**Success** is decided by the object's pose relative to the palm after closing against its pose
during the load and shake phases: the largest displacement of its centre of mass must stay below
``max_translation`` (10 mm) and its largest rotation below ``max_rotation`` (0.2 rad, 11.5°). An
object that is held moves by the contacts' compliance only (a few millimetres: see docs/physics.md
for measured figures), a dropped one falls without bound (the run stops once
it has moved 5 times the thresholds), and a grasp whose object has slid by more than a centimetre
(two of the planner's 5 mm unit facets) or turned by more than 11° no longer has the planned
contacts. :attr:`SimResult.outcome` tells a grasp that slipped but kept the object from one that
dropped it.
"""
from __future__ import annotations

import math
import os
import time
from dataclasses import asdict, dataclass, fields
from typing import List, Optional, Sequence

import numpy as np

from . import _core
from .convex import DEFAULT_THRESHOLD, convex_pieces
from .inertia import hull_mass_properties, mass_properties, solid_mass_properties
from .params import with_overrides
from .planner import as_mesh

__all__ = ["SimParams", "SimResult", "Simulator", "SimReport", "TrialNoise", "Trial", "trial_perturbations",
           "simulate_trials", "simulate_grasps", "verify_grasps", "import_mujoco", "load_phase"]

_G = 9.81


def import_mujoco():
    """The ``mujoco`` module, or ImportError naming the extra that installs it."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        raise ImportError("the physics check needs MuJoCo: pip install .[sim]") from None
    return mujoco


@dataclass
class SimParams:
    """Physical and procedural parameters of the physics check (SI units: m, kg, s, rad).

    Attributes:
        density: target density, kg/m³. 1000 (water; most plastics are 900-1400): the bundled
            targets weigh 0.15-0.43 kg.
        hand_density: density of hand links without a URDF ``<inertial>``, kg/m³. The root is fixed
            and the fingers are servoed, so their masses barely change the outcome.
        friction: Coulomb friction coefficient of every contact, the planner's mu (0.5: rubber or
            plastic finger pads on plastic or glass are 0.4-1.0).
        timestep: s. 1 ms with the implicit-fast integrator: 4 steps per contact time constant
            (``contact_timeconst``), stable in every run of the tests and the benchmark (the jaw's
            50 N on the 0.43 kg box, the Barrett's 5 N·m on the 0.15 kg mug).
        impratio: MuJoCo's ratio of frictional to normal constraint impedance; 10 with elliptic
            friction cones (MuJoCo's recommendation for grasping) keeps a static grasp from creeping.
        effort_scale: factor on every URDF ``effort`` (actuator force bound).
        hold_fraction: a DOF's actuator is a position servo that reaches its force bound at an
            error of this fraction of the DOF's range (kp = effort / (hold_fraction * range)). A
            DOF that does not close the hand (the Barrett spread) holds its planned value with it; a
            closing DOF is commanded one range beyond its closing limit, so it always pushes with
            its full bounded force, like a hand's motors closing until they stall.
        open_fraction: fraction of a closing DOF's range the fingers are opened by before closing
            (0.02: 0.049 rad on a Barrett flexion, 6 mm at its fingertip; 1.6 mm on the jaw). The
            planned DOFs touch within the planner's 1 mm gap and penetrate by at most h/4, so this
            clears them while keeping the re-closing short, so that the fingers reach the object
            nearly together as in the plan; at 0.05 the first finger to arrive pushed the flask by
            up to 27 mm before the others caught it.
        close_time: s of closing, without gravity.
        turn_time, hold_time: s to turn gravity by 90° and to hold each direction.
        shake_time: s of shaking per axis (x, y, z).
        shake_accel: amplitude of the shake's acceleration, m/s² (5: half of g, a brisk 3 cm shake at
            2 Hz).
        shake_frequency: Hz.
        max_translation: success threshold on the displacement of the object's centre of mass
            relative to the palm, m.
        max_rotation: success threshold on the object's rotation relative to the palm, rad.
        convex_threshold: CoACD concavity threshold for non-convex targets, links and obstacles.
        contact_timeconst: s, MuJoCo's contact time constant (solref). 0.004 (4 timesteps; MuJoCo's
            stability floor is 2): at MuJoCo's default 0.02 the Barrett fingers, pressing with their
            5 N·m, sank 8 mm into the flask, a geometry the plan never had; at 0.004 they sink
            ~0.6 mm, a rubber pad's compression.
        contact_dmax: MuJoCo's contact impedance at full penetration (solimp dmax; its default).
        lift_distance: m the obstacles recede along the lift direction while gravity fades in
            (the first ``turn_time``), before they are taken away: the hand lifts the object off the
            table at about 0.1 m/s instead of the table vanishing. A palm that rests on an object
            standing on a table presses it against the table while the fingers close (a millimetre
            of the convex pieces' overlap at the contact stiffness is hundreds of newtons); taken
            away at once, the table released that compression in one step and threw the object out
            of hands that held it once the table receded (measured: docs/physics.md).
    """

    density: float = 1000.0
    hand_density: float = 1000.0
    friction: float = 0.5
    timestep: float = 0.001
    impratio: float = 10.0
    effort_scale: float = 1.0
    hold_fraction: float = 0.02
    open_fraction: float = 0.02
    close_time: float = 0.6
    turn_time: float = 0.25
    hold_time: float = 0.25
    shake_time: float = 0.5
    shake_accel: float = 5.0
    shake_frequency: float = 2.0
    max_translation: float = 0.01
    max_rotation: float = 0.2
    convex_threshold: float = DEFAULT_THRESHOLD
    contact_timeconst: float = 0.004
    contact_dmax: float = 0.95
    lift_distance: float = 0.03

    def validate(self) -> None:
        """Raises ValueError naming the first bad field."""
        for f in fields(self):
            v = getattr(self, f.name)
            zero_ok = f.name in ("open_fraction", "shake_time", "shake_accel", "hold_time", "lift_distance")
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0 \
                    or (v == 0 and not zero_ok):
                raise ValueError(f"{f.name}: expected a finite number {'>=' if zero_ok else '>'} 0, got {v!r}")
        if self.open_fraction >= 1:
            raise ValueError(f"open_fraction: expected a number in [0, 1), got {self.open_fraction!r}")
        if self.convex_threshold > 1:
            raise ValueError(f"convex_threshold: expected a number in (0, 1], got {self.convex_threshold!r}")
        if self.timestep > 0.01:
            raise ValueError(f"timestep: {self.timestep:g} s is too long for contact dynamics (at most 0.01 s)")

    @property
    def duration(self) -> float:
        """Simulated time of the whole procedure, s."""
        return self.close_time + 8 * self.turn_time + 8 * self.hold_time + 3 * self.shake_time


@dataclass(frozen=True)
class SimResult:
    """Outcome of one simulated grasp.

    Attributes:
        success: the object stayed within both thresholds over the load and shake phases.
        outcome: ``"held"``, ``"slipped"`` (moved beyond a threshold but stayed in the hand),
            ``"dropped"`` (moved 5 times a threshold: the run stops there) or ``"unstable"`` (the
            integration diverged; slips are infinite; not seen with the default parameters).
        slip_translation: largest displacement of the object's centre of mass relative to the palm
            after closing, m.
        slip_rotation: largest rotation of the object relative to the palm after closing, rad.
        closing_translation, closing_rotation: how far the object moved while the hand closed, m, rad.
        contact_links: hand links touching the object at the end of closing.
        time_simulated: s of simulated time.
        wall_time: s of computer time for this grasp (CPU).
        failed_phase: None for a held grasp; else where the object first left a threshold:
            ``"closing"`` (it moved beyond them while the hand closed), or the load phase of
            :func:`load_phase` (``"lift"``, ``"hold -z"``, ``"turn +x"``, ..., ``"shake z"``).
        start_backoff: how far (m) the hand was moved back along its approach before closing, so
            that the links no closing DOF moves (the palm) start touching the object, not inside it.
    """

    success: bool
    outcome: str
    slip_translation: float
    slip_rotation: float
    closing_translation: float
    closing_rotation: float
    contact_links: tuple
    time_simulated: float
    wall_time: float
    failed_phase: Optional[str] = None
    start_backoff: float = 0.0

    def to_dict(self) -> dict:
        """JSON-ready (an unstable run's infinite slips are null)."""
        def num(x):
            return round(float(x), 9) if math.isfinite(x) else None
        return {"success": bool(self.success), "outcome": self.outcome,
                "slip_translation": num(self.slip_translation), "slip_rotation": num(self.slip_rotation),
                "closing_translation": round(float(self.closing_translation), 9),
                "closing_rotation": round(float(self.closing_rotation), 9),
                "contact_links": list(self.contact_links),
                "time_simulated": round(float(self.time_simulated), 6),
                "wall_time": round(float(self.wall_time), 4), "failed_phase": self.failed_phase,
                "start_backoff": round(float(self.start_backoff), 9)}


def _as_pose(T, where) -> np.ndarray:
    T = np.asarray(T, float)
    if T.shape != (4, 4) or not np.isfinite(T).all():
        raise ValueError(f"{where}: expected a finite 4x4 pose")
    R = T[:3, :3]
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0:
        raise ValueError(f"{where}: the rotation part is not a rotation")
    return T


def _quat(R) -> np.ndarray:
    """MuJoCo quaternion (w, x, y, z) of a rotation matrix."""
    mujoco = import_mujoco()
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, float).ravel())
    return q


def _rotation_angle(R) -> float:
    return float(math.acos(max(-1.0, min(1.0, (np.trace(R) - 1.0) / 2.0))))


@dataclass(frozen=True)
class TrialNoise:
    """The execution and model errors of perturbed trials (trial 0 is always as planned).

    Attributes:
        translation_sigma: wrist offset, normal per axis of the target frame, m (1 mm).
        rotation_sigma: wrist rotation about a uniformly random axis through the wrist origin,
            normal, rad (1 degree).
        friction: friction coefficient, uniform in this interval.
        density: target density, kg/m³, uniform in this interval.
    """

    translation_sigma: float = 0.001
    rotation_sigma: float = math.radians(1.0)
    friction: tuple = (0.4, 0.6)
    density: tuple = (500.0, 1500.0)

    def validate(self) -> None:
        """Raises ValueError naming the first bad field."""
        for name in ("translation_sigma", "rotation_sigma"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise ValueError(f"{name}: expected a finite number >= 0, got {v!r}")
        for name, low in (("friction", 0.0), ("density", 1e-9)):
            v = getattr(self, name)
            ok = isinstance(v, (tuple, list)) and len(v) == 2 and all(
                isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v)
            if not ok or not low <= v[0] <= v[1]:
                raise ValueError(f"{name}: expected an interval (low, high) with {low:g} <= low <= high, got {v!r}")


@dataclass(frozen=True)
class Trial:
    """One trial's perturbation: ``offset`` (4x4) is applied to the planned wrist pose in the target
    frame (:meth:`apply`); ``friction`` and ``density`` are None for trial 0 (the simulator's own)."""

    index: int
    offset: np.ndarray
    friction: Optional[float]
    density: Optional[float]

    def apply(self, wrist_pose) -> np.ndarray:
        """The perturbed wrist pose: rotated by the offset's rotation about the wrist origin, then
        moved by its translation (both in the target frame)."""
        T = np.asarray(wrist_pose, float)
        P = T.copy()
        P[:3, :3] = self.offset[:3, :3] @ T[:3, :3]
        P[:3, 3] = T[:3, 3] + self.offset[:3, 3]
        return P

    def to_dict(self) -> dict:
        angle = _rotation_angle(self.offset[:3, :3])
        return {"wrist_offset": [round(float(x), 9) for x in self.offset[:3, 3]],
                "wrist_rotation": round(angle, 9), "friction": self.friction, "density": self.density}


def trial_perturbations(n: int, seed: int = 0, noise: Optional[TrialNoise] = None) -> List[Trial]:
    """The perturbations of ``n`` trials: trial 0 as planned, trial k >= 1 drawn from
    ``numpy.random.default_rng([seed, k])`` with the :class:`TrialNoise` model. Trial k's
    perturbation depends only on (seed, k), so every grasp simulated with a seed meets the same
    errors (a paired comparison of grasps and rankings)."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"trials: expected an integer >= 1, got {n!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed: expected an integer >= 0, got {seed!r}")
    noise = noise or TrialNoise()
    noise.validate()
    out = [Trial(0, np.eye(4), None, None)]
    for k in range(1, int(n)):
        rng = np.random.default_rng([int(seed), k])
        axis = rng.normal(size=3)
        axis /= max(np.linalg.norm(axis), 1e-12)
        angle = rng.normal(0.0, noise.rotation_sigma)
        K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        D = np.eye(4)
        D[:3, :3] = np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K
        D[:3, 3] = rng.normal(0.0, noise.translation_sigma, size=3)
        out.append(Trial(k, D, float(rng.uniform(*noise.friction)), float(rng.uniform(*noise.density))))
    return out


def _smoothstep(s: float) -> float:
    """0 at 0, 1 at 1, with zero slope at both ends: the easing of every ramp of the procedure."""
    return s * s * (3 - 2 * s)


def _slerp_dir(a, b, s) -> np.ndarray:
    """Unit vector a fraction s (smoothstep-eased) of the way from a to b on the great circle."""
    s = _smoothstep(s)
    ang = math.acos(max(-1.0, min(1.0, float(a @ b))))
    if ang < 1e-9:
        return a.copy()
    return (math.sin((1 - s) * ang) * a + math.sin(s * ang) * b) / math.sin(ang)


# Gravity directions of the load phase, target frame: each 90° from the next, so the turn between
# consecutive ones is a well-defined great-circle arc.
_DIRECTIONS = np.array([[0, 0, -1], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [0, 0, 1], [1, 0, 0],
                        [0, 0, -1]], float)


def load_profile(params: SimParams, t: float) -> Optional[np.ndarray]:
    """Gravity minus the hand's acceleration (m/s², target frame) at time t after closing; None past
    the end of the procedure."""
    ramp = params.turn_time
    seg = params.turn_time + params.hold_time
    if t < ramp:                                     # gravity fades in along -z
        s = t / ramp
        return _G * _smoothstep(s) * _DIRECTIONS[0]
    t -= ramp
    if t < params.hold_time:
        return _G * _DIRECTIONS[0]
    t -= params.hold_time
    for a, b in zip(_DIRECTIONS[:-1], _DIRECTIONS[1:]):
        if t < seg:
            return _G * (_slerp_dir(a, b, t / params.turn_time) if t < params.turn_time else b)
        t -= seg
    for axis in range(3):
        if t < params.shake_time:
            g = _G * _DIRECTIONS[-1].copy()
            g[axis] -= params.shake_accel * math.sin(2 * math.pi * params.shake_frequency * t)
            return g
        t -= params.shake_time
    return None


_AXIS_NAMES = {(0, 0, -1): "-z", (1, 0, 0): "+x", (0, 1, 0): "+y", (-1, 0, 0): "-x", (0, -1, 0): "-y",
               (0, 0, 1): "+z"}


def load_phase(params: SimParams, t: float) -> Optional[str]:
    """Name of the load phase at time t after closing (as :func:`load_profile` runs them): ``"lift"``
    (gravity fades in along -z while the obstacles recede), ``"hold -z"``, then ``"turn D"`` and
    ``"hold D"`` for each gravity direction D in turn, ``"shake x"``, ``"shake y"``, ``"shake z"``;
    None past the end."""
    if t < params.turn_time:
        return "lift"
    t -= params.turn_time
    if t < params.hold_time:
        return "hold -z"
    t -= params.hold_time
    for b in _DIRECTIONS[1:]:
        name = _AXIS_NAMES[tuple(int(v) for v in b)]
        if t < params.turn_time + params.hold_time:
            return ("turn " if t < params.turn_time else "hold ") + name
        t -= params.turn_time + params.hold_time
    for axis in "xyz":
        if t < params.shake_time:
            return "shake " + axis
        t -= params.shake_time
    return None


class Simulator:
    """The MuJoCo scene of one hand, target and set of obstacles, compiled once; :meth:`simulate`
    runs the procedure of the module documentation for one grasp.

    Args:
        hand: a :class:`pairgrasp.Hand` or the path of a hand spec.
        target: a :class:`pairgrasp.Mesh` or a mesh path (metres). Its mass and inertia come from its
            solid when it is closed, else from a closed stand-in (:func:`pairgrasp.inertia.solid_mass_properties`).
        mass: the target's mass (kg) instead of its volume times ``density`` (the shape's inertia is
            scaled to it).
        obstacles: meshes (or paths) in the target frame: the plan's obstacles and occluders.
        lift_direction: the direction (target frame) the hand lifts the object in when the load
            begins: the obstacles recede the opposite way (``SimParams.lift_distance``) before
            they are taken away. +z (the load's first gravity is -z); a support plane's normal.
        params: :class:`SimParams`; keyword arguments override its fields.

    Attributes:
        spec: the ``mujoco.MjSpec`` (``spec.to_xml()`` gives the scene as MJCF).
        model: the compiled ``mujoco.MjModel``.
        counts: numbers of bodies, joints, equality constraints, actuators, geoms, convex pieces per
            part, checked against the hand when the scene is built.
        target_mass: kg.
        target_mass_source: where the mass and inertia come from (``"solid"``, ``"convex hull (not
            closed)"``, ...: :func:`pairgrasp.inertia.solid_mass_properties`).

    Raises:
        ImportError: MuJoCo is not installed.
        ValueError: bad parameters or mass, a DOF joint without an effort limit.
    """

    def __init__(self, hand, target, obstacles: Sequence = (), params: Optional[SimParams] = None,
                 mass: Optional[float] = None, lift_direction=(0.0, 0.0, 1.0), **overrides):
        mujoco = import_mujoco()
        self.params = with_overrides(SimParams, params, overrides, "simulation")
        lift = np.asarray(lift_direction, float).reshape(-1)
        if lift.shape != (3,) or not np.isfinite(lift).all() or np.linalg.norm(lift) < 1e-9:
            raise ValueError(f"lift_direction: expected a finite nonzero 3-vector, got {lift_direction!r}")
        self.lift_direction = lift / np.linalg.norm(lift)
        p = self.params
        self.hand = hand if isinstance(hand, _core.Hand) else _core.load_hand(os.fspath(hand))
        self.target = as_mesh(target, "target")
        self.obstacles = [as_mesh(o, "obstacle") for o in obstacles]
        target_pieces = convex_pieces(self.target, threshold=p.convex_threshold)
        props, self.target_mass_source = solid_mass_properties(self.target, p.density, target_pieces, mass)
        self.target_mass = props.mass

        spec = mujoco.MjSpec()
        spec.modelname = f"pairgrasp_{self.hand.name}"
        spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
        spec.compiler.autolimits = True
        spec.compiler.degree = False                        # joint ranges in radians, as in the URDF
        spec.option.timestep = p.timestep
        spec.option.gravity = [0.0, 0.0, 0.0]
        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
        spec.option.impratio = p.impratio
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        self.counts = {"pieces": {}}
        # contype/conaffinity: the hand (1) touches the target (2) and obstacles (4); the target
        # touches the obstacles; nothing touches itself.
        self._add_hand(spec, mujoco)
        tb = spec.worldbody.add_body(name="target")
        tb.add_freejoint(name="target_free")
        tb.explicitinertial = True
        tb.mass = props.mass
        tb.ipos = props.center_of_mass
        I = props.inertia
        tb.fullinertia = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
        n = self._add_pieces(spec, tb, "target", target_pieces, contype=2, conaffinity=1 | 4)
        self.counts["pieces"]["target"] = n
        self._obstacle_bodies = []
        for k, mesh in enumerate(self.obstacles):
            ob = spec.worldbody.add_body(name=f"obstacle_{k}", mocap=True)
            n = self._add_pieces(spec, ob, f"obstacle_{k}", convex_pieces(mesh, threshold=p.convex_threshold),
                                 contype=4, conaffinity=1 | 2)
            self.counts["pieces"][f"obstacle_{k}"] = n
            self._obstacle_bodies.append(ob.name)
        self.spec = spec
        self.model = spec.compile()
        self._check_counts(mujoco)
        m = self.model
        self._target_body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "target")
        self._target_qadr = m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "target_free")]
        self._target_geoms = set(np.nonzero(m.geom_bodyid == self._target_body)[0].tolist())
        self._palm_body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, self.hand.wrist_link)
        self._mocap = [m.body_mocapid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b)] for b in self._obstacle_bodies]
        self._qadr = {j: int(m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j)])
                      for j in self.hand.joint_names}
        # Links no closing DOF moves (the palm; the Barrett knuckles turn with the spread only).
        h = self.hand
        lo, hi = np.asarray(h.dof_lower, float), np.asarray(h.dof_upper, float)
        mid = (lo + hi) / 2
        closing = np.asarray(_core.closing_directions(h, mid), float)
        T0, T1 = h.link_transforms(mid), h.link_transforms(mid + 0.1 * closing * (hi - lo))
        static = {n for n in T0 if np.abs(np.asarray(T0[n]) - np.asarray(T1[n])).max() < 1e-12}
        self._static_geoms = [g for g in range(m.ngeom) if g not in self._target_geoms and
                              mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[g])) in static]

    # ----- scene construction -----

    def _add_pieces(self, spec, body, name, pieces, contype, conaffinity) -> int:
        mujoco = import_mujoco()
        for k, piece in enumerate(pieces):
            mname = f"{name}_{k}"
            mesh = spec.add_mesh(name=mname)
            mesh.uservert = np.asarray(piece, float).ravel().tolist()
            mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
            g = body.add_geom(name=mname, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=mname)
            g.contype, g.conaffinity = contype, conaffinity
            g.condim = 3
            g.friction = [self.params.friction, 0.0, 0.0]
            g.solref = [self.params.contact_timeconst, 1.0]
            g.solimp = [min(0.9, self.params.contact_dmax), self.params.contact_dmax, 0.001, 0.5, 2.0]
        return len(pieces)

    def _add_hand(self, spec, mujoco) -> None:
        h, p = self.hand, self.params
        joints = h.joints
        links = {link.name: link for link in h.links}
        bodies = {}
        root = h.link_names[0]
        bodies[root] = spec.worldbody.add_body(name=root)          # fixed in the world: the hand's frame
        for j in joints:                                            # depth-first: parents come first
            b = bodies[j.parent_link].add_body(name=j.child_link)
            b.pos = j.origin[:3, 3]
            b.quat = _quat(j.origin[:3, :3])
            bodies[j.child_link] = b
            if j.type == _core.JointType.fixed:
                continue
            mj = b.add_joint(name=j.name)
            mj.type = mujoco.mjtJoint.mjJNT_SLIDE if j.type == _core.JointType.prismatic else mujoco.mjtJoint.mjJNT_HINGE
            mj.axis = j.axis
            if j.limited:
                mj.limited = mujoco.mjtLimited.mjLIMITED_TRUE
                mj.range = [j.lower, j.upper]
            if j.effort > 0 and j.velocity > 0:
                mj.damping = [p.effort_scale * j.effort / j.velocity, 0.0, 0.0]   # linear term only
        for name, b in bodies.items():
            self._set_link_inertia(b, name, links.get(name))
            if name in links:
                n = self._add_pieces(spec, b, name, convex_pieces(links[name].mesh, threshold=p.convex_threshold),
                                     contype=1, conaffinity=0)
                self.counts["pieces"][name] = n
        # Couplings: a DOF's joints after its first, and URDF mimic joints, as joint equalities
        # q = c0 + c1 q_master.
        self._couplings = []
        for dof in h.dofs:
            j0 = dof.joints[0]
            for jk in dof.joints[1:]:
                c1 = jk.ratio / j0.ratio
                self._couplings.append((jk.joint, j0.joint, jk.offset - c1 * j0.offset, c1))
        for j in joints:
            if j.mimic_joint:
                self._couplings.append((j.name, j.mimic_joint, j.offset, j.multiplier))
        for slave, master, c0, c1 in self._couplings:
            e = spec.add_equality(name=f"couple_{slave}")
            e.type = mujoco.mjtEq.mjEQ_JOINT
            e.objtype = mujoco.mjtObj.mjOBJ_JOINT
            e.name1, e.name2 = slave, master
            data = np.zeros(len(e.data))
            data[:2] = c0, c1                                   # polycoef: q1 = c0 + c1 q2
            e.data = data
            e.solref = [0.005, 1.0]
        # One position actuator per DOF on its first joint, force bounded by the joint's effort.
        by_name = {j.name: j for j in joints}
        self._actuated = []
        for dof in h.dofs:
            j0 = dof.joints[0]
            uj = by_name[j0.joint]
            if not uj.effort > 0:
                raise ValueError(f"{h.urdf_path}: joint '{uj.name}' (DOF {dof.name}) has no <limit effort>, so its "
                                 f"actuator force cannot be bounded")
            force = p.effort_scale * uj.effort
            span = abs(j0.ratio) * (dof.upper - dof.lower)          # the DOF's range in joint units
            a = spec.add_actuator(name=f"dof_{dof.name}", target=j0.joint)
            a.trntype = mujoco.mjtTrn.mjTRN_JOINT
            a.set_to_position(kp=force / (p.hold_fraction * max(span, 1e-9)))
            a.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            a.forcerange = [-force, force]
            self._actuated.append((dof, j0))

    def _set_link_inertia(self, body, name, link):
        body.explicitinertial = True
        inertial = self.hand.inertial(name)
        if inertial.present and inertial.mass > 0:
            F = inertial.frame
            body.mass = inertial.mass
            body.ipos = F[:3, 3]
            I = F[:3, :3] @ inertial.inertia @ F[:3, :3].T
        else:
            mp = None
            if link is not None:
                mesh = link.mesh if link.mesh.closed else None
                try:
                    if mesh is not None:
                        mp = mass_properties(mesh, self.params.hand_density)
                    else:
                        mp = hull_mass_properties(link.mesh.vertices, self.params.hand_density)
                except ValueError:
                    mp = None
            if mp is None:   # no geometry: a 1 g point mass with the inertia of a 1 cm sphere
                body.mass, body.ipos, I = 1e-3, np.zeros(3), np.eye(3) * 0.4 * 1e-3 * 0.01 ** 2
            else:
                body.mass, body.ipos, I = mp.mass, mp.center_of_mass, mp.inertia
        # MuJoCo needs a positive definite tensor that satisfies the triangle inequality.
        w = np.linalg.eigvalsh(I)
        floor = 1e-9 + 1e-3 * w.max()
        I = I + np.eye(3) * max(0.0, floor - w.min())
        body.fullinertia = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]

    def _check_counts(self, mujoco):
        m, h = self.model, self.hand
        movable = [j for j in h.joints if j.type != _core.JointType.fixed]
        mimics = sum(1 for j in h.joints if j.mimic_joint)
        extra = sum(len(d.joints) - 1 for d in h.dofs)
        expected = {"bodies": len(h.link_names) + 1 + len(self.obstacles) + 1, "joints": len(movable) + 1,
                    "equalities": mimics + extra, "actuators": len(h.dofs)}
        got = {"bodies": m.nbody, "joints": m.njnt, "equalities": m.neq, "actuators": m.nu}
        if got != expected:
            raise RuntimeError(f"MuJoCo scene: expected {expected}, compiled {got}")
        for j in movable:
            k = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j.name)
            if j.limited and (not m.jnt_limited[k] or not np.allclose(m.jnt_range[k], [j.lower, j.upper])):
                raise RuntimeError(f"MuJoCo scene: joint {j.name} lost its URDF limits")
        self.counts.update(got, geoms=int(m.ngeom), mimics=mimics, dof_couplings=extra)

    # ----- simulation -----

    def simulate(self, wrist_pose, dofs, friction: Optional[float] = None, density: Optional[float] = None,
                 until: Optional[float] = None) -> SimResult:
        """Closes the hand at ``wrist_pose`` (wrist frame in the target frame, 4x4) from ``dofs``
        (the planned closed DOF values, opened by ``open_fraction`` first), loads and shakes the
        grasp, and returns the outcome. ``friction`` and ``density`` override the parameters for
        this run (for robustness trials). ``until``: s of the load procedure after closing to run
        (None: all of it; 0: the closing alone; ``turn_time``: the closing and the lift), for a
        cheap check; the outcome then covers what ran.

        Raises:
            ValueError: a pose that is not rigid, DOF values of the wrong size or out of the limits,
                a negative or non-finite ``until``.
        """
        if until is not None and (isinstance(until, bool) or not isinstance(until, (int, float))
                                  or not math.isfinite(until) or until < 0):
            raise ValueError(f"until: expected a finite number >= 0 (s), got {until!r}")
        mujoco = import_mujoco()
        t_wall = time.perf_counter()
        p, h, m = self.params, self.hand, self.model
        W = _as_pose(wrist_pose, "wrist_pose")
        q = np.asarray(dofs, float).reshape(-1)
        lo, hi = np.asarray(h.dof_lower, float), np.asarray(h.dof_upper, float)
        h.joint_values(q)                                   # size, finiteness and limits, named errors
        dirs = np.asarray(_core.closing_directions(h, q), float).reshape(-1)
        start = np.clip(q - dirs * p.open_fraction * (hi - lo), lo, hi)
        goal = np.where(dirs > 0, 2 * hi - lo, np.where(dirs < 0, 2 * lo - hi, q))   # one range past the limit

        # The hand's root (its wrist link) frame is the world: objects in the target frame are placed by inv(W).
        to_world = np.linalg.inv(W)
        Rw = to_world[:3, :3]
        d = mujoco.MjData(m)
        saved = self._override(friction, density)
        try:
            for name, v in h.joint_values(start).items():
                d.qpos[self._qadr[name]] = v
            a = self._target_qadr
            d.qpos[a:a + 3] = to_world[:3, 3]
            d.qpos[a + 3:a + 7] = _quat(Rw)
            for mid in self._mocap:
                d.mocap_pos[mid] = to_world[:3, 3]
                d.mocap_quat[mid] = _quat(Rw)
            for k, (dof, j0) in enumerate(self._actuated):
                i = h.dof_names.index(dof.name)
                d.ctrl[k] = j0.ratio * goal[i] + j0.offset
            mujoco.mj_forward(m, d)
            # Closing starts touching, not overlapping: the links no closing DOF moves (the palm)
            # are moved back along the approach out of the object's convex pieces (the plan allows
            # them a small depth; a penalty contact would resolve it in a few steps and throw the
            # object out of the hand). In the hand's frame the object and the obstacles move instead.
            approach = np.asarray(h.approach, float)
            start_backoff = 0.0
            for _ in range(4):
                depth = self._static_depth(d)
                if depth <= 1e-5:
                    break
                step = depth + 1e-4
                start_backoff += step
                d.qpos[a:a + 3] += step * approach
                for mid in self._mocap:
                    d.mocap_pos[mid] += step * approach
                mujoco.mj_forward(m, d)
            to_world = to_world.copy()
            to_world[:3, 3] += start_backoff * approach
            n_close = int(round(p.close_time / p.timestep))
            m.opt.gravity[:] = 0.0
            T0 = self._relative(d)
            for _ in range(n_close):
                mujoco.mj_step(m, d)
            # MuJoCo resets a diverged state to the initial one and counts a warning: both are failures
            bad = mujoco.mjtWarning.mjWARN_BADQACC
            warned = 0
            unstable = not np.isfinite(d.qpos).all() or d.warning[bad].number > warned
            T1 = self._relative(d) if not unstable else T0
            closing_t = float(np.linalg.norm(T1[:3, 3] - T0[:3, 3]))
            closing_r = _rotation_angle(T0[:3, :3].T @ T1[:3, :3])
            touching = self._touching(d)
            recede = Rw @ (-self.lift_direction)            # world direction the obstacles move in
            lifted = not self._mocap
            slip_t = slip_r = 0.0
            outcome = "held"
            failed = "closing" if closing_t > p.max_translation or closing_r > p.max_rotation else None
            t = 0.0
            check_every = max(1, int(round(0.005 / p.timestep)))
            step = 0
            while not unstable:
                g = load_profile(p, t) if until is None or t < until else None
                if g is None:
                    break
                if not lifted:                              # lift: the obstacles recede, then go away
                    if t < p.turn_time:
                        s = t / p.turn_time
                        for mid in self._mocap:
                            d.mocap_pos[mid] = to_world[:3, 3] + recede * p.lift_distance * _smoothstep(s)
                    else:
                        for mid in self._mocap:
                            d.mocap_pos[mid] = [1e3, 1e3, 1e3]
                        lifted = True
                m.opt.gravity[:] = Rw @ g
                mujoco.mj_step(m, d)
                t += p.timestep
                step += 1
                if step % check_every == 0:
                    if not np.isfinite(d.qpos).all() or d.warning[bad].number > warned:
                        unstable = True
                        break
                    T = self._relative(d)
                    slip_t = max(slip_t, float(np.linalg.norm(T[:3, 3] - T1[:3, 3])))
                    slip_r = max(slip_r, _rotation_angle(T1[:3, :3].T @ T[:3, :3]))
                    if failed is None and (slip_t > p.max_translation or slip_r > p.max_rotation):
                        failed = load_phase(p, t)
                    if slip_t > 5 * p.max_translation or slip_r > 5 * p.max_rotation:
                        outcome = "dropped"
                        break
            if unstable:
                outcome, slip_t, slip_r = "unstable", math.inf, math.inf
                failed = failed or (load_phase(p, t) if t > 0 else "closing")
            elif outcome == "held" and (slip_t > p.max_translation or slip_r > p.max_rotation):
                outcome = "slipped"
        finally:
            self._restore(saved)
            m.opt.gravity[:] = 0.0
        return SimResult(success=outcome == "held", outcome=outcome, slip_translation=slip_t, slip_rotation=slip_r,
                         closing_translation=closing_t, closing_rotation=closing_r, contact_links=touching,
                         time_simulated=p.close_time + t, wall_time=time.perf_counter() - t_wall,
                         failed_phase=None if outcome == "held" else failed, start_backoff=start_backoff)

    def _override(self, friction, density):
        m = self.model
        saved = (m.geom_friction.copy(), m.body_mass.copy(), m.body_inertia.copy())
        if friction is not None:
            if not (np.isfinite(friction) and friction >= 0):
                raise ValueError(f"friction: expected a finite number >= 0, got {friction!r}")
            m.geom_friction[:, 0] = friction
        if density is not None:
            if not (np.isfinite(density) and density > 0):
                raise ValueError(f"density: expected a finite number > 0, got {density!r}")
            s = density / self.params.density
            m.body_mass[self._target_body] *= s
            m.body_inertia[self._target_body] *= s
            self._set_const()
        return saved + (density is not None,)

    def _restore(self, saved):
        m = self.model
        m.geom_friction[:], m.body_mass[:], m.body_inertia[:] = saved[:3]
        if saved[3]:
            self._set_const()

    def _set_const(self):
        """Recomputes the constants MuJoCo derives from the masses (the constraints' mass scaling)."""
        mujoco = import_mujoco()
        mujoco.mj_setConst(self.model, mujoco.MjData(self.model))

    def _static_depth(self, d) -> float:
        """Deepest overlap (m) of a link no closing DOF moves with the target's convex pieces."""
        mujoco = import_mujoco()
        fromto = np.zeros(6)
        depth = 0.0
        for g1 in self._static_geoms:
            for g2 in self._target_geoms:
                depth = max(depth, -float(mujoco.mj_geomDistance(self.model, d, g1, g2, 0.01, fromto)))
        return depth

    def _relative(self, d) -> np.ndarray:
        """Pose of the target's body frame in the palm frame, with the centre of mass as translation."""
        b, w = self._target_body, self._palm_body
        Rp = d.xmat[w].reshape(3, 3)
        Ro = d.xmat[b].reshape(3, 3)
        T = np.eye(4)
        T[:3, :3] = Rp.T @ Ro
        T[:3, 3] = Rp.T @ (d.xipos[b] - d.xpos[w])
        return T

    def _touching(self, d) -> tuple:
        m = self.model
        mujoco = import_mujoco()
        links = set()
        for c in d.contact[: d.ncon]:
            g1, g2 = int(c.geom1), int(c.geom2)
            if (g1 in self._target_geoms) != (g2 in self._target_geoms):
                other = g2 if g1 in self._target_geoms else g1
                body = m.geom_bodyid[other]
                name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, body)
                if not name.startswith("obstacle_"):
                    links.add(name)
        return tuple(sorted(links))


def simulate_trials(sim: "Simulator", wrist_pose, dofs, trials: Sequence[Trial]) -> List[SimResult]:
    """Simulates one grasp once per trial (:func:`trial_perturbations`): the wrist pose perturbed by
    the trial's offset, with its friction and density."""
    return [sim.simulate(t.apply(wrist_pose), dofs, friction=t.friction, density=t.density) for t in trials]


def _trials_record(trials: Sequence[Trial], results: Sequence[SimResult]) -> dict:
    """A grasp's ``simulation`` object: trial 0's outcome, every trial and the success rate."""
    rec = results[0].to_dict()
    rec["trials"] = [{**r.to_dict(), **t.to_dict()} for t, r in zip(trials, results)]
    rec["success_rate"] = round(sum(r.success for r in results) / len(results), 9)
    return rec


@dataclass
class SimReport:
    """What :func:`simulate_grasps` returns: the results of the simulated grasps (file order; trial
    0, as planned), every trial's (``trials[i][k]``), their ranks and epsilons, the simulator's
    scene counts, the target's mass (kg) and where it came from
    (:attr:`Simulator.target_mass_source`) and the path written."""

    results: List[SimResult]
    ranks: List[int]
    epsilons: List[float]
    counts: dict
    params: SimParams
    path: str
    target_mass: float
    target_mass_source: str
    picture: Optional[str]
    trials: List[List[SimResult]]

    @property
    def success_rates(self) -> List[float]:
        """Per grasp, the fraction of its trials that held."""
        return [sum(r.success for r in rs) / len(rs) for rs in self.trials]


def simulate_grasps(path, top: Optional[int] = None, hand=None, target=None, params: Optional[SimParams] = None,
                    picture: bool = True, progress=None, trials: int = 1, seed: int = 0,
                    noise: Optional[TrialNoise] = None, mass: Optional[float] = None, **overrides) -> SimReport:
    """Simulates the first ``top`` grasps of a grasps.json file ``trials`` times each (trial 0 as
    planned, the others perturbed: :func:`trial_perturbations` with ``seed`` and ``noise``) and
    writes each outcome into it, as ``grasps[i].simulation`` (trial 0's :meth:`SimResult.to_dict`,
    plus ``trials``: every trial's outcome with its perturbation, and ``success_rate``), with the
    parameters under the top-level ``simulation`` key, and a picture of epsilon against the outcome
    as planned beside it (``simulation.png``). ``mass``: the target's mass (kg) instead of its
    volume times the density (:class:`Simulator`).

    The hand, target, obstacles and occluders are those recorded in the file's ``inputs`` (paths
    relative to the current folder or to the file's folder), unless ``hand`` / ``target`` are given;
    a recorded ``support`` plane becomes a box (:data:`SUPPORT_MARGIN` beyond the target on every
    side) that stands under the target while the hand closes and goes away with the obstacles.
    Nothing is written unless every grasp was simulated.

    Raises:
        pairgrasp.FileError: a missing or malformed grasps file, or a recorded input that is missing.
        ValueError: ``top`` or ``trials`` < 1, a hand other than the one the grasps were planned for,
            bad parameters.
        ImportError: MuJoCo is not installed.
    """
    from .grasps_file import load_planned, write_grasps

    path = os.fspath(path)
    _check_top(top)
    import_mujoco()
    perturbations = trial_perturbations(trials, seed, noise)
    planned = load_planned(path, hand, target)
    rep = _simulate_planned(planned, path, top, params, progress, perturbations, seed, noise, mass, overrides)
    out_png = tmp_png = None
    if picture:
        from .render import simulation_figure

        out_png = os.path.join(os.path.dirname(str(path)), "simulation.png")  # beside it, as the user named it
        tmp_png = out_png + ".part.png"
        simulation_figure(rep.epsilons, rep.results, rep.params, tmp_png,
                          title=f"{planned.hand.name} on "
                                f"{os.path.basename(str(planned.grasps.inputs.get('target', 'target')))}")
    try:
        write_grasps(path, planned.grasps.document)
        if tmp_png:
            os.replace(tmp_png, out_png)
    finally:
        if tmp_png and os.path.exists(tmp_png):
            os.remove(tmp_png)
    rep.picture = out_png
    return rep


def _check_top(top):
    if top is not None and (isinstance(top, bool) or not isinstance(top, int) or top < 1):
        raise ValueError(f"top: expected an integer >= 1, got {top!r}")


def _planned_scene(planned, path, params, mass, overrides) -> "Simulator":
    """The Simulator of a plan already read: its hand and target, its obstacles and occluders, and
    the table it stood on (``inputs.support``), which recedes along the support's normal."""
    from .grasps_file import resolve_path, recorded_support

    inputs, scale, base = planned.grasps.inputs, planned.scale, planned.base
    others = []
    for key in ("obstacles", "occluders"):
        for k, o in enumerate(inputs.get(key, []) or []):
            others.append(_core.load_mesh(resolve_path(o, base, f"{path}: inputs.{key}[{k}]"), scale=scale))
    support = recorded_support(inputs)
    if support is not None:   # the table the target stood on while the hand closed, taken away for the load
        others.append(_core.support_box(support, planned.target, SUPPORT_MARGIN))
    lift = support.normal if support is not None else (0.0, 0.0, 1.0)
    return Simulator(planned.hand, planned.target, others, params=params, mass=mass, lift_direction=lift, **overrides)


def _simulate_planned(planned, path, top, params, progress, perturbations, seed, noise, mass, overrides) -> SimReport:
    """simulate_grasps() on a plan already read: records every outcome in ``planned.grasps.document``
    (which is not written) and returns the report (no picture)."""
    gf = planned.grasps
    grasps = gf.grasps if top is None else gf.grasps[:top]
    sim = _planned_scene(planned, path, params, mass, overrides)
    per_grasp = []
    for k, g in enumerate(grasps):
        per_grasp.append(simulate_trials(sim, g.wrist_pose, g.dofs, perturbations))
        if progress:
            progress(k + 1, len(grasps), per_grasp[-1][0])
    results = [rs[0] for rs in per_grasp]
    doc = gf.document
    for g, rs in zip(doc["grasps"], per_grasp):
        g["simulation"] = _trials_record(perturbations, rs)
    doc["simulation"] = {"engine": f"mujoco {import_mujoco().__version__}", "parameters": asdict(sim.params),
                         "target_mass": round(sim.target_mass, 9),
                         "target_mass_source": sim.target_mass_source, "simulated": len(results),
                         "trials": len(perturbations), "seed": int(seed), "noise": asdict(noise or TrialNoise()),
                         "scene": {k: v for k, v in sim.counts.items()}}
    return SimReport(results=results, ranks=[g.rank for g in grasps], epsilons=[g.epsilon for g in grasps],
                     counts=sim.counts, params=sim.params, path=path, picture=None, trials=per_grasp,
                     target_mass=sim.target_mass, target_mass_source=sim.target_mass_source)


#: How far (m) the simulated support extends beyond the target's footprint on every side, and how deep.
SUPPORT_MARGIN = 0.15


#: What ``plan --verify-top`` simulates: every trial of the whole procedure, or the lift check.
VERIFY_CHECKS = ("trials", "lift")


def verify_grasps(path, top: int, trials: int = 4, seed: int = 0, progress=None, document=None, hand=None,
                  target=None, check: str = "trials", **kwargs) -> List[int]:
    """Simulation in the loop: simulates the first ``top`` grasps of a grasps.json file and re-ranks
    them (ties keep the planned order; the grasps after ``top`` keep theirs). Each grasp keeps its
    planned rank as ``planned_rank`` and the document records ``verification``: ``{"top", "check",
    "planned_ranks"}`` (the planned ranks in the new order), with ``"trials"`` and ``"seed"`` for
    the trials check. Returns the planned ranks in the new order.

    ``check``:

    - ``"trials"``: :func:`simulate_grasps` with ``trials`` and ``seed`` (``kwargs`` go to it); the
      grasps are re-ranked by their success rate, each gets its ``simulation``.
    - ``"lift"``: the grasp as planned, without errors, through the closing and the lift only
      (:meth:`Simulator.simulate` ``until=turn_time``: gravity fades in while the table recedes), about
      a seventh of one trial; the grasps are re-ranked by how far the object moved, the closing's
      translation of its centre of mass relative to the palm plus the lift's largest, least first.
      Each gets ``lift_check``: ``{"moved", "closing_translation", "lift_translation" (m),
      "outcome", "contact_links", "wall_time" (s)}``. ``trials`` and ``seed`` are not used.

    ``document``: the plan's document not yet written (as ``plan --verify-top`` passes it): it is
    simulated and re-ranked in place and not written; ``path`` is where it will be written (its
    folder is where recorded paths are relative to). Without it, ``path`` is read and written back.

    Raises what :func:`simulate_grasps` raises, and ValueError for an unknown ``check``.
    """
    from .grasps_file import load_planned, write_grasps

    path = os.fspath(path)
    _check_top(top)
    if check not in VERIFY_CHECKS:
        raise ValueError(f"check: expected one of {', '.join(VERIFY_CHECKS)}, got {check!r}")
    import_mujoco()
    noise, params, mass = kwargs.pop("noise", None), kwargs.pop("params", None), kwargs.pop("mass", None)
    planned = load_planned(path, hand, target, document=document)
    doc = planned.grasps.document
    items = doc["grasps"]
    if check == "trials":
        perturbations = trial_perturbations(trials, seed, noise)
        rep = _simulate_planned(planned, path, top, params, progress, perturbations, seed, noise, mass, kwargs)
        n = len(rep.trials)
        key = [-x for x in rep.success_rates]
    else:
        sim = _planned_scene(planned, path, params, mass, kwargs)
        grasps = planned.grasps.grasps[:top]
        n, key = len(grasps), []
        for k, (g, item) in enumerate(zip(grasps, items)):
            r = sim.simulate(g.wrist_pose, g.dofs, until=sim.params.turn_time)
            key.append(r.closing_translation + r.slip_translation)
            item["lift_check"] = {"moved": round(key[-1], 9), "closing_translation": round(r.closing_translation, 9),
                                  "lift_translation": round(r.slip_translation, 9), "outcome": r.outcome,
                                  "contact_links": list(r.contact_links), "wall_time": round(r.wall_time, 4)}
            if progress:
                progress(k + 1, n, r)
    head = sorted(range(n), key=lambda i: key[i])   # stable: ties in planned order
    order = head + list(range(n, len(items)))
    reranked = []
    for new_rank, i in enumerate(order, start=1):
        g = dict(items[i])
        g["planned_rank"] = g["rank"]
        g["rank"] = new_rank
        reranked.append(g)
    doc["grasps"] = reranked
    doc["verification"] = {"top": len(head), "check": check, **(
        {"trials": int(trials), "seed": int(seed)} if check == "trials" else {}),
        "planned_ranks": [g["planned_rank"] for g in reranked[:len(head)]]}
    if document is None:
        write_grasps(path, doc)
    return [g["planned_rank"] for g in reranked]
