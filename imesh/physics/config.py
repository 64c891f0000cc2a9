"""Settings of the DART dynamics check (:class:`PhysicsConfig`), one small part per concept:
the joint controller (:class:`ControlConfig`), the time line (:class:`TimingConfig`), the fall
detection (:class:`FallConfig`) and the ground contact (:class:`GroundConfig`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ..core.checks import NonNegative, require_count, require_finite
from ..errors import OptionError

CONTROLLERS = ("wbc", "kinematic", "spd", "pid")
COLLISION_DETECTORS = ("ode", "bullet", "dart", "fcl")


@dataclass(frozen=True)
class WbcGains(NonNegative):
    """Feedback gains of the whole-body controller's tasks (accelerations per unit error).

    Attributes:
        dcm: capture-point gain ``k_xi`` [1/s] of the horizontal CoM (the divergent component
            of motion converges at ``k_xi``).
        com_z_kp: vertical CoM stiffness [1/s^2]; ``com_z_kd`` its damping [1/s].
        base_kp: base orientation stiffness [1/s^2]; ``base_kd`` [1/s].
        sole_kp: swing sole pose stiffness [1/s^2]; ``sole_kd`` [1/s].
        joint_kp: joint posture stiffness [1/s^2]; ``joint_kd`` [1/s].
        momentum_kp: feedback of the centroidal angular momentum [1/s].
        contact_kd: damping of a contact sole's residual velocity [1/s] (30: with the
            angular momentum weighted as the CoM, 10 let the JVRC-1 walk's stance sole slip
            59.4 mm at a lift-off, 60 left 7 of the 12 runs of docs/wholebody.md above 80 mm of
            key-point error, 100 lost 8 of them).
        contact_kp: stiffness driving a contact sole back flat on the ground (height, roll,
            pitch) [1/s^2].
    """

    dcm: float = 8.0
    com_z_kp: float = 100.0
    com_z_kd: float = 20.0
    base_kp: float = 200.0
    base_kd: float = 28.0
    sole_kp: float = 400.0
    sole_kd: float = 40.0
    joint_kp: float = 200.0
    joint_kd: float = 28.0
    momentum_kp: float = 5.0
    contact_kd: float = 30.0
    contact_kp: float = 100.0


@dataclass(frozen=True)
class WbcWeights(NonNegative):
    """Weights of the whole-body controller's tasks in its QP cost (per squared m/s^2 or
    rad/s^2), and the regularization of the unknowns.

    Attributes:
        com: centre of mass, with the capture-point feedback that keeps the robot up.
        momentum: centroidal angular momentum rate, in ZMP-equivalent units (``Ldot / m z``),
            as heavy as the CoM: at a tenth of it the controller bought the balance with the
            trunk (the JVRC-1 walk's waist 13 deg forward of the reference, its hands 138 mm
            off), and 8 of the 12 runs of docs/wholebody.md had a key point more than 80 mm
            off, 5 with this weight (docs/checking.md).
        base: base orientation.
        swing: swing soles (6 rows each). At 30 (and the upper body at 2) the swing foot lags
            its reference after each lift-off (the plan starts it at over 1 m/s in one frame)
            and the G1 walk's left knee ends 86.9 mm off; at 60 81.0 mm and its stance sole
            slips 2.8 mm instead of 7.6 (at 45 the worst walk of docs/wholebody.md reads
            81.3 mm, at 80 88.0).
        joints: joint posture of the legs (the joints between the base and a sole). At 0.05
            (they yielded to the CoM) a knee straightened in a push-off stayed straight
            while the reference bent it: at a straight knee its bending moves neither the
            sole nor the hip along the leg to first order, so the sole and CoM tasks do not
            bend it back (G1 veer: the stance knee at its limit, 0.77 rad from the
            reference, key points 113 mm off; the JVRC-1 veer's swing knee 0.6 rad, 112 mm);
            at 0.5 22 and 27 mm. (A weight of 1, with an older toe roll, fought the CoM and
            lost the G1 walk at 2.0 s.)
        upper_body: joint posture of every other joint (waist, arms, head: a torso swung to
            catch the balance moves the hands and the head far from the reference). At 1 the
            G1 walk's trunk gave way after a lift-off (waist 7 deg off, left hand 97.6 mm off)
            and the HRP-4C walk and wave read 97.8 and 88.8 mm; at 2 (the swing at 30) 86.9,
            72.5 and 68.8; at 3 the JVRC-1 wash 147 mm (the legs lose to the trunk).
        contact: the contact soles' acceleration rows when they cannot all be met within the
            torque limits (then a task, the heaviest; otherwise constraints).
        acceleration: every generalized acceleration (regularization).
        force: every contact force component, per N^2 (spreads the load between the soles).
        moment: every contact moment component about the sole centre, per (N m)^2 (keeps the
            centres of pressure off the edges where the dynamics leave them free, as in double
            support). Small on purpose: it prices the centre of pressure away from the sole
            centre, which is where the reference puts it, so a larger weight trades CoM
            tracking for it; at 1e-2 JVRC-1 holding a still pose stood with its CoM 4.3 mm
            behind the reference for good, at 1e-4 0.2 mm.
    """

    com: float = 1000.0
    momentum: float = 1000.0
    base: float = 10.0
    swing: float = 60.0
    joints: float = 0.5
    upper_body: float = 2.0
    contact: float = 1e4
    acceleration: float = 1e-4
    force: float = 1e-5
    moment: float = 1e-4


@dataclass(frozen=True)
class WbcConfig:
    """The whole-body QP controller (``ControlConfig(controller="wbc")``,
    :mod:`imesh.physics.wbc`).

    Attributes:
        gains: task feedback gains.
        weights: task weights.
        rate_hz: control rate [Hz] (the torques are held between control steps; at most the
            simulation rate).
        cop_margin: fraction of each sole's half sizes kept free of the centre of pressure.
        friction_fraction: the controller assumes this fraction of the ground's friction.
        torque_fraction: torques are constrained to this fraction of the effort limits.
        min_normal_force_n: smallest normal force of a sole in contact [N].
        contact_height_m: a sole planned in support is treated as in contact once its lowest
            corner is this close to the ground [m].
        limit_horizon_s: the joint accelerations are bounded so that every joint, braking
            over this time, stays within its position limits and below its velocity limit [s]
            (without them the swing leg reached its foot targets with JVRC-1's knee bent 0.66
            rad backwards; at 0.1 s they braked HRP-4C's swing knee so early that its foot
            landed 20 mm high and 0.2 m behind its footprint).
        toe_roll_frames: over the last this many frames of a double support that ends in a
            lift-off, the lifting sole rolls over its toe edge (:mod:`imesh.physics.wbc`); 0:
            it stays flat until it leaves.
        toe_cop_fraction: in that roll the centre of pressure stays in the front
            ``1 - toe_cop_fraction`` of the sole's half length.
        toe_lateral: ... and within ``toe_lateral`` of the sole's half width of its middle,
            so that both toe corners carry it: in DART a centre of pressure near a toe corner
            stood the rolling sole on that corner alone, which holds no moment about the
            vertical, and its heel swung 7 mm sideways before the lift-off (JVRC-1 veer). The
            rolling sole's wrench cone is that of this front strip (a line contact).
        slip_speed_m_s: a sole the plan slides or pivots is sliding once its centre moves
            faster than this over the ground [m/s]; the controller then takes the ground's
            friction on it as Coulomb's kinetic force, against the motion
            (:mod:`imesh.physics.wbc`).
        landing_depth_m: a sole the plan has in support while it is still in the air (a late
            landing) is driven to this far below its reference [m]. On the 12 runs of
            docs/wholebody.md, from 0 to 0.02, the runs slipping more than 5 mm fall from 4 to
            2 and those with a key point more than 80 mm off from 5 to 4 (at 0.015, 0.025, 0.03
            and 0.04: 3, 4, 4, 2 slipping and 4, 5, 5, 5 off).
    """

    gains: WbcGains = field(default_factory=WbcGains)
    weights: WbcWeights = field(default_factory=WbcWeights)
    rate_hz: float = 1000.0
    cop_margin: float = 0.1
    friction_fraction: float = 0.7
    torque_fraction: float = 1.0
    min_normal_force_n: float = 1.0
    contact_height_m: float = 0.005
    limit_horizon_s: float = 0.05
    toe_roll_frames: int = 2
    toe_cop_fraction: float = 0.8
    landing_depth_m: float = 0.02
    toe_lateral: float = 0.3
    slip_speed_m_s: float = 0.02

    def __post_init__(self) -> None:
        require_finite(self, ("rate_hz", "friction_fraction", "torque_fraction",
                              "limit_horizon_s"), positive=True)
        if not (isinstance(self.toe_roll_frames, int) and self.toe_roll_frames >= 0):
            raise OptionError("toe_roll_frames", self.toe_roll_frames, "an integer >= 0")
        if not 0.0 < self.toe_lateral <= 1.0:
            raise OptionError("toe_lateral", self.toe_lateral, "a fraction in (0, 1]")
        if not 0.0 <= self.toe_cop_fraction < 1.0:
            raise OptionError("toe_cop_fraction", self.toe_cop_fraction, "a fraction in [0, 1)")
        require_finite(self, ("min_normal_force_n", "contact_height_m", "landing_depth_m",
                              "slip_speed_m_s"), positive=False)
        if not 0.0 <= self.cop_margin < 1.0:
            raise OptionError("cop_margin", self.cop_margin, "a fraction in [0, 1)")
        if self.torque_fraction > 1.0:
            raise OptionError("torque_fraction", self.torque_fraction, "at most 1")


@dataclass(frozen=True)
class ControlConfig:
    """The controller of the check and its gains.

    Gains are set per joint from its torque limit, so one setting suits robots with 5 Nm wrists
    and 140 Nm knees: ``kp = kp_per_effort * effort_max`` [Nm/rad] (a joint saturates at
    ``1 / kp_per_effort`` rad of error), ``kd = kd_ratio * kp`` [Nm s/rad],
    ``ki = ki_ratio * kp`` [Nm/(rad s)] (PID only). ``gains`` overrides single joints.

    Attributes:
        controller: ``"wbc"`` (the whole-body QP controller with balance feedback, the
            default), ``"kinematic"`` (joints follow the reference exactly, base free: the
            paper's check), ``"spd"`` (open-loop stable PD, Tan et al. 2011: implicit in the
            joint damping, stable at high gains) or ``"pid"`` (open-loop explicit PID).
        kp_per_effort: proportional gain per Nm of torque limit [1/rad].
        kd_ratio: derivative gain relative to the proportional gain [s].
        ki_ratio: integral gain relative to the proportional gain [1/s] (``"pid"`` only).
        gains: joint name -> (kp [Nm/rad], kd [Nm s/rad]) overriding the rule above.
        feedforward: add the inverse-dynamics torques of the reference motion (contact forces
            of the support feet distributed by weighted least squares).
        torque_limit_scale: torques are clamped to ``effort_max * torque_limit_scale``.
        mass_matrix_every: the SPD controller refreshes the mass matrix every this many steps
            (DART's mass matrix costs about as much as a physics step; it changes slowly).
        wbc: the whole-body controller's settings (``"wbc"`` only).
    """

    controller: str = "wbc"
    kp_per_effort: float = 20.0
    kd_ratio: float = 0.05
    ki_ratio: float = 2.0
    gains: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    feedforward: bool = True
    torque_limit_scale: float = 1.0
    mass_matrix_every: int = 8
    wbc: WbcConfig = field(default_factory=WbcConfig)

    def __post_init__(self) -> None:
        if self.controller not in CONTROLLERS:
            raise OptionError("physics controller", self.controller, CONTROLLERS)
        require_finite(self, ("kp_per_effort", "torque_limit_scale"), positive=True)
        require_finite(self, ("kd_ratio", "ki_ratio"), positive=False)
        require_count(self, ("mass_matrix_every",))
        for joint, pair in self.gains.items():
            if (len(pair) != 2 or not all(np.isfinite(g) and g >= 0 for g in pair)):
                raise OptionError(f"gains of {joint}", pair, "(kp >= 0, kd >= 0)")


@dataclass(frozen=True)
class TimingConfig:
    """The simulated time line.

    Attributes:
        dt: simulation and control period [s] (1 kHz).
        settle_s: time the robot holds the first frame on the ground before tracking [s].
        extra_time_s: time the robot holds the last frame after the motion [s].
    """

    dt: float = 0.001
    settle_s: float = 0.5
    extra_time_s: float = 0.0

    def __post_init__(self) -> None:
        require_finite(self, ("dt",), positive=True)
        require_finite(self, ("settle_s", "extra_time_s"), positive=False)
        if self.dt > 0.01:
            raise OptionError("dt", self.dt, "at most 0.01 s (1 kHz is the default)")


@dataclass(frozen=True)
class FallConfig:
    """When the robot has fallen, and what a fall does.

    Attributes:
        height_m: fallen when the base is this much lower than the reference [m].
        tilt_rad: fallen when the base orientation differs from the reference by more than
            this angle [rad].
        lost_m: the motion is lost (counted as a fall) when a key point of the robot
            (markers.toml) is farther than this from where the reference has it [m]: a
            balance controller that stays up by not following the motion (a lean that would
            put the CoM beyond the toes) has not performed it. 0 turns it off.
        stop: end the simulation at a fall (the rest of the result is NaN).
    """

    height_m: float = 0.25
    tilt_rad: float = 0.8
    lost_m: float = 0.25
    stop: bool = True

    def __post_init__(self) -> None:
        require_finite(self, ("height_m", "tilt_rad"), positive=True)
        require_finite(self, ("lost_m",), positive=False)
        if self.lost_m < 0:
            raise OptionError("fall lost_m", self.lost_m, ">= 0 [m] (0: off)")


@dataclass(frozen=True)
class GroundConfig:
    """The ground, the robot's soles and how their contacts are computed and read.

    Attributes:
        friction: Coulomb friction coefficient of the ground and the robot.
        slide_friction: Coulomb friction coefficient under a sole while the plan slides or
            pivots it (its ``contact_modes``), static and kinetic: a floor as slippery as the
            whole-body solve assumed there (``ForceOptions.kinetic_friction``: at most 0.3).
            On a floor of ``friction`` (1.0) a sliding sole is braked by its whole normal
            force, which no plan of a slide asks for, and a held one does not slide at all.
            Measured on the two clips with slides (G1, docs/checking.md): at 0, 0.1, 0.3 and
            1.0 salsa A was lost at 6.13, 6.43, 6.30 and 5.67 s, the zombie walk (0, 0.1,
            0.3) at 1.33, 1.67 and 1.40 s.
        sole_thickness_m: thickness of the sole boxes that replace the foot proxies [m].
        start_clearance_m: the first frame is placed this high above the ground before settling
            [m].
        collision_detector: DART collision detector (``ode`` handles every primitive and gives
            box-box contact patches; ``fcl`` has no capsules).
        contact_sample_every: contact forces (for the contact ZMP) are read every this many
            steps.
    """

    friction: float = 1.0
    slide_friction: float = 0.1
    sole_thickness_m: float = 0.02
    start_clearance_m: float = 0.001
    collision_detector: str = "ode"
    contact_sample_every: int = 4

    def __post_init__(self) -> None:
        if self.collision_detector not in COLLISION_DETECTORS:
            raise OptionError("collision detector", self.collision_detector,
                              COLLISION_DETECTORS)
        require_finite(self, ("sole_thickness_m",), positive=True)
        require_finite(self, ("friction", "slide_friction", "start_clearance_m"),
                       positive=False)
        require_count(self, ("contact_sample_every",))


@dataclass(frozen=True)
class PhysicsConfig:
    """How a robot motion is simulated and judged in DART.

    Attributes:
        fixed_base: weld the base to the world at the motion's first base pose (arm-only
            tracking; no ground, no falls, no contact ZMP).
        control: the joint controller and its gains.
        timing: simulation period, settling and hold times.
        fall: fall detection.
        ground: ground, soles and contact computation.
    """

    fixed_base: bool = False
    control: ControlConfig = field(default_factory=ControlConfig)
    timing: TimingConfig = field(default_factory=TimingConfig)
    fall: FallConfig = field(default_factory=FallConfig)
    ground: GroundConfig = field(default_factory=GroundConfig)
