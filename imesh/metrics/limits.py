"""Joint-limit violations of a robot motion: positions, velocities and accelerations by finite
differences at the motion's frame rate."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class LimitReport:
    """Joint-limit violations of a motion.

    Attributes:
        position: (T,) bool frames with a joint outside its position limits.
        velocity: (T,) bool frames with a joint faster than its velocity limit (backward
            differences; frame 0 never).
        acceleration: (T,) bool frames with a joint's second difference over its acceleration
            limit (central: frame t from t-1, t, t+1; first and last frame never).
        position_joints: joint -> frames outside its position limits (violating joints only).
        velocity_joints: joint -> frames above its velocity limit (violating joints only).
        worst_position_rad: largest excursion beyond a position limit [rad].
        worst_velocity_ratio: largest |velocity| / limit.
    """

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    position_joints: dict[str, int]
    velocity_joints: dict[str, int]
    acceleration_joints: dict[str, int]
    worst_position_rad: float
    worst_velocity_ratio: float
    worst_acceleration_ratio: float

    @property
    def any(self) -> np.ndarray:
        """(T,) bool frames with any violation."""
        return self.position | self.velocity | self.acceleration


def limit_violations(robot, q: np.ndarray, fps: float, position_tol: float = 1e-6,
                     velocity_tol: float = 1e-6) -> LimitReport:
    """Frames with joints outside their position limits or above their velocity or
    acceleration limits (one tolerance: ``velocity_tol`` is relative to both rate limits).

    Args:
        robot: the robot (``q_lower``, ``q_upper``, ``v_max``, ``joint_names``).
        q: (T, nq) float configurations.
        fps: frame rate [1/s].
        position_tol: [rad] tolerance on the position limits.
        velocity_tol: relative tolerance on the velocity limits.
    """
    qj = np.asarray(q, dtype=float)[:, 7:]
    over = np.maximum(qj - robot.q_upper, robot.q_lower - qj)
    pos = over > position_tol
    vel_ratio = np.zeros_like(qj)
    if len(qj) > 1:
        vel_ratio[1:] = np.abs(np.diff(qj, axis=0)) * fps / robot.v_max
    vel = vel_ratio > 1.0 + velocity_tol
    acc_ratio = np.zeros_like(qj)
    if len(qj) > 2:
        acc_ratio[1:-1] = np.abs(np.diff(qj, n=2, axis=0)) * fps * fps / robot.a_max
    acc = acc_ratio > 1.0 + velocity_tol
    names = robot.joint_names

    def per_joint(mask):
        return {names[j]: int(mask[:, j].sum()) for j in np.flatnonzero(mask.any(0))}

    return LimitReport(
        position=pos.any(axis=1), velocity=np.asarray(vel.any(axis=1)),
        acceleration=np.asarray(acc.any(axis=1)),
        position_joints=per_joint(pos), velocity_joints=per_joint(vel),
        acceleration_joints=per_joint(acc),
        worst_position_rad=float(max(over.max(initial=0.0), 0.0)),
        worst_velocity_ratio=float(vel_ratio.max(initial=0.0)),
        worst_acceleration_ratio=float(acc_ratio.max(initial=0.0)))
