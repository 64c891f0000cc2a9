"""Motion pattern optimization in the reduced space (eqs 4-13, 28-34).

Design parameters: the reduced trajectory ``Theta_hat`` (r x n) of the five non-foot link angles
(theta_1..theta_5; the foot angles theta_0, theta_6 are given by the contact condition), kept
band-limited to K harmonics, and the torques ``U`` (n x 6). The evaluation function (eq. 12) is

    E = J_r + J_m,
    J_m = sum_k (theta_ddot_k - theta_ddot^T_k)^T W_m (...)       (eq. 4)
    J_r = sum_k w_ym y_mk^2                                       (eq. 31, closed loop)
          + w_slip sum_switch v_slip^2 + w_step sum_switch (step - step_human)^2

with ``theta_ddot = Theta F2`` and ``theta_ddot^T`` the accelerations the torques produce through
the constrained dynamics (eq. 5, :class:`~imesh.reduction.dynamics.ChainDynamics`). The two added
motion conditions (the sliding foot stops when it becomes the base; the step length of the human
motion) are what walking needs beyond the paper's moon-walk (docs/reduction.md).

Each iteration has the paper's two stages:

(I)  the reduced data and the torques move along the gradient of E (eq. 13 through F1 and F2,
     eq. 28; the same for U) and are restored (eq. 27). The ground-force condition (eq. 32, with
     the base pad's friction cone) and the limits enter this stage as squared violations, whose
     gradients are the directions of eqs 33-34 and 8-11; torque changes inside a contact phase
     are penalized lightly (smooth torques, jumps allowed where contacts change);
(II) angles and torques still past their limits are pulled back by the projection updates
     (eqs 8-11; angle limits on the robot's joint angles, moved with the smallest change of the
     non-foot angles).

``method="gauss-newton"`` (default) takes a Levenberg-Marquardt step on all parameters with the
residuals and derivatives of stage (I); ``method="gradient"`` the paper's steepest descent
(Jacobi-scaled, Armijo step). Both record J_m and J_r after every iteration.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import OptionError
from .chain import FEET, MID, PlanarChain, joint_matrix
from .contact import ContactSchedule
from .diff import derivative_matrices
from .dynamics import ChainDynamics, DynamicsResult
from .pca import PCABasis, pca_basis

log = logging.getLogger(__name__)

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


@dataclass
class Evaluation:
    """Everything known about one (Theta, U): trajectory, dynamics, terms of E."""

    phi: np.ndarray          # (n, 7)
    phid: np.ndarray
    phidd: np.ndarray
    torque: np.ndarray       # (n, 6)
    dyn: DynamicsResult
    residual: np.ndarray     # (n, 7) phidd - acc
    y: np.ndarray            # (n,) closure y_m [m]
    dy: np.ndarray           # (n, 7)
    slip: np.ndarray         # (n,) sliding velocity at the switch frames, 0 elsewhere [m/s]
    step: np.ndarray         # (n,) step-length error at the phase ends, 0 elsewhere [m]
    dstep_dphi: np.ndarray   # (n, 7)
    dslip_dphi: np.ndarray   # (n, 7)
    dslip_dphid: np.ndarray  # (n, 7)
    J_m: float
    J_r: float
    penalty: float = 0.0     # squared violations of forces and limits (weighted)

    @property
    def E(self) -> float:
        return self.J_m + self.J_r

    @property
    def objective(self) -> float:
        return self.J_m + self.J_r + self.penalty


@dataclass
class IterationRecord:
    """One iteration (stage I + II): both evaluation terms and the constraint evidence."""

    iteration: int
    J_m: float
    J_r: float
    E: float
    penalty: float
    closure_max_mm: float
    slip_max_m_s: float
    min_grf_N: float
    angle_violations: int
    torque_violations: int
    seconds: float
    step: float = float("nan")
    projected_angles: int = 0
    projected_torques: int = 0


@dataclass
class OptimizationResult:
    """The optimized motion and the evidence.

    Attributes:
        phi, phid, phidd: (n, 7) link angles, rates, accelerations of the robot motion.
        torque: (n, 6) [Nm] joint torques (JOINTS order).
        initial: evaluation of the initial motion with its best torques.
        final: evaluation of the result.
        history: one record per iteration (stage I + II).
        basis: the PCA basis (None when not reduced).
        seconds: wall time [s].
        converged: the stopping tests were met (not just the iteration limit).
    """

    phi: np.ndarray
    phid: np.ndarray
    phidd: np.ndarray
    torque: np.ndarray
    initial: Evaluation
    final: Evaluation
    history: list[IterationRecord]
    basis: PCABasis | None
    seconds: float
    converged: bool
    config: ReductionConfig = field(default_factory=ReductionConfig)


def fourier_basis(n: int, harmonics: int | None) -> np.ndarray:
    """(n, nb) orthonormal real Fourier basis of harmonics 0..K of an n-sample cycle
    (identity for None: every sample free)."""
    if harmonics is None:
        return np.eye(n)
    K = int(harmonics)
    if not 1 <= K < n // 2:
        raise OptionError("harmonics", harmonics, f"1..{n // 2 - 1} or None")
    t = 2 * np.pi * np.arange(n) / n
    cols = [np.ones(n) / np.sqrt(n)]
    for k in range(1, K + 1):
        cols.append(np.cos(k * t) * np.sqrt(2.0 / n))
        cols.append(np.sin(k * t) * np.sqrt(2.0 / n))
    return np.stack(cols, axis=1)


#: residual rows per frame: 7 accelerations, closure, slip, 3 forces, 6 angles, 6 torques,
#: friction
_ROWS: dict[str, slice | int] = {"acc": slice(0, 7), "closure": 7, "slip": 8, "grf": slice(9, 12),
         "angle": slice(12, 18), "torque": slice(18, 24), "friction": 24, "step": 25}
_M = 26


class MotionOptimizer:
    """The optimization problem of one cyclic motion on one robot.

    Args:
        chain: the robot's sagittal chain.
        schedule: contact schedule (base foot, contact case, foot angles) per sample.
        phi0: (n, 7) initial link angles (the feet are replaced by the schedule's).
        dt: sample period [s].
        config: settings.
        dynamics: a ChainDynamics of ``chain`` to reuse.
    """

    def __init__(self, chain: PlanarChain, schedule: ContactSchedule, phi0: np.ndarray,
                 dt: float, config: ReductionConfig | None = None,
                 dynamics: ChainDynamics | None = None):
        self.chain = chain
        self.schedule = schedule
        self.config = c = config or ReductionConfig()
        self.dyn = dynamics or ChainDynamics(chain)
        self.n = n = int(phi0.shape[0])
        if schedule.n != n:
            raise OptionError("contact schedule length", schedule.n, f"{n} (the motion's)")
        self.dt = float(dt)
        self.F1, self.F2 = derivative_matrices(n, self.dt, c.cutoff_hz)
        phi0 = np.array(phi0, float)
        phi0[:, FEET[0]] = schedule.feet[:, 0]
        phi0[:, FEET[1]] = schedule.feet[:, 1]
        self.phi0 = phi0
        self.feet_d1 = schedule.feet_d1 / self.dt
        self.feet_d2 = schedule.feet_d2 / self.dt ** 2
        self.mid = list(MID)
        self.basis = (pca_basis(phi0[:, self.mid].T, c.rank, c.center)
                      if c.rank is not None else None)
        self.fourier = fourier_basis(n, c.harmonics)
        self.fourier_u = fourier_basis(n, c.torque_harmonics)
        # cyclic forward difference inside contact phases (rows zero across a change of base
        # foot or contact case)
        same = (schedule.base == np.roll(schedule.base, -1)) & \
            (schedule.case == np.roll(schedule.case, -1))
        self.rate_matrix = (np.roll(np.eye(n), 1, axis=1) - np.eye(n)) * same[:, None]
        self.F1T = self.F1.T @ self.fourier
        self.F2T = self.F2.T @ self.fourier
        self.switch_frames = np.array(sorted({(k + d) % n for k in schedule.switches
                                              for d in (-1, 0)}), int)
        self.switch_mask = np.zeros(n, bool)
        self.switch_mask[self.switch_frames] = True
        # last sample of each base phase: the step-length condition
        self.end_mask = np.zeros(n)
        self.end_mask[[(k - 1) % n for k in schedule.switches]] = 1.0
        self.step_target = self.chain.step_length(phi0, schedule.base)[0]
        self.A_joint = chain.joint_sign[:, None] * joint_matrix()   # q_joint = A_joint @ phi
        self.A_mid_pinv = np.linalg.pinv(self.A_joint[:, self.mid])
        # force and torque terms are set for an 8.4 kg, 0.34 m-leg robot; other robots scale
        # them with their weight (forces) and weight x leg length (torques)
        leg = float(chain.joint_xz[0, 1] - chain.ground_z)
        self.force_scale = chain.total_mass / REFERENCE_MASS
        self.torque_scale = self.force_scale * leg / REFERENCE_LEG
        self.f_min = c.f_min * self.force_scale
        self.f_margin = c.grf_margin * self.force_scale
        self.f_target = self.f_min + self.f_margin
        self.s_grf = np.sqrt(c.weight_grf) / self.force_scale
        self.s_friction = np.sqrt(c.weight_friction) / self.force_scale
        self.s_torque = np.sqrt(c.weight_torque) / self.torque_scale
        self.w_rate = c.weight_torque_rate / self.torque_scale ** 2

    # --- parametrization ------------------------------------------------------------------

    @property
    def basis_matrix(self) -> np.ndarray:
        """(5, r) d Theta_mid / d Theta_hat."""
        return self.basis.Q1 if self.basis is not None else np.eye(5)

    def to_params(self, phi: np.ndarray) -> np.ndarray:
        """(r, nb) parameters of a motion's non-foot angles: PCA projection (eq. 26), then the
        band-limited projection."""
        mid = phi[:, self.mid].T
        hat = self.basis.reduce(mid) if self.basis is not None else mid.copy()
        return hat @ self.fourier

    def to_phi(self, params: np.ndarray) -> np.ndarray:
        """(n, 7) link angles from parameters (restoration, eq. 27) and the given feet."""
        phi = self.phi0.copy()
        hat = params @ self.fourier.T
        mid = self.basis.restore(hat) if self.basis is not None else hat
        phi[:, self.mid] = mid.T
        return phi

    # --- evaluation -------------------------------------------------------------------------

    def evaluate(self, phi: np.ndarray, torque: np.ndarray, derivatives: bool = True
                 ) -> Evaluation:
        """Trajectory (F1, F2; exact foot rates), dynamics, J_m, J_r and penalty terms."""
        s = self.schedule
        phid = (phi.T @ self.F1).T
        phidd = (phi.T @ self.F2).T
        phid[:, FEET] = self.feet_d1
        phidd[:, FEET] = self.feet_d2
        dyn = self.dyn.forward(phi, phid, torque, s.base, s.case, derivatives=derivatives)
        res = phidd - dyn.acc
        y, dy = self.chain.closure(phi, s.base)
        slip, dsq, dsv = self.chain.slip_velocity(phi, phid, s.base)
        m = self.switch_mask
        slip, dsq, dsv = slip * m, dsq * m[:, None], dsv * m[:, None]
        step, dstep = self.chain.step_length(phi, s.base)
        step = (step - self.step_target) * self.end_mask
        dstep = dstep * self.end_mask[:, None]
        c = self.config
        ev = Evaluation(phi=phi, phid=phid, phidd=phidd, torque=np.array(torque, float),
                        dyn=dyn, residual=res, y=y, dy=dy, slip=slip, dslip_dphi=dsq,
                        dslip_dphid=dsv, step=step, dstep_dphi=dstep,
                        J_m=float(c.weight_acc * np.sum(res ** 2)),
                        J_r=float(c.weight_closure * np.sum(y ** 2)
                                  + c.weight_slip * np.sum(slip ** 2)
                                  + c.weight_step * np.sum(step ** 2)))
        e = self._penalty_residuals(ev)
        ev.penalty = float(np.sum(e ** 2)) + self.w_rate * float(
            np.sum((self.rate_matrix @ ev.torque) ** 2))
        return ev

    def _penalty_residuals(self, ev: Evaluation) -> np.ndarray:
        """(n, 16) weighted violations: 3 forces, 6 joint angles, 6 torques, friction."""
        c = self.config
        ch = self.chain
        ft = self.f_target
        grf = np.where(ev.dyn.grf_active, np.maximum(ft - ev.dyn.grf, 0.0), 0.0)
        q = ev.phi @ self.A_joint.T
        lo, hi = ch.q_lower + c.angle_margin, ch.q_upper - c.angle_margin
        ang = np.maximum(q - hi, 0.0) + np.maximum(lo - q, 0.0)
        um = ch.effort * (1.0 - c.torque_margin)
        tq = np.maximum(np.abs(ev.torque) - um, 0.0)
        lam = ev.dyn.lam
        fr = np.maximum(np.abs(lam[:, 0]) - c.friction * lam[:, 1]
                        + self.f_margin * c.friction, 0.0)
        return np.concatenate([self.s_grf * grf, np.sqrt(c.weight_angle) * ang,
                               self.s_torque * tq, self.s_friction * fr[:, None]], axis=1)

    def residual_blocks(self, ev: Evaluation):
        """All residuals (n, 24) and their derivatives w.r.t. link angles (Eq), rates (Ev),
        trajectory accelerations (Ea) (n, 24, 7) and torques (Eu) (n, 24, 6).

        The objective is the sum of squares; J_m and J_r are the first 9 rows.
        """
        c = self.config
        ch = self.chain
        d = ev.dyn
        # evaluate() computes the derivatives by default, and the optimizer never turns them off
        assert d.dlam_dphi is not None and d.dlam_dphid is not None and d.dlam_du is not None
        n = self.n
        e = np.zeros((n, _M))
        Eq = np.zeros((n, _M, 7))
        Ev = np.zeros((n, _M, 7))
        Ea = np.zeros((n, _M, 7))
        Eu = np.zeros((n, _M, 6))
        sw = np.sqrt(c.weight_acc)
        a = _ROWS["acc"]
        e[:, a] = sw * ev.residual
        Eq[:, a] = -sw * d.dacc_dphi
        Ev[:, a] = -sw * d.dacc_dphid
        Ea[:, a] = sw * np.eye(7)[None]
        Eu[:, a] = -sw * d.dacc_du
        sy = np.sqrt(c.weight_closure)
        e[:, 7] = sy * ev.y
        Eq[:, 7] = sy * ev.dy
        sv = np.sqrt(c.weight_slip)
        e[:, 8] = sv * ev.slip
        Eq[:, 8] = sv * ev.dslip_dphi
        Ev[:, 8] = sv * ev.dslip_dphid
        # forces: rows active where a contact force is below its target
        ft = self.f_target
        low = d.grf_active & (d.grf < ft)
        sf = self.s_grf * low
        g = _ROWS["grf"]
        e[:, g] = sf * (ft - d.grf)
        Eq[:, g] = -sf[..., None] * d.dgrf_dphi
        Ev[:, g] = -sf[..., None] * d.dgrf_dphid
        Eu[:, g] = -sf[..., None] * d.dgrf_du
        # joint angles
        q = ev.phi @ self.A_joint.T
        lo, hi = ch.q_lower + c.angle_margin, ch.q_upper - c.angle_margin
        sa = np.sqrt(c.weight_angle)
        up, dn = q > hi, q < lo
        sign = sa * (up.astype(float) - dn.astype(float))           # (n, 6)
        r = _ROWS["angle"]
        e[:, r] = sa * (np.maximum(q - hi, 0.0) + np.maximum(lo - q, 0.0))
        Eq[:, r] = sign[..., None] * self.A_joint[None]
        # torques
        um = ch.effort * (1.0 - c.torque_margin)
        st = self.s_torque
        tsign = st * (np.sign(ev.torque) * (np.abs(ev.torque) > um))
        t = _ROWS["torque"]
        e[:, t] = st * np.maximum(np.abs(ev.torque) - um, 0.0)
        Eu[:, t] = tsign[..., None] * np.eye(6)[None]
        # friction cone of the base pad: |fx| <= mu fz (with a margin)
        lam = d.lam
        viol = np.abs(lam[:, 0]) - c.friction * lam[:, 1] + self.f_margin * c.friction
        act = self.s_friction * (viol > 0)
        coef = np.stack([np.sign(lam[:, 0]), -c.friction * np.ones(n)], axis=1)  # d/d(fx, fz)
        e[:, 24] = act * np.maximum(viol, 0.0)
        Eq[:, 24] = act[:, None] * np.einsum("tc,tcj->tj", coef, d.dlam_dphi[:, :2])
        Ev[:, 24] = act[:, None] * np.einsum("tc,tcj->tj", coef, d.dlam_dphid[:, :2])
        Eu[:, 24] = act[:, None] * np.einsum("tc,tcj->tj", coef, d.dlam_du[:, :2])
        ss = np.sqrt(c.weight_step)
        e[:, 25] = ss * ev.step
        Eq[:, 25] = ss * ev.dstep_dphi
        return e, Eq, Ev, Ea, Eu

    def jacobian(self, Eq, Ev, Ea) -> np.ndarray:
        """(n, 24, nb, r) derivatives of the residuals w.r.t. the parameters (eq. 13 through
        F1 and F2, eq. 28, then the band-limited basis)."""
        Q = self.basis_matrix
        mid = self.mid
        T = self.fourier
        return (np.einsum("kb,kia->kiba", T, Eq[..., mid] @ Q)
                + np.einsum("kb,kia->kiba", self.F1T, Ev[..., mid] @ Q)
                + np.einsum("kb,kia->kiba", self.F2T, Ea[..., mid] @ Q))

    def full_jacobian(self, ev: Evaluation):
        """Residuals (n*24,) and their Jacobian w.r.t. all parameters (n*24, P_theta + P_u):
        trajectory parameters first (harmonic-major), then torque parameters."""
        e, Eq, Ev, Ea, Eu = self.residual_blocks(ev)
        Jt = self.jacobian(Eq, Ev, Ea)                          # (n, M, nb, r)
        Ju = np.einsum("kb,kiu->kibu", self.fourier_u, Eu)       # (n, M, nbu, 6)
        n = self.n
        J = np.concatenate([Jt.reshape(n * _M, -1), Ju.reshape(n * _M, -1)], axis=1)
        e = e.reshape(-1)
        if self.w_rate > 0:
            # smooth torques inside each contact phase: rows sqrt(w) (u_k+1 - u_k)
            sw = np.sqrt(self.w_rate)
            Dt = self.rate_matrix @ self.fourier_u                # (n, nbu)
            rows = sw * np.einsum("kb,uv->kubv", Dt, np.eye(6)).reshape(n * 6, -1)
            Jrate = np.concatenate([np.zeros((n * 6, Jt.shape[2] * Jt.shape[3])), rows],
                                   axis=1)
            J = np.concatenate([J, Jrate], axis=0)
            e = np.concatenate([e, sw * (self.rate_matrix @ ev.torque).reshape(-1)])
        return e, J

    def normal_equations(self, ev: Evaluation) -> tuple[np.ndarray, np.ndarray, float]:
        """Gauss-Newton matrix J^T J, gradient J^T e and objective e^T e, built block by block
        (the torque block is block-diagonal plus the torque-rate coupling) instead of from the
        dense Jacobian."""
        if self.config.torque_harmonics is not None:
            e, J = self.full_jacobian(ev)
            return J.T @ J, J.T @ e, float(e @ e)
        e, Eq, Ev, Ea, Eu = self.residual_blocks(ev)
        n = self.n
        Jt = self.jacobian(Eq, Ev, Ea).reshape(n, _M, -1)         # (n, M, Pt)
        Pt = Jt.shape[2]
        J2 = Jt.reshape(n * _M, Pt)
        Htt = J2.T @ J2
        gt = J2.T @ e.reshape(-1)
        Htu = np.einsum("kip,kiu->pku", Jt, Eu).reshape(Pt, n * 6)
        Huu: np.ndarray = np.zeros((n, 6, n, 6))          # reshaped to (n 6, n 6) below
        Huu[np.arange(n), :, np.arange(n), :] = np.einsum("kiu,kiv->kuv", Eu, Eu)
        gu = np.einsum("kiu,ki->ku", Eu, e).reshape(-1)
        obj = float(np.sum(e ** 2))
        w = self.w_rate
        if w > 0:
            D = self.rate_matrix
            Huu += w * np.einsum("kl,uv->kulv", D.T @ D, np.eye(6))
            r = D @ ev.torque
            gu += w * (D.T @ r).reshape(-1)
            obj += w * float(np.sum(r ** 2))
        Huu = Huu.reshape(n * 6, n * 6)
        H = np.block([[Htt, Htu], [Htu.T, Huu]])
        return H, np.concatenate([gt, gu]), obj

    def gradient(self, ev: Evaluation) -> tuple[np.ndarray, np.ndarray]:
        """Gradient of the objective w.r.t. the trajectory parameters (r, nb) (eqs 13, 28) and
        the torque parameters (6, nbu)."""
        e, J = self.full_jacobian(ev)
        g = 2.0 * J.T @ e
        return self._split(g)

    def _split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        nb, r = self.fourier.shape[1], self.basis_matrix.shape[1]
        pt = x[: nb * r].reshape(nb, r).T
        pu = x[nb * r:].reshape(self.fourier_u.shape[1], 6).T
        return pt, pu

    def to_torque_params(self, torque: np.ndarray) -> np.ndarray:
        """(6, nbu) band-limited torque parameters of (n, 6) torques."""
        return torque.T @ self.fourier_u

    def to_torque(self, params_u: np.ndarray) -> np.ndarray:
        return (params_u @ self.fourier_u.T).T

    # --- stage II ---------------------------------------------------------------------------

    def stage2(self, phi: np.ndarray, torque: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Angle and torque limits by the projection updates (eqs 8-11)."""
        c = self.config
        ch = self.chain
        phi = phi.copy()
        q = phi @ self.A_joint.T
        lo, hi = ch.q_lower + 0.5 * c.angle_margin, ch.q_upper - 0.5 * c.angle_margin
        dq = np.where(q > hi, -c.k_theta * (q - hi), 0.0) + \
            np.where(q < lo, -c.k_theta * (q - lo), 0.0)
        if np.any(dq):
            # the smallest change of the non-foot angles that moves the joints by dq
            phi[:, self.mid] += dq @ self.A_mid_pinv.T
        um = ch.effort * (1.0 - 0.5 * c.torque_margin)
        torque = torque - c.k_u * (np.maximum(torque - um, 0.0) - np.maximum(-um - torque, 0.0))
        return phi, torque

    # --- evidence ---------------------------------------------------------------------------

    def violations(self, ev: Evaluation) -> tuple[int, int, float]:
        """(angle violations, torque violations, min active vertical force) over all samples."""
        q = ev.phi @ self.A_joint.T
        ang = int(np.sum((q < self.chain.q_lower - 1e-9) | (q > self.chain.q_upper + 1e-9)))
        tq = int(np.sum(np.abs(ev.torque) > self.chain.effort + 1e-9))
        grf = np.where(ev.dyn.grf_active, ev.dyn.grf, np.inf).min()
        return ang, tq, float(grf)

    def _record(self, it: int, ev: Evaluation, t0: float, step: float) -> IterationRecord:
        ang, tq, grf = self.violations(ev)
        return IterationRecord(iteration=it, J_m=ev.J_m, J_r=ev.J_r, E=ev.E,
                               penalty=ev.penalty,
                               closure_max_mm=float(1e3 * np.max(np.abs(ev.y))),
                               slip_max_m_s=float(np.max(np.abs(ev.slip))),
                               min_grf_N=grf, angle_violations=ang, torque_violations=tq,
                               seconds=time.perf_counter() - t0, step=step)

    def _done(self, ev: Evaluation, J_m0: float) -> bool:
        c = self.config
        ang, tq, grf = self.violations(ev)
        return (ev.J_m <= c.jm_target_ratio * J_m0 and np.max(np.abs(ev.y)) <= c.closure_tol_m
                and np.max(np.abs(ev.slip)) <= c.slip_tol_m_s
                and ang == 0 and tq == 0 and grf >= self.f_min)

    # --- the solvers ------------------------------------------------------------------------

    def initial(self) -> Evaluation:
        """The initial motion with the torques that best fit it (least squares of J_m, frame by
        frame): J_m of the motion itself, not of arbitrary torques."""
        ev = self.evaluate(self.phi0, np.zeros((self.n, 6)))
        assert ev.dyn.dacc_du is not None          # evaluate() computes the derivatives
        torque = ev.torque + np.stack([np.linalg.lstsq(P, r, rcond=1e-10)[0] for P, r in
                                       zip(ev.dyn.dacc_du, ev.residual, strict=True)])
        return self.evaluate(self.phi0, torque)

    def run(self, progress: Callable[[IterationRecord], None] | None = None
            ) -> OptimizationResult:
        """Alternate stages (I) and (II) until the stopping tests hold or the budget is spent."""
        t0 = time.perf_counter()
        c = self.config
        init = self.initial()
        J_m0 = max(init.J_m, 1e-12)
        params = self.to_params(init.phi)
        pu = self.to_torque_params(init.torque)
        ev = self.evaluate(self.to_phi(params), self.to_torque(pu))
        history = [self._record(0, ev, t0, 0.0)]
        if progress:
            progress(history[-1])
        mu, step = 1e-3, 1.0
        best, stall = ev.objective, 0
        converged = False
        for it in range(1, c.max_iterations + 1):
            # stage (I)
            if c.method == "gauss-newton":
                params, pu, ev, mu = self._lm_step(params, pu, ev, mu)
                step = mu
            else:
                params, pu, ev, step = self._gradient_step(params, pu, ev, step)
            # stage (II)
            n_ang = n_tq = 0
            if c.stage2:
                phi2, torque2 = self.stage2(ev.phi, ev.torque)
                n_ang = int(np.sum(np.any(phi2 != ev.phi, axis=1)))
                n_tq = int(np.sum(torque2 != ev.torque))
                if n_ang or n_tq:
                    params = self.to_params(phi2)
                    pu = self.to_torque_params(torque2)
                    ev = self.evaluate(self.to_phi(params), self.to_torque(pu))
            history.append(self._record(it, ev, t0, step))
            history[-1].projected_angles, history[-1].projected_torques = n_ang, n_tq
            if progress:
                progress(history[-1])
            if self._done(ev, J_m0):
                converged = True
                break
            if ev.objective < best * (1 - 1e-4):
                best, stall = ev.objective, 0
            else:
                stall += 1
                if stall >= c.patience:
                    break
        return OptimizationResult(phi=ev.phi, phid=ev.phid, phidd=ev.phidd, torque=ev.torque,
                                  initial=init, final=ev, history=history, basis=self.basis,
                                  seconds=time.perf_counter() - t0, converged=converged,
                                  config=c)

    def _gradient_step(self, params, pu, ev: Evaluation, step: float):
        """The paper's gradient step (eqs 13, 28-29; the same for U) on all parameters, each
        divided by its diagonal Gauss-Newton curvature (Jacobi scaling: the acceleration term
        weighs harmonic k like k^4, so unscaled steepest descent stalls), Armijo step size."""
        H, g, _ = self.normal_equations(ev)
        g = 2.0 * g
        diag = 2.0 * np.diag(H)
        d = -g / np.maximum(diag, 1e-12 * diag.max())
        gd = float(g @ d)
        if gd >= 0:
            return params, pu, ev, step
        step = step * 2.0
        dt_, du = self._split(d)
        for _ in range(60):
            trial, trial_u = params + step * dt_, pu + step * du
            ev_t = self.evaluate(self.to_phi(trial), self.to_torque(trial_u))
            if ev_t.objective <= ev.objective + 1e-4 * step * gd:
                return trial, trial_u, ev_t, step
            step *= 0.5
        return params, pu, ev, step

    def _lm_step(self, params, pu, ev: Evaluation, mu: float):
        """One Levenberg-Marquardt step on (trajectory parameters, torque parameters)."""
        H, g, _ = self.normal_equations(ev)
        dH = np.diag(H)
        scale = np.maximum(dH, 1e-9 * max(dH.max(), 1e-12))
        for _ in range(12):
            try:
                d = np.linalg.solve(H + mu * np.diag(scale), -g)
            except np.linalg.LinAlgError:
                mu *= 10.0
                continue
            dt_, du = self._split(d)
            trial, trial_u = params + dt_, pu + du
            ev_t = self.evaluate(self.to_phi(trial), self.to_torque(trial_u))
            if ev_t.objective < ev.objective:
                return trial, trial_u, ev_t, max(mu / 3.0, 1e-9)
            mu *= 8.0
        return params, pu, ev, mu
