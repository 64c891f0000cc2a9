"""The outcome of a DART dynamics check (:class:`PhysicsResult`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .config import PhysicsConfig

#: The DESIGN.md metric names a physics check provides.
PHYSICS_METRICS = ("physics_fell", "physics_survived_s", "tracking_rms_rad", "torque_ratio_max")


@dataclass(frozen=True, eq=False)
class PhysicsResult:
    """What happened when the robot tracked a motion in DART.

    Per-frame arrays have one row per motion frame (T, at the motion's fps, time 0 = the first
    frame after settling); rows after a fall are NaN.

    Attributes:
        robot: robot name.
        joint_names: (n,) joints in the column order of the joint arrays.
        fps: frame rate of the per-frame arrays [1/s].
        fell: the robot fell (base too low or too tilted relative to the reference), or the
            simulation diverged.
        fall_reason: why it was judged fallen ("" when it did not fall).
        survived_s: motion time until the fall [s] (the motion's duration when it did not).
        duration_s: motion time simulated when nothing fails (motion +
            ``TimingConfig.extra_time_s``) [s].
        tracking_rms_rad: RMS joint error over the survived frames and all joints [rad].
        torque_ratio_max: largest demanded |torque| / torque limit over joints and control
            steps (before clamping; > 1 means the controller wanted more than the motors have).
        saturation_fraction: fraction of control steps with at least one torque clamped.
        base_drift_m: distance between the simulated and the reference base position at the
            last survived frame [m].
        base_height_drift_m: largest |simulated - reference| base height over the survived
            frames [m].
        keypoint_rms_mm: RMS distance between the robot's key points (markers.toml) in the
            simulated and the reference motion over the survived frames [mm] (NaN without key
            points); ``keypoint_max_mm`` the largest.
        keypoint_worst: the key point of ``keypoint_max_mm`` ("" without key points);
            ``keypoint_worst_s`` its motion time [s] (NaN without).
        slip_mm: largest horizontal displacement of a sole corner on the ground within one
            planned support phase, from the frame the corner is down in the simulation while
            it stays down [mm] (a roll over the toe edge is no slip).
        slip_side: the sole of ``slip_mm`` ("" without slip); ``slip_s`` the motion time [s]
            at which its corner is farthest from where it came down (NaN without).
        friction_ratio: largest tangential / (mu x normal) ground force ratio of a loaded sole.
        cop_margin_mm: smallest distance of a loaded sole's centre of pressure to its edge [mm]
            (negative: outside, the sole tips).
        relaxed_fraction: fraction of the whole-body controller's QPs that were infeasible
            within the torque limits and solved without them (0 for other controllers).
        real_time_factor: simulated time / wall time, settling included.
        wall_s: wall time of the simulation loop [s].
        controller_us_per_step: wall time of the Python controller per control step [us].
        physics_us_per_step: wall time of DART's step (and recording) per control step [us].
        times_s: (T,) float motion time of every frame [s].
        q: (T, nq) float simulated configurations (pinocchio convention).
        q_reference: (T, nq) float the tracked reference (base placed on the ground).
        joint_error_rad: (T, n) float simulated minus reference joint angles [rad].
        torques_nm: (T, n) float applied (clamped) joint torques at the frames [Nm].
        torque_ratio: (T,) float largest demanded torque ratio within each frame period.
        zmp_contact_m: (T, 2) float [m] centre of pressure of the ground contact forces,
            averaged over each frame period (NaN without contact).
        zmp_planned_m: (T, 2) float [m] multibody ZMP of the reference.
        contact_force_n: (T,) float total vertical ground force, averaged per frame [N].
        sole_forces_n: (T, 2, 3) float [left, right] ground force on each sole, averaged per
            frame [N].
        sole_cop_m: (T, 2, 2) float [left, right] centre of pressure of each sole [m] (NaN
            below 1 N).
        support: (T, 2) bool reference support phases used for the feed-forward.
        ground_offset_m: base height added to place the motion's first frame on the ground [m].
        config: the settings used.
        link_contact_force_n: (T,) float vertical force of the ground and the props on the
            robot's links other than the soles (hands, knees), averaged per frame [N].
        props: the scene's props in the world (empty: the ground alone).
    """

    robot: str
    joint_names: tuple[str, ...]
    fps: float
    fell: bool
    fall_reason: str
    survived_s: float
    duration_s: float
    tracking_rms_rad: float
    torque_ratio_max: float
    saturation_fraction: float
    base_drift_m: float
    base_height_drift_m: float
    keypoint_rms_mm: float
    keypoint_max_mm: float
    keypoint_worst: str
    keypoint_worst_s: float
    slip_mm: float
    slip_side: str
    slip_s: float
    friction_ratio: float
    cop_margin_mm: float
    relaxed_fraction: float
    real_time_factor: float
    wall_s: float
    controller_us_per_step: float
    physics_us_per_step: float
    times_s: np.ndarray
    q: np.ndarray
    q_reference: np.ndarray
    joint_error_rad: np.ndarray
    torques_nm: np.ndarray
    torque_ratio: np.ndarray
    zmp_contact_m: np.ndarray
    zmp_planned_m: np.ndarray
    contact_force_n: np.ndarray
    sole_forces_n: np.ndarray
    sole_cop_m: np.ndarray
    support: np.ndarray
    ground_offset_m: float
    config: PhysicsConfig = field(default_factory=PhysicsConfig)
    link_contact_force_n: np.ndarray = field(default_factory=lambda: np.zeros(0))
    props: tuple[str, ...] = ()

    @property
    def zmp_contact_error_mm(self) -> float:
        """RMS distance [mm] between the contact ZMP and the planned ZMP over the survived
        frames with contact (NaN if none)."""
        ok = ~np.isnan(self.zmp_contact_m[:, 0]) & ~np.isnan(self.zmp_planned_m[:, 0])
        if not ok.any():
            return float("nan")
        d = np.linalg.norm(self.zmp_contact_m[ok] - self.zmp_planned_m[ok], axis=1)
        return float(1e3 * np.sqrt(np.mean(d ** 2)))

    def metrics(self) -> dict:
        """The DESIGN.md physics metrics: ``physics_fell``, ``physics_survived_s``,
        ``tracking_rms_rad``, ``torque_ratio_max``."""
        return {
            "physics_fell": bool(self.fell),
            "physics_survived_s": float(self.survived_s),
            "tracking_rms_rad": float(self.tracking_rms_rad),
            "torque_ratio_max": float(self.torque_ratio_max),
        }

    def summary(self) -> dict:
        """Metrics and the other scalars (JSON-ready)."""
        return {
            **self.metrics(),
            "fall_reason": self.fall_reason,
            "duration_s": self.duration_s,
            "saturation_fraction": self.saturation_fraction,
            "base_drift_m": self.base_drift_m,
            "base_height_drift_m": self.base_height_drift_m,
            "keypoint_rms_mm": self.keypoint_rms_mm,
            "keypoint_max_mm": self.keypoint_max_mm,
            "keypoint_worst": self.keypoint_worst,
            "keypoint_worst_s": self.keypoint_worst_s,
            "slip_mm": self.slip_mm,
            "slip_side": self.slip_side,
            "slip_s": self.slip_s,
            "friction_ratio": self.friction_ratio,
            "cop_margin_mm": self.cop_margin_mm,
            "relaxed_fraction": self.relaxed_fraction,
            "zmp_contact_error_mm": self.zmp_contact_error_mm,
            "real_time_factor": self.real_time_factor,
            "wall_s": self.wall_s,
            "controller_us_per_step": self.controller_us_per_step,
            "physics_us_per_step": self.physics_us_per_step,
            "ground_offset_m": self.ground_offset_m,
            "link_contact_force_max_n": (float(np.nanmax(self.link_contact_force_n))
                                         if np.isfinite(self.link_contact_force_n).any()
                                         else 0.0),
            "props": list(self.props),
            "controller": self.config.control.controller,
            "fixed_base": self.config.fixed_base,
        }
