"""Flight, landings and slides of a robot motion, measured on its own soles and CoM.

- **flight**: frames in which no sole is within ``FlightDetection.height_m`` of the ground. Only
  gravity acts there, so the CoM's acceleration (the evaluator's finite differences of the
  pinocchio CoM, :func:`imesh.metrics.derivatives.motion_derivatives`) should be ``(0, 0, -g)``:
  reported as the largest ``|c'' - g|`` over the flight frames whose difference stencil (two
  frames either side) lies in the same flight phase;
- **landings**: at the first frame after a flight phase the CoM's vertical velocity [m/s] and
  the largest total normal force ``m (g + c_z'')`` over the next ``impact_s``, in body weights;
- **slides**: support frames (``support``) in which a sole moves along the ground on purpose
  (``sliding``, the plan's slides) are counted apart from skid: :func:`skid_apart_from_slides`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contacts.phases import SIDES, runs
from ..core.checks import require_finite
from .derivatives import motion_derivatives
from .skid import SkidReport, foot_skid, near_slides
from .soles import SoleTracks

GRAVITY = 9.81


@dataclass(frozen=True)
class FlightDetection:
    """Thresholds of the flight detection of a robot motion.

    Attributes:
        height_m: a frame is flight when the lowest corner of every sole is above this [m].
        impact_s: a landing's normal force is the largest over this time after it [s].
    """

    height_m: float = 0.01
    impact_s: float = 0.3

    def __post_init__(self) -> None:
        require_finite(self, ("height_m", "impact_s"), positive=True)


@dataclass(frozen=True)
class FlightReport:
    """Flight phases of a robot motion and how physical they are.

    Attributes:
        phases: [start, stop) frames of the flight phases.
        flight_frames: frames in flight.
        com_accel_error: largest ``|c'' - (0, 0, -g)|`` over the flight frames whose
            difference stencil lies in the phase [m/s^2] (NaN: none).
        judged_frames: how many frames that figure covers.
        landing_speed: per landing, the CoM's vertical speed at touch-down [m/s] (downward
            positive).
        landing_normal: per landing, the largest total normal force over ``impact_s`` after it
            [body weights].
        takeoff_normal: per take-off, the largest total normal force over ``impact_s`` before
            it [body weights].
    """

    phases: list[tuple[int, int]]
    flight_frames: int
    com_accel_error: float
    judged_frames: int
    landing_speed: list[float]
    landing_normal: list[float]
    takeoff_normal: list[float]


def flight_mask(soles: SoleTracks, config: FlightDetection | None = None) -> np.ndarray:
    """(T,) bool frames in which no sole is within ``config.height_m`` of the ground."""
    config = config or FlightDetection()
    low = np.min([soles.lowest(s) for s in SIDES], axis=0)
    return low > config.height_m


def flight_report(robot, q: np.ndarray, fps: float, soles: SoleTracks,
                  config: FlightDetection | None = None) -> FlightReport:
    """Flight phases, the CoM's deviation from a ballistic path in them and the landings.

    Args:
        robot: the robot (:meth:`~imesh.robot.Robot.centroidal_trajectory`).
        q: (T, nq) configurations; fps: their rate [1/s].
        soles: :func:`~imesh.metrics.soles.sole_tracks` of ``q``.
        config: thresholds.
    """
    config = config or FlightDetection()
    fly = flight_mask(soles, config)
    phases = runs(fly)
    v, _ = motion_derivatives(q, fps)
    com, dh, _ = robot.centroidal_trajectory(q, v, fps)
    acc = dh[:, :3] / robot.mass
    # the evaluator's acceleration at t differences t-2..t+2: judge frames whose stencil flies
    inner = np.zeros(len(q), dtype=bool)
    for s, e in phases:
        inner[s + 2:e - 2] = True
    err = np.linalg.norm(acc[inner] - np.array([0.0, 0.0, -GRAVITY]), axis=1)
    vz = np.gradient(com[:, 2], 1.0 / fps) if len(q) > 1 else np.zeros(len(q))
    n = max(1, int(round(config.impact_s * fps)))
    normal = (GRAVITY + acc[:, 2]) / GRAVITY
    landing_speed, landing_normal, takeoff_normal = [], [], []
    for s, e in phases:
        if e < len(q):
            landing_speed.append(float(-vz[e]))
            landing_normal.append(float(normal[e:e + n].max()))
        if s > 0:
            takeoff_normal.append(float(normal[max(s - n, 0):s].max()))
    return FlightReport(phases=phases, flight_frames=int(fly.sum()),
                        com_accel_error=float(err.max()) if err.size else float("nan"),
                        judged_frames=int(inner.sum()), landing_speed=landing_speed,
                        landing_normal=landing_normal, takeoff_normal=takeoff_normal)


def skid_apart_from_slides(soles: SoleTracks, support: np.ndarray, sliding: np.ndarray
                           ) -> tuple[SkidReport, SkidReport]:
    """Foot skid of the support frames that are not slides, and the motion of the slides.

    Args:
        soles: sole tracks of the motion.
        support: (T, 2) bool support (e.g. :func:`imesh.metrics.support.detect_support`).
        sliding: (T, 2) bool frames in which a sole slides on purpose (the plan's slides,
            ``RetargetResult.support.sliding``); a frame next to a slide counts with it (the
            skid of frame t is the motion from t - 1).

    Returns:
        (skid without the slides, the same measure over the slides).
    """
    near = near_slides(sliding)
    return foot_skid(soles, support & ~near), foot_skid(soles, support & near)
