"""Settings of the motion-reduction optimizer (Okada & Miyazaki), one small frozen dataclass per
concept, composed by :class:`ReductionConfig`:

- :class:`SubspaceConfig`: the reduced dimension r (eqs 23-27), the band limit of the optimized
  trajectories and the cut-off of the differentiating filters (eqs 14-22);
- :class:`MotionWeights`: the weights of the evaluation function E = J_r + J_m (eqs 4, 12, 31);
- :class:`GroundForceConfig`: the ground-force condition (eq. 32) and the base pad's friction
  cone;
- :class:`JointLimitConfig`: the joint-angle and torque limits, as squared violations in stage
  (I) (eqs 33-34) and projections in stage (II) (eqs 8-11);
- :class:`SolverConfig`: the stage (I) step and the stopping tests.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..core.checks import NonNegative, require_count, require_finite
from ..errors import OptionError

METHODS = ("gauss-newton", "gradient")
#: The robot the force and torque settings are given for (the planar biped): other robots
#: scale forces by their mass and torques by mass x leg length.
REFERENCE_MASS = 8.4
REFERENCE_LEG = 0.34


@dataclass(frozen=True)
class SubspaceConfig:
    """Where the motion is optimized: the PCA subspace (eqs 23-27) and the band limits.

    Attributes:
        rank: r, the reduced dimension of the five non-foot angles (None: no reduction).
        center: subtract the mean posture before the SVD (the paper does not).
        cutoff_hz: cut-off f of the differentiating filters (eqs 14-22) [Hz].
        harmonics: the reduced trajectories are kept band-limited to harmonics 0..K of the
            cycle (None: free samples). The filter differentiators are blind near the Nyquist
            frequency (F1 has gain 0 there), so free samples let the optimizer hide zig-zags
            from the dynamics; K harmonics well below the cut-off keep every component visible.
        torque_harmonics: band-limit the torques the same way (None, the default: free
            samples; torques must jump where the contacts change, which a band limit forbids).
            Both are checked against the cycle's sample count by :func:`fourier_basis`.
    """

    rank: int | None = 3
    center: bool = False
    cutoff_hz: float = 40.0
    harmonics: int | None = 15
    torque_harmonics: int | None = None

    def __post_init__(self) -> None:
        if self.rank is not None and not 1 <= self.rank <= 5:
            raise OptionError("reduced dimension r", self.rank, "1..5 or full")
        require_finite(self, ("cutoff_hz",), positive=True)


@dataclass(frozen=True)
class MotionWeights(NonNegative):
    """Weights of J_m (eq. 4) and of the motion conditions of J_r (eq. 31).

    Attributes:
        acc: W_m = acc * I, the weight of the acceleration residual of J_m [1/(rad/s^2)^2].
        closure: w_ym, the weight of the closed-loop condition y_m = 0 [1/m^2].
        slip: weight of the sliding velocity of the moving foot at the base switches
            [1/(m/s)^2] (a motion condition added to J_r: the sliding foot must stop to become
            the base, see :meth:`PlanarChain.slip_velocity`).
        step: weight of the step-length condition [1/m^2]: at the last sample of each base
            phase the moving foot's ball is as far ahead of the base ball as in the initial
            (human) motion, so the motion stays a walk of the human's step length (a motion
            condition of J_r "depending on the reference motion").
        torque_rate: weight of the squared torque change between consecutive samples of the
            same contact phase [1/(Nm)^2]; without it each sample picks its own load split
            between the feet (case i) and torques and ground forces come out spiky.
    """

    acc: float = 1.0
    closure: float = 1e6
    slip: float = 1e4
    step: float = 1e4
    torque_rate: float = 1.0


@dataclass(frozen=True)
class GroundForceConfig(NonNegative):
    """The ground-force condition (eq. 32) and the base pad's friction cone, as squared
    violations.

    Forces are for an 8.4 kg robot with 0.34 m legs (:data:`REFERENCE_MASS`,
    :data:`REFERENCE_LEG`) and scale with the robot's mass. The pad must not slip:
    |f_x| <= friction * f_z, with the ground-force margin (a pad standing on a few newtons
    cannot take large horizontal forces).

    Attributes:
        f_min: [N] vertical ground forces must exceed this (eq. 32 with a margin from zero).
        margin: [N] the force terms aim at f_min + margin.
        weight: weight of the squared violation of the ground-force condition [1/N^2].
        friction: friction coefficient mu of the base pad.
        friction_weight: weight of the squared violation of the friction cone [1/N^2].
    """

    f_min: float = 1.0
    margin: float = 2.0
    weight: float = 1.0
    friction: float = 0.5
    friction_weight: float = 1.0


@dataclass(frozen=True)
class JointLimitConfig(NonNegative):
    """The joint-angle and torque limits: squared violations in stage (I) (their gradients are
    the directions of eqs 33-34 and 8-11), then, if ``project``, the projections of stage (II)
    back inside them (eqs 8-11).

    Torques are for an 8.4 kg robot with 0.34 m legs and scale with mass x leg length.

    Attributes:
        angle_margin: [rad] the limit terms and projections aim this far inside angle limits.
        torque_margin: fraction of the torque limit kept free by the limit terms/projections.
        weight_angle: weight of the squared joint-angle limit violations [1/rad^2].
        weight_torque: weight of the squared torque limit violations [1/(Nm)^2].
        project: run stage (II) after every stage (I).
        k_theta: K_theta of eqs 8-9 (1 = project onto the angle limit).
        k_u: K_u of eqs 10-11 (1 = project onto the torque limit).
    """

    angle_margin: float = 0.01
    torque_margin: float = 0.02
    weight_angle: float = 1e4
    weight_torque: float = 1e2
    project: bool = True
    k_theta: float = 1.0
    k_u: float = 1.0

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.torque_margin < 1.0:
            raise OptionError("torque margin", self.torque_margin, "a fraction in [0, 1)")


@dataclass(frozen=True)
class SolverConfig:
    """The stage (I) step and the stopping tests: stop when every |y_m| is below
    ``closure_tol_m``, the sliding velocity at the switches below ``slip_tol_m_s``,
    J_m <= ``jm_target_ratio`` * J_m(initial) and no limit or force is violated; or after
    ``patience`` iterations without a 1e-4 relative improvement, or ``max_iterations``.

    Attributes:
        method: "gauss-newton" (Levenberg-Marquardt) or "gradient" (steepest descent).
        max_iterations: stage (I)+(II) iterations at most.
        patience: iterations without a 1e-4 relative improvement of the objective.
        closure_tol_m: [m] bound on every |y_m|.
        slip_tol_m_s: [m/s] bound on the sliding velocity at the switches.
        jm_target_ratio: target J_m / J_m(initial).
    """

    method: str = "gauss-newton"
    max_iterations: int = 200
    patience: int = 30
    closure_tol_m: float = 2e-4
    slip_tol_m_s: float = 5e-3
    jm_target_ratio: float = 1e-4

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise OptionError("optimization method", self.method, METHODS)
        require_count(self, ("max_iterations", "patience"))
        require_finite(self, ("closure_tol_m", "slip_tol_m_s", "jm_target_ratio"),
                       positive=False)


@dataclass(frozen=True)
class ReductionConfig:
    """Settings of the optimization, one part per concept.

    Attributes:
        subspace: PCA rank, band limits, filter cut-off (eqs 14-27).
        weights: weights of J_m and J_r (eqs 4, 12, 31).
        ground: ground-force condition (eq. 32) and friction cone of the base pad.
        limits: joint-angle and torque limits: stage (I) terms and stage (II) projections
            (eqs 8-11, 33-34).
        solver: stage (I) method and stopping tests.
    """

    subspace: SubspaceConfig = field(default_factory=SubspaceConfig)
    weights: MotionWeights = field(default_factory=MotionWeights)
    ground: GroundForceConfig = field(default_factory=GroundForceConfig)
    limits: JointLimitConfig = field(default_factory=JointLimitConfig)
    solver: SolverConfig = field(default_factory=SolverConfig)
