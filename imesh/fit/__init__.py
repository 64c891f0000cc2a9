"""Joint fitting: robot configurations from adapted marker trajectories.

Per frame, warm started from the previous one, damped least squares (Nakaoka & Komura 2012,
eqs 7-8) over the free-flyer base and all joints, with joint position / velocity / acceleration
limits as bounds on the per-frame increment (Kim, Kim & Oh 2005, eqs 9, 13, 14). See
``docs/fitting.md``.

Modules, in the order of the data flow:

- :mod:`~imesh.fit.targets`: what the robot fits (key points, directions) from markers.toml;
- :mod:`~imesh.fit.config`: :class:`FitConfig`, the weights, budgets and limits switches;
- :mod:`~imesh.fit.limits`: the joint limits and each frame's box (Kim eqs 9, 13, 14);
- :mod:`~imesh.fit.kinematics`: placements and Jacobians of the target frames;
- :mod:`~imesh.fit.residual`: the rows ``W e`` and ``W J`` of eq. 8, per frame;
- :mod:`~imesh.fit.dls`: one frame's damped least-squares iteration (eq. 7), on
  :mod:`~imesh.fit.boxqp`, the box-bounded inner solve;
- :mod:`~imesh.fit.initial`: frame 0's start from the marker geometry;
- :mod:`~imesh.fit.track`: the frame loop; :mod:`~imesh.fit.feasible`: the look-ahead
  projection of the joint trajectory onto the limits;
- :mod:`~imesh.fit.motion`: :func:`fit_motion`, the driver; :mod:`~imesh.fit.result`:
  :class:`FitResult`.

Example:
    >>> from imesh.robot import load_robot
    >>> from imesh.fit import fit_motion
    >>> result = fit_motion(load_robot("jvrc1"), adapted_markers)
    >>> result.motion            # RobotMotion (T, nq)
    >>> result.summary()         # marker_rms_mm, frames at limits, seconds_per_frame ...
"""

from .boxqp import solve_box_dls, solve_box_qp
from .config import FitConfig
from .errors import FitError, UnknownFrameError
from .motion import fit_motion
from .result import FitResult
from .targets import (
    DirectionTarget,
    KeypointTarget,
    as_directions,
    as_keypoints,
    compile_targets,
    robot_targets,
)

__all__ = [
    "DirectionTarget", "FitConfig", "FitError", "FitResult", "KeypointTarget", "UnknownFrameError",
    "as_directions", "as_keypoints", "compile_targets", "fit_motion",
    "robot_targets", "solve_box_dls", "solve_box_qp",
]
