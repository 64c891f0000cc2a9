"""The check of a finished arm trajectory against its joint limits (Kim, Kim & Oh 2005, eqs 9,
13, 14 with backward differences): which frames leave the position box, or move faster or
accelerate harder than the limits allow.

The bounds the solver keeps inside, per frame, are those of the initial fit
(:class:`imesh.fit.limits.IncrementBox`, the same boxes and conflict policy for the arm joints);
the limits are a :class:`imesh.core.limits.JointLimits`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.limits import BOUND_TOL, JointLimits


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
                 tol: float = BOUND_TOL) -> Violations:
    """Frames of a trajectory outside its limits.

    Args:
        theta: (T, n) float [rad] the joint trajectory.
        limits: the n joints' limits.
        fps: frame rate [1/s].
        tol: slack [rad] on the position (eq. 9) and on the first and second backward
            differences (eqs 13, 14: ``|theta_i - theta_{i-1}| <= dt v_max``, ``|theta_i -
            2 theta_{i-1} + theta_{i-2}| <= dt^2 a_max``).

    Returns:
        The frames outside each limit and the worst ratios of speed and acceleration to the
        limits.
    """
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
