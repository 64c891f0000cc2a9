"""The paper's dynamics check: the imitated joint trajectory tracked by PID in DART with the base
fixed (Kim, Kim & Oh 2005, sec. 4).

A thin layer over :func:`imesh.physics.simulate_motion` with ``PhysicsConfig(fixed_base=True,
controller="pid")``: the base is welded at the motion's first pose, every joint follows a cubic
spline of the frames under ``tau = Kp e + Kd de + Ki int(e)`` at 1 kHz (gains from the torque
limits, capped for explicit stability; no inverse-dynamics feed-forward by default, as in the
paper), torques clamped to the motor limits. The arm joints' tracking error is reported
separately from the whole body's (legs and torso only hold the nominal pose).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..core.robot_motion import RobotMotion
from . import ControlConfig, PhysicsConfig, TimingConfig, simulate_motion

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class ArmTracking:
    """How well DART's PID followed an arm motion.

    Attributes:
        robot: robot name.
        joints: the arm joints the arm numbers are over.
        arm_rms_rad: RMS tracking error of the arm joints over all frames [rad].
        arm_max_rad: largest |error| of an arm joint [rad].
        all_rms_rad: RMS tracking error of every joint [rad].
        diverged: the simulation produced non-finite states (instability).
        torque_ratio_max: largest demanded |torque| / limit (> 1: the motors saturated).
        saturation_fraction: fraction of control steps with a clamped torque.
        physics: the full :class:`imesh.physics.PhysicsResult`.
    """

    robot: str
    joints: tuple[str, ...]
    arm_rms_rad: float
    arm_max_rad: float
    all_rms_rad: float
    diverged: bool
    torque_ratio_max: float
    saturation_fraction: float
    physics: object

    def summary(self) -> dict:
        return {"arm_tracking_rms_rad": self.arm_rms_rad, "arm_tracking_max_rad": self.arm_max_rad,
                "tracking_rms_rad": self.all_rms_rad, "diverged": self.diverged,
                "torque_ratio_max": self.torque_ratio_max,
                "saturation_fraction": self.saturation_fraction}


def track_arms(robot, motion: RobotMotion, joints: Sequence[str] | None = None, *,
               feedforward: bool = False, kp_per_effort: float = 20.0, settle_s: float = 0.2
               ) -> ArmTracking:
    """Track ``motion`` with PID in DART, base fixed, and report the arm joints' errors.

    Args:
        robot: the robot.
        motion: its motion (e.g. ``ArmsResult.motion``).
        joints: the arm joints to report on (None: every joint).
        feedforward: add inverse-dynamics torques of the reference (imesh's default tracker
            does; the paper's PID does not).
        kp_per_effort: proportional gain per Nm of torque limit [1/rad] (see ControlConfig).
        settle_s: time the first frame is held before tracking [s].

    Returns:
        ArmTracking.

    Raises:
        MissingDependencyError: dartpy missing (names the install command).
        PhysicsError: a model mismatch.
    """
    config = PhysicsConfig(fixed_base=True,
                           control=ControlConfig(controller="pid", feedforward=feedforward,
                                                 kp_per_effort=kp_per_effort),
                           timing=TimingConfig(settle_s=settle_s))
    result = simulate_motion(robot, motion, config=config)
    names = tuple(joints) if joints is not None else tuple(robot.joint_names)
    cols = np.array([robot.joint_index(n) for n in names], dtype=np.int64)
    err = result.joint_error_rad[:, cols]
    finite = np.isfinite(err).all(axis=1)
    diverged = bool(result.fell) or not finite.all()
    arm_rms = float(np.sqrt(np.mean(err[finite] ** 2))) if finite.any() else float("nan")
    arm_max = float(np.abs(err[finite]).max()) if finite.any() else float("nan")
    tracking = ArmTracking(robot=robot.name, joints=names, arm_rms_rad=arm_rms,
                           arm_max_rad=arm_max, all_rms_rad=float(result.tracking_rms_rad),
                           diverged=diverged, torque_ratio_max=float(result.torque_ratio_max),
                           saturation_fraction=float(result.saturation_fraction),
                           physics=result)
    log.info("DART PID (fixed base) %s: arm tracking RMS %.4f rad, max %.4f rad, %s",
             robot.name, arm_rms, arm_max, "DIVERGED" if diverged else "stable")
    return tracking
