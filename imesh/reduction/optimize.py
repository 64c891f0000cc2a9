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

This module holds the iterations (:class:`MotionOptimizer`); the settings are in
:mod:`~imesh.reduction.config`, the parameters and their restoration in
:mod:`~imesh.reduction.parametrization`, E and its residuals in :mod:`~imesh.reduction.objective`,
their derivatives in :mod:`~imesh.reduction.linearization`, stage (II) in
:mod:`~imesh.reduction.projection` and the records in :mod:`~imesh.reduction.result`.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

import numpy as np

from ..errors import OptionError
from .chain import FEET, MID, PlanarChain, joint_matrix
from .config import REFERENCE_LEG, REFERENCE_MASS, ReductionConfig
from .contact import ContactSchedule
from .diff import derivative_matrices
from .dynamics import ChainDynamics
from .linearization import Linearization
from .objective import Evaluation
from .parametrization import fourier_basis
from .pca import pca_basis
from .projection import Projection
from .result import IterationRecord, OptimizationResult

log = logging.getLogger(__name__)


class MotionOptimizer(Linearization, Projection):
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
        self.F1, self.F2 = derivative_matrices(n, self.dt, c.subspace.cutoff_hz)
        phi0 = np.array(phi0, float)
        phi0[:, FEET[0]] = schedule.feet[:, 0]
        phi0[:, FEET[1]] = schedule.feet[:, 1]
        self.phi0 = phi0
        self.feet_d1 = schedule.feet_d1 / self.dt
        self.feet_d2 = schedule.feet_d2 / self.dt ** 2
        self.mid = list(MID)
        self.basis = (pca_basis(phi0[:, self.mid].T, c.subspace.rank, c.subspace.center)
                      if c.subspace.rank is not None else None)
        self.fourier = fourier_basis(n, c.subspace.harmonics)
        self.fourier_u = fourier_basis(n, c.subspace.torque_harmonics)
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
        self.f_min = c.ground.f_min * self.force_scale
        self.f_margin = c.ground.margin * self.force_scale
        self.f_target = self.f_min + self.f_margin
        self.s_grf = np.sqrt(c.ground.weight) / self.force_scale
        self.s_friction = np.sqrt(c.ground.friction_weight) / self.force_scale
        self.s_torque = np.sqrt(c.limits.weight_torque) / self.torque_scale
        self.w_rate = c.weights.torque_rate / self.torque_scale ** 2

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
        s = self.config.solver
        ang, tq, grf = self.violations(ev)
        return (ev.J_m <= s.jm_target_ratio * J_m0 and np.max(np.abs(ev.y)) <= s.closure_tol_m
                and np.max(np.abs(ev.slip)) <= s.slip_tol_m_s
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
        for it in range(1, c.solver.max_iterations + 1):
            # stage (I)
            if c.solver.method == "gauss-newton":
                params, pu, ev, mu = self._lm_step(params, pu, ev, mu)
                step = mu
            else:
                params, pu, ev, step = self._gradient_step(params, pu, ev, step)
            # stage (II)
            n_ang = n_tq = 0
            if c.limits.project:
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
                if stall >= c.solver.patience:
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
        dt_, du = self.split(d)
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
            dt_, du = self.split(d)
            trial, trial_u = params + dt_, pu + du
            ev_t = self.evaluate(self.to_phi(trial), self.to_torque(trial_u))
            if ev_t.objective < ev.objective:
                return trial, trial_u, ev_t, max(mu / 3.0, 1e-9)
            mu *= 8.0
        return params, pu, ev, mu
