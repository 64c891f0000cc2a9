"""The result of joint fitting: the fitted robot motion with per-frame evidence (errors of the
targets of Nakaoka & Komura 2012 eq. 8, activity of Kim et al.'s limits, iterations, timing)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, overload

import numpy as np

from ..core.robot_motion import RobotMotion
from .config import FitConfig
from .targets import DirectionTarget, KeypointTarget


class _FrameCount:
    """Read-only attribute: the number of frames in which a (T,) boolean field is set."""

    def __init__(self, flags: str) -> None:
        self.flags = flags

    @overload
    def __get__(self, result: None, owner: Any = None) -> _FrameCount: ...
    @overload
    def __get__(self, result: object, owner: Any = None) -> int: ...
    def __get__(self, result: object, owner: Any = None) -> int | _FrameCount:
        if result is None:  # the class attribute itself (introspection)
            return self
        return int(getattr(result, self.flags).sum())


@dataclass(frozen=True, eq=False)
class FitResult:
    """Fitted robot motion with per-frame evidence.

    Attributes:
        motion: the fitted configurations (T, nq).
        keypoints: the key points fitted (K entries).
        directions: the directions fitted (D entries).
        keypoint_error_m: (T, K) distance robot point - marker [m]; NaN where the marker is
            missing.
        keypoint_rms_m: (T,) RMS over the valid key points [m] (NaN when none is valid).
        keypoint_max_m: (T,) largest key-point error [m].
        direction_error_deg: (T, D) angle between the robot axis and the marker direction [deg];
            NaN where a marker is missing.
        iterations: (T,) DLS iterations taken per frame.
        at_position_bound: (T,) any joint on a bound set by its position limit.
        at_velocity_bound: (T,) any joint on a bound set by its velocity limit.
        at_acceleration_bound: (T,) any joint on a bound set by its acceleration limit.
        conflict: (T,) the boxes of some joint did not intersect (the conflict policy of
            :mod:`imesh.fit.limits`).
        joint_bound_frames: (n,) per joint, frames in which it sat on any bound.
        seconds_per_frame: wall time of the frame loop divided by T [s].
        config: the settings used.
        restart_frames: frames whose solution came from a restart at their own markers
            (FitConfig.restart_rms_m).
        frames_at_position_bound, frames_at_velocity_bound, frames_at_acceleration_bound,
            conflict_frames: the number of frames with the matching (T,) flag set.
    """

    motion: RobotMotion
    keypoints: tuple[KeypointTarget, ...]
    directions: tuple[DirectionTarget, ...]
    keypoint_error_m: np.ndarray
    keypoint_rms_m: np.ndarray
    keypoint_max_m: np.ndarray
    direction_error_deg: np.ndarray
    iterations: np.ndarray
    at_position_bound: np.ndarray
    at_velocity_bound: np.ndarray
    at_acceleration_bound: np.ndarray
    conflict: np.ndarray
    joint_bound_frames: np.ndarray
    seconds_per_frame: float
    config: FitConfig = field(default_factory=FitConfig)
    restart_frames: int = 0

    frames_at_position_bound = _FrameCount("at_position_bound")
    frames_at_velocity_bound = _FrameCount("at_velocity_bound")
    frames_at_acceleration_bound = _FrameCount("at_acceleration_bound")
    conflict_frames = _FrameCount("conflict")

    @property
    def marker_rms_mm(self) -> float:
        """RMS over all frames and valid key points of the key-point error [mm]."""
        err = self.keypoint_error_m[np.isfinite(self.keypoint_error_m)]
        return float(1e3 * np.sqrt(np.mean(err**2))) if err.size else float("nan")

    def report(self) -> dict:
        """The JSON report of the fitting stage (same as :meth:`summary`)."""
        return self.summary()

    def summary(self) -> dict:
        """Scalar report (for JSON reports and benchmark tables)."""
        d = self.direction_error_deg
        dfin = d[np.isfinite(d)]
        kmax = self.keypoint_max_m[np.isfinite(self.keypoint_max_m)]
        return {
            "robot": self.motion.robot,
            "frames": self.motion.n_frames,
            "marker_rms_mm": self.marker_rms_mm,
            "keypoint_rms_m": 1e-3 * self.marker_rms_mm,
            "keypoint_max_mm": float(1e3 * kmax.max()) if kmax.size else float("nan"),
            "direction_rms_deg": float(np.sqrt(np.mean(dfin**2))) if dfin.size else 0.0,
            "direction_max_deg": float(dfin.max()) if dfin.size else 0.0,
            "mean_iterations": float(self.iterations.mean()),
            "frames_at_position_bound": self.frames_at_position_bound,
            "frames_at_velocity_bound": self.frames_at_velocity_bound,
            "frames_at_acceleration_bound": self.frames_at_acceleration_bound,
            "conflict_frames": self.conflict_frames,
            "seconds_per_frame": self.seconds_per_frame,
            "restart_frames": self.restart_frames,
        }
