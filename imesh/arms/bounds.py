"""Joint position, velocity and acceleration limits as bounds on the per-frame increments
(Kim, Kim & Oh 2005, eqs 7-15, backward differences), and the check of a finished trajectory.

For the arm joints at frame ``i`` (``dt = 1 / fps``, ``v_{i-1} = (theta_{i-1} - theta_{i-2})
/ dt``):

    position      q_min - theta_{i-1}      <= dtheta <= q_max - theta_{i-1}          (eqs 9, 10)
    velocity      -dt v_max                 <= dtheta <= dt v_max                    (eqs 13, 15)
    acceleration  dt v_{i-1} - dt^2 a_max   <= dtheta <= dt v_{i-1} + dt^2 a_max     (eqs 14, 15)

The boxes are intersected in that priority order with the conflict policy of
:mod:`imesh.fit.limits` (the same helpers): where a lower-priority box misses the running
intersection the joint is pinned to its closest point, and an optional lowest-priority braking
box keeps each joint slow enough to stop before its position limits at ``a_max``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fit.limits import ACCELERATION, POSITION, VELOCITY
from ..fit.limits import braking_reach as _braking_reach
from ..fit.limits import intersect as _intersect

#: Tolerance [rad] of the checks below (on increments, like the solver's bounds).
CHECK_TOL = 1e-9


@dataclass(frozen=True, eq=False)
class JointLimits:
    """Limits of the arm joints.

    Attributes:
        lower, upper: (n,) float [rad] position limits.
        v_max: (n,) float [rad/s] velocity limits (inf = off).
        a_max: (n,) float [rad/s^2] acceleration limits (inf = off).
    """

    lower: np.ndarray
    upper: np.ndarray
    v_max: np.ndarray
    a_max: np.ndarray


@dataclass(frozen=True, eq=False)
class FrameBox:
    """The bounds of one frame in absolute joint values (``theta_i``, not increments).

    Attributes:
        lo, hi: (n,) float [rad] the intersected box of eqs 9, 13, 14 (and braking).
        posvel_lo, posvel_hi: (n,) float [rad] position and velocity bounds only (eqs 9, 13:
            the time-varying limits of the paper's Fig. 4).
        src_lo, src_hi: (n,) int which limit set each bound (POSITION, VELOCITY, ACCELERATION).
        conflict: some joint's boxes did not intersect.
    """

    lo: np.ndarray
    hi: np.ndarray
    posvel_lo: np.ndarray
    posvel_hi: np.ndarray
    src_lo: np.ndarray
    src_hi: np.ndarray
    conflict: bool


def frame_box(limits: JointLimits, theta_prev: np.ndarray | None,
              theta_prev2: np.ndarray | None, dt: float, brake: bool) -> FrameBox:
    """The box of frame ``i`` from the two previous frames (None at the start of the motion:
    frame 0 has the position box only, frame 1 adds velocity, frames >= 2 acceleration)."""
    zero = np.zeros(len(limits.lower), dtype=np.int64)
    lo, hi, src_lo, src_hi = limits.lower, limits.upper, zero, zero
    clash = False
    if theta_prev is not None:
        step_v = dt * limits.v_max
        lo, hi, src_lo, src_hi, c = _intersect(lo, hi, src_lo, src_hi, theta_prev - step_v,
                                               theta_prev + step_v, VELOCITY)
        clash = bool(c.any())
    pv_lo, pv_hi = lo, hi
    step_a = dt * dt * limits.a_max
    has_acc = bool(np.any(np.isfinite(step_a)))
    if theta_prev is not None and has_acc:
        if theta_prev2 is not None:
            centre = 2.0 * theta_prev - theta_prev2
            lo, hi, src_lo, src_hi, c = _intersect(lo, hi, src_lo, src_hi, centre - step_a,
                                                   centre + step_a, ACCELERATION)
            clash = clash or bool(c.any())
        if brake:
            lo, hi, src_lo, src_hi, _ = _intersect(
                lo, hi, src_lo, src_hi,
                theta_prev - _braking_reach(theta_prev - limits.lower, step_a),
                theta_prev + _braking_reach(limits.upper - theta_prev, step_a), POSITION)
    return FrameBox(lo=lo, hi=hi, posvel_lo=pv_lo, posvel_hi=pv_hi, src_lo=src_lo,
                    src_hi=src_hi, conflict=clash)


@dataclass(frozen=True, eq=False)
class Violations:
    """Frames of a trajectory outside its limits (backward differences).

    Attributes:
        position, velocity, acceleration: (T,) bool per frame.
        worst_velocity_ratio: largest ``|v| / v_max``.
        worst_acceleration_ratio: largest ``|a| / a_max``.
    """

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    worst_velocity_ratio: float
    worst_acceleration_ratio: float

    def counts(self) -> dict[str, int]:
        return {"position": int(self.position.sum()), "velocity": int(self.velocity.sum()),
                "acceleration": int(self.acceleration.sum())}


def check_limits(theta: np.ndarray, limits: JointLimits, fps: float,
                 tol: float = CHECK_TOL) -> Violations:
    """Frames where ``theta`` (T, n) leaves the position box, or its backward-difference velocity
    or acceleration exceeds the limits (by more than ``tol`` rad on the increment)."""
    dt = 1.0 / fps
    theta = np.asarray(theta, dtype=float)
    T = len(theta)
    pos = np.asarray(((theta < limits.lower - tol) | (theta > limits.upper + tol)).any(axis=1))
    vel = np.zeros(T, dtype=bool)
    acc = np.zeros(T, dtype=bool)
    vr = ar = 0.0
    if T > 1:
        d1 = np.abs(np.diff(theta, axis=0))
        vel[1:] = (d1 > dt * limits.v_max + tol).any(axis=1)
        vr = float((d1 / (dt * limits.v_max)).max())
    if T > 2:
        d2 = np.abs(np.diff(theta, n=2, axis=0))
        acc[2:] = (d2 > dt * dt * limits.a_max + tol).any(axis=1)
        ar = float((d2 / (dt * dt * limits.a_max)).max())
    return Violations(position=pos, velocity=vel, acceleration=acc, worst_velocity_ratio=vr,
                      worst_acceleration_ratio=ar)
