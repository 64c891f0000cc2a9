"""Settings of the motion-reduction optimizer (Okada & Miyazaki): the reduced dimension r
(eqs 23-27), the weights of the evaluation function E = J_r + J_m (eqs 4, 12, 31) and of the
squared violations of the ground-force condition and the limits (eqs 8-11, 32-34), the stage
(II) projection gains (eqs 8-11) and the stopping tests."""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import OptionError

METHODS = ("gauss-newton", "gradient")
#: The robot the force and torque settings are given for (the planar biped): other robots
#: scale forces by their mass and torques by mass x leg length.
REFERENCE_MASS = 8.4
REFERENCE_LEG = 0.34


@dataclass(frozen=True)
class ReductionConfig:
    """Settings of the optimization.

    Attributes:
        rank: r, the reduced dimension of the five non-foot angles (None: no reduction).
        center: subtract the mean posture before the SVD (the paper does not).
        cutoff_hz: cut-off f of the differentiating filters [Hz].
        harmonics: the reduced trajectories are kept band-limited to harmonics 0..K of the
            cycle (None: free samples). The filter differentiators are blind near the Nyquist
            frequency (F1 has gain 0 there), so free samples let the optimizer hide zig-zags
            from the dynamics; K harmonics well below the cut-off keep every component visible.
        torque_harmonics: band-limit the torques the same way (None, the default: free
            samples; torques must jump where the contacts change, which a band limit forbids).
        weight_torque_rate: weight of the squared torque change between consecutive samples
            of the same contact phase [1/(Nm)^2]; without it each sample picks its own load
            split between the feet (case i) and torques and ground forces come out spiky.
        weight_acc: W_m = weight_acc * I [1/(rad/s^2)^2].
        weight_closure: w_ym [1/m^2].
        weight_slip: weight of the sliding velocity of the moving foot at the base switches
            [1/(m/s)^2] (a motion condition added to J_r: the sliding foot must stop to become
            the base, see :meth:`PlanarChain.slip_velocity`).
        weight_step: weight of the step-length condition [1/m^2]: at the last sample of each
            base phase the moving foot's ball is as far ahead of the base ball as in the initial
            (human) motion, so the motion stays a walk of the human's step length (a motion
            condition of J_r "depending on the reference motion").
        weight_grf, weight_angle, weight_torque: weights of the squared violations of the
            ground-force condition (eq. 32, below f_min + grf_margin) [1/N^2], of the joint
            angle limits [1/rad^2] and of the torque limits [1/(Nm)^2]: the gradients of these
            terms are the directions of eqs 33-34 and 8-11.
        weight_friction, friction: the base pad must not slip: |f_x| <= friction * f_z
            (added to the ground-force condition; a pad standing on a few newtons cannot take
            large horizontal forces) [1/N^2].
        method: "gauss-newton" or "gradient".
        max_iterations: stage (I)+(II) iterations at most.
        k_theta, k_u: K_theta and K_u of eqs 8-11 (1 = project onto the limit).
        f_min: [N] ground forces must exceed this (eq. 32 with a margin from zero). Force and
            torque settings are for an 8.4 kg robot with 0.34 m legs and scale with the
            robot's mass (forces) and mass x leg length (torques).
        grf_margin: [N] the force terms aim at f_min + grf_margin.
        angle_margin: [rad] the limit terms and projections aim this far inside angle limits.
        torque_margin: fraction of the torque limit kept free by the limit terms/projections.
        closure_tol_m: stop when every |y_m| is below this, ...
        slip_tol_m_s: ... the sliding velocity at the switches below this, ...
        jm_target_ratio: ... J_m <= ratio * J_m(initial) and no limit or force is violated;
        patience: ... or after this many iterations without a 1e-4 relative improvement.
        stage2: run stage (II) (projections of eqs 8-11) after every stage (I).
    """

    rank: int | None = 3
    center: bool = False
    cutoff_hz: float = 40.0
    harmonics: int | None = 15
    torque_harmonics: int | None = None
    weight_torque_rate: float = 1.0
    weight_acc: float = 1.0
    weight_closure: float = 1e6
    weight_slip: float = 1e4
    weight_step: float = 1e4
    weight_grf: float = 1.0
    weight_angle: float = 1e4
    weight_torque: float = 1e2
    weight_friction: float = 1.0
    friction: float = 0.5
    method: str = "gauss-newton"
    max_iterations: int = 200
    k_theta: float = 1.0
    k_u: float = 1.0
    f_min: float = 1.0
    grf_margin: float = 2.0
    angle_margin: float = 0.01
    torque_margin: float = 0.02
    closure_tol_m: float = 2e-4
    slip_tol_m_s: float = 5e-3
    jm_target_ratio: float = 1e-4
    patience: int = 30
    stage2: bool = True

    def __post_init__(self):
        if self.method not in METHODS:
            raise OptionError("optimization method", self.method, METHODS)
        if self.rank is not None and not 1 <= self.rank <= 5:
            raise OptionError("reduced dimension r", self.rank, "1..5 or full")

