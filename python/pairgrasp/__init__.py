"""pairgrasp: grasp planning by pairwise-feature alignment of a gripper's contact surface with a target.

Lengths are in metres, angles in radians. Errors: bad argument values raise ValueError, bad files
raise pairgrasp.FileError (a RuntimeError) naming the file.
"""
from ._core import *  # noqa: F401,F403
from ._core import FileError, version  # noqa: F401

__version__ = version()
from .quality import (GraspQuality, LOAD_DIRECTIONS, contact_frames, epsilon_upper_bound, force_resistance,  # noqa: F401,E402
                      grasp_quality, load_resistance, wrench_matrix)
from .planner import Candidate, Grasp, PlanParams, PlanResult, Planner, dof_axes, dof_grid, support_plane  # noqa: F401,E402
from .checks import InputWarning  # noqa: F401,E402
from .grasps_file import GRASPS_FORMAT, GraspsFile, load_grasps, parse_grasps, write_grasps  # noqa: F401,E402
from .inertia import MassProperties, mass_properties  # noqa: F401,E402
from .convex import convex_pieces  # noqa: F401,E402
from .hand_spec import draw_hand, propose_spec  # noqa: F401,E402
from .equilibrium import closing_friction  # noqa: F401,E402
from .mjcf import import_hand  # noqa: F401,E402
from .sim import (SimParams, SimResult, Simulator, Trial, TrialNoise, simulate_grasps, simulate_trials,  # noqa: F401,E402
                  trial_perturbations, verify_grasps, load_phase)
from .batch import plan_batch  # noqa: F401,E402
