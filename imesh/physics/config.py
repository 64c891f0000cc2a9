"""Settings of the DART dynamics check (:class:`PhysicsConfig`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ..core.checks import require_finite
from ..errors import OptionError

CONTROLLERS = ("spd", "pid")
COLLISION_DETECTORS = ("ode", "bullet", "dart", "fcl")


@dataclass(frozen=True)
class PhysicsConfig:
    """How a robot motion is simulated and judged in DART.

    Gains are set per joint from its torque limit, so one setting suits robots with 5 Nm wrists
    and 140 Nm knees: ``kp = kp_per_effort * effort_max`` [Nm/rad] (a joint saturates at
    ``1 / kp_per_effort`` rad of error), ``kd = kd_ratio * kp`` [Nm s/rad],
    ``ki = ki_ratio * kp`` [Nm/(rad s)] (PID only). ``gains`` overrides single joints.

    Attributes:
        fixed_base: weld the base to the world at the motion's first base pose (arm-only
            tracking; no ground, no falls, no contact ZMP).
        controller: ``"spd"`` (stable PD, Tan et al. 2011: implicit in the joint damping, stable
            at high gains) or ``"pid"`` (explicit PID).
        kp_per_effort: proportional gain per Nm of torque limit [1/rad].
        kd_ratio: derivative gain relative to the proportional gain [s].
        ki_ratio: integral gain relative to the proportional gain [1/s] (``"pid"`` only).
        gains: joint name -> (kp [Nm/rad], kd [Nm s/rad]) overriding the rule above.
        feedforward: add the inverse-dynamics torques of the reference motion (contact forces
            of the support feet distributed by weighted least squares).
        torque_limit_scale: torques are clamped to ``effort_max * torque_limit_scale``.
        dt: simulation and control period [s] (1 kHz).
        mass_matrix_every: the SPD controller refreshes the mass matrix every this many steps
            (DART's mass matrix costs about as much as a physics step; it changes slowly).
        settle_s: time the robot holds the first frame on the ground before tracking [s].
        extra_time_s: time the robot holds the last frame after the motion [s].
        fall_height_m: fallen when the base is this much lower than the reference [m].
        fall_tilt_rad: fallen when the base orientation differs from the reference by more than
            this angle [rad].
        stop_on_fall: end the simulation at a fall (the rest of the result is NaN).
        friction: Coulomb friction coefficient of the ground and the robot.
        sole_thickness_m: thickness of the sole boxes that replace the foot proxies [m].
        start_clearance_m: the first frame is placed this high above the ground before settling
            [m].
        collision_detector: DART collision detector (``ode`` handles every primitive and gives
            box-box contact patches; ``fcl`` has no capsules).
        contact_sample_every: contact forces (for the contact ZMP) are read every this many
            steps.
    """

    fixed_base: bool = False
    controller: str = "spd"
    kp_per_effort: float = 20.0
    kd_ratio: float = 0.05
    ki_ratio: float = 2.0
    gains: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    feedforward: bool = True
    torque_limit_scale: float = 1.0
    dt: float = 0.001
    mass_matrix_every: int = 8
    settle_s: float = 0.5
    extra_time_s: float = 0.0
    fall_height_m: float = 0.25
    fall_tilt_rad: float = 0.8
    stop_on_fall: bool = True
    friction: float = 1.0
    sole_thickness_m: float = 0.02
    start_clearance_m: float = 0.001
    collision_detector: str = "ode"
    contact_sample_every: int = 4

    def __post_init__(self) -> None:
        if self.controller not in CONTROLLERS:
            raise OptionError("physics controller", self.controller, CONTROLLERS)
        if self.collision_detector not in COLLISION_DETECTORS:
            raise OptionError("collision detector", self.collision_detector,
                              COLLISION_DETECTORS)
        positive = ("kp_per_effort", "dt", "fall_height_m", "fall_tilt_rad",
                    "torque_limit_scale", "sole_thickness_m")
        require_finite(self, positive, positive=True)
        require_finite(self, ("kd_ratio", "ki_ratio", "settle_s", "extra_time_s", "friction",
                              "start_clearance_m"), positive=False)
        if self.dt > 0.01:
            raise OptionError("dt", self.dt, "at most 0.01 s (1 kHz is the default)")
        for name in ("mass_matrix_every", "contact_sample_every"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise OptionError(name, value, "an integer >= 1")
        for joint, pair in self.gains.items():
            if (len(pair) != 2 or not all(np.isfinite(g) and g >= 0 for g in pair)):
                raise OptionError(f"gains of {joint}", pair, "(kp >= 0, kd >= 0)")
