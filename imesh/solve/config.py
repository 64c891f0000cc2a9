"""Settings of the whole-body solve (DESIGN.md, "Whole-body spacetime solve").

The weights of the objective's terms (:mod:`.costs`), the margins and slack prices of the
constraint rows (:mod:`.contacts`, :mod:`.zmp`, :mod:`.forces`, :mod:`.limits`,
:mod:`.collision`) and the SQP's stopping rules and trust region (:mod:`.sqp`), in one frozen
dataclass.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..core.checks import require_finite
from ..errors import OptionError
from .qp import SOLVERS


@dataclass(frozen=True)
class WholeBodyConfig:
    """Settings of the whole-body solve.

    Attributes:
        iterations: largest number of SQP iterations.
        step_tolerance: stop when no coordinate of the update exceeds this [m or rad] ...
        merit_tolerance: ... or when the constraints hold (soles within 1 mm, ZMP and swing
            feet within 1 mm of their bounds) and an iteration lowered the merit by less than
            this fraction.
        mesh_weight: w_L, weight of the interaction-mesh (Laplacian) energy of the key points.
        direction_weight: multiplies the key directions' weights.
        accel_weight: w_a, weight of the squared second differences (at 30 fps) of the base and
            joint coordinates [per (m or rad)^2].
        zmp_weight: w_z, weight of the squared distance of the ZMP beyond ``zmp_band_m`` from
            the desired ZMP (per axis) [1/m^2].
        zmp_band_m: a dead band around the desired ZMP [m]: a ZMP already within it costs
            nothing, so a balanced motion is left as it is.
        damping: w_r, weight of |dq|^2 in every iteration.
        init_weight: w_i, pull of the joints towards the initializer.
        zmp_margin_m: the support polygon is shrunk by this much [m].
        velocity_margin, acceleration_margin: the limits are used times (1 - margin), so the
            written motion meets them with room for rounding.
        clearance_m: swing-sole corners stay this high above the ground [m].
        swing_lift_m: over the middle third of a swing between two support phases of a foot,
            its ground points stay this high [m]: a step is a step (the evaluator, like a
            controller, tells phases apart by the sole leaving the ground).
        swing_edge_m: in every other frame of such a swing the ground points stay this high
            [m]: the sole leaves and lands flat instead of rolling over its toe or heel (the
            footprint model has no rolling contact).
        zmp_slack_weight: price of the ZMP constraints' slack per metre (an exact penalty:
            above the multipliers of a feasible problem the slack is 0 where it can be).
        elastic_weight: price per metre (or radian) of the slack of the sole and ground
            constraints: an exact penalty, so a linearization that cannot put a sole on its
            footprint at once (the initializer far from it) still has a solution that moves
            towards it; at a feasible point the slack is 0.
        min_normal: the total normal force stays above this fraction of the weight
            (``g + c_z'' >= min_normal g``): the ground cannot pull, and a tracking controller
            whose feet carry less than this at a push-off leaves the ground.
        max_normal: ... and below this fraction (``g + c_z'' <= max_normal g``): the support
            joints carry at most this times the weight (a human walk stays within about 0.7
            and 1.3).
        friction: mu of the friction cone the ground's total horizontal force stays in (the
            evaluator's ``friction_ratio_max`` uses the same mu); 0: no friction rows.
        torque_margin: the net joint torques (inverse dynamics, the base wrench split between
            the support soles as the evaluator's ``torque_ratio_ref``) stay within
            ``1 - torque_margin`` of the effort limits (elastic rows, :mod:`.torque`); 1: no
            torque rows.
        trust_region: largest change of any base or joint coordinate in one iteration [m or
            rad], so the linearization stays valid.
        base_trust: the base translation's region is this fraction of ``trust_region`` [m].
        initial_lowpass_hz: cut-off of the low-pass applied to the initial fit before the
            solve [Hz] (:func:`imesh.solve.initial.smooth_initializer`).
        solver: QP solver, one of :data:`imesh.solve.qp.SOLVERS`.
        qp_tolerance: absolute tolerance of each QP solve.
        self_collision: keep the robot's capsules apart (docs/collision.md): every checked
            pair closer than ``collision_activation_m`` gets a row ``d + J dq >= margin``.
        collision_margin_m: the signed distance the capsules keep [m].
        collision_activation_m: pairs closer than this at the iterate get a row [m].
    """

    iterations: int = 20
    step_tolerance: float = 1e-4
    merit_tolerance: float = 3e-2
    mesh_weight: float = 1.0
    direction_weight: float = 1.0
    accel_weight: float = 3.0
    zmp_weight: float = 10.0
    zmp_band_m: float = 0.015
    damping: float = 1e-3
    init_weight: float = 1e-2
    zmp_margin_m: float = 0.01
    velocity_margin: float = 1e-3
    acceleration_margin: float = 1e-3
    clearance_m: float = 0.0
    swing_lift_m: float = 0.03
    swing_edge_m: float = 0.02
    zmp_slack_weight: float = 1e3
    elastic_weight: float = 1e4
    min_normal: float = 0.7
    max_normal: float = 1.3
    friction: float = 0.7
    torque_margin: float = 0.05
    trust_region: float = 0.3
    base_trust: float = 0.2
    initial_lowpass_hz: float = 4.0
    solver: str = "piqp"
    qp_tolerance: float = 1e-7
    self_collision: bool = True
    collision_margin_m: float = 0.005
    collision_activation_m: float = 0.02

    def __post_init__(self) -> None:
        if not (isinstance(self.iterations, int) and self.iterations >= 1):
            raise OptionError("iterations", self.iterations, "an integer >= 1")
        require_finite(self, ("step_tolerance", "qp_tolerance", "merit_tolerance"),
                       positive=True)
        require_finite(self, ("mesh_weight", "direction_weight", "accel_weight", "zmp_weight",
                              "damping", "init_weight", "zmp_margin_m", "velocity_margin",
                              "acceleration_margin", "clearance_m", "swing_lift_m",
                              "swing_edge_m", "zmp_slack_weight", "elastic_weight",
                              "zmp_band_m", "trust_region", "initial_lowpass_hz", "base_trust",
                              "min_normal", "max_normal", "friction", "torque_margin",
                              "collision_activation_m"), positive=False)
        if self.torque_margin > 1:
            raise OptionError("torque_margin", self.torque_margin, "a number in [0, 1]")
        if self.max_normal < self.min_normal:
            raise OptionError("max_normal", self.max_normal,
                              f"a number >= min_normal ({self.min_normal})")
        if self.solver not in SOLVERS:
            raise OptionError("solver", self.solver, SOLVERS)
