"""The evaluation function of the optimization and its residuals (eqs 4-13, 31-34).

``E = J_r + J_m`` (eq. 12): ``J_m`` (eq. 4) compares the trajectory's accelerations
``Theta F2`` with those the torques produce through the constrained dynamics (eq. 5,
:class:`~imesh.reduction.dynamics.ChainDynamics`); ``J_r`` is the loop closure ``y_m`` (eq. 31)
plus the two motion conditions walking needs (the sliding foot stops when it becomes the base;
the human's step length). The ground-force condition (eq. 32, with the base pad's friction cone)
and the angle and torque limits enter as squared violations whose gradients are the directions
of eqs 33-34 and 8-11.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .chain import FEET, PlanarChain
from .config import ReductionConfig
from .contact import ContactSchedule
from .dynamics import ChainDynamics, DynamicsResult


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


#: residual rows per frame (N_RESIDUALS = 26): 7 accelerations, closure, slip, 3 forces, 6 angles,
#: 6 torques, friction, step length
RESIDUAL_ROWS: dict[str, slice | int] = {
    "acc": slice(0, 7), "closure": 7, "slip": 8, "grf": slice(9, 12), "angle": slice(12, 18),
    "torque": slice(18, 24), "friction": 24, "step": 25}
N_RESIDUALS = 26


class Objective:
    """Evaluation (eq. 12) and residuals (eqs 4, 31-34, 8-11) of one (Theta, U), a part of
    :class:`~imesh.reduction.optimize.MotionOptimizer`.

    Attributes:
        chain, schedule, config, dyn, n: the problem (robot chain, contacts, settings,
            dynamics, samples).
        F1, F2: (n, n) circulant derivative matrices (eqs 14-22).
        feet_d1, feet_d2: exact rates and accelerations of the scheduled foot angles.
        switch_mask: samples around a change of base foot (the slip condition).
        end_mask, step_target: last sample of each base phase and the human step length.
        A_joint: (6, 7) joint angles from link angles.
        f_target, f_margin: [N] target and margin of the ground forces.
        s_grf, s_friction, s_torque, w_rate: weights scaled to the robot.
        rate_matrix: (n, n) torque change inside a contact phase.
    """

    chain: PlanarChain
    schedule: ContactSchedule
    config: ReductionConfig
    dyn: ChainDynamics
    n: int
    F1: np.ndarray
    F2: np.ndarray
    feet_d1: np.ndarray
    feet_d2: np.ndarray
    switch_mask: np.ndarray
    end_mask: np.ndarray
    step_target: np.ndarray
    A_joint: np.ndarray
    f_target: float
    f_margin: float
    s_grf: np.floating
    s_friction: np.floating
    s_torque: np.floating
    w_rate: float
    rate_matrix: np.ndarray

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
                        J_m=float(c.weights.acc * np.sum(res ** 2)),
                        J_r=float(c.weights.closure * np.sum(y ** 2)
                                  + c.weights.slip * np.sum(slip ** 2)
                                  + c.weights.step * np.sum(step ** 2)))
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
        lo, hi = ch.q_lower + c.limits.angle_margin, ch.q_upper - c.limits.angle_margin
        ang = np.maximum(q - hi, 0.0) + np.maximum(lo - q, 0.0)
        um = ch.effort * (1.0 - c.limits.torque_margin)
        tq = np.maximum(np.abs(ev.torque) - um, 0.0)
        lam = ev.dyn.lam
        fr = np.maximum(np.abs(lam[:, 0]) - c.ground.friction * lam[:, 1]
                        + self.f_margin * c.ground.friction, 0.0)
        return np.concatenate([self.s_grf * grf, np.sqrt(c.limits.weight_angle) * ang,
                               self.s_torque * tq, self.s_friction * fr[:, None]], axis=1)

    def residual_blocks(self, ev: Evaluation):
        """All residuals (n, 26) and their derivatives w.r.t. link angles (Eq), rates (Ev),
        trajectory accelerations (Ea) (n, 26, 7) and torques (Eu) (n, 26, 6).

        The objective is the sum of squares; J_m and J_r are the first 9 rows.
        """
        c = self.config
        ch = self.chain
        d = ev.dyn
        # evaluate() computes the derivatives by default, and the optimizer never turns them off
        assert d.dlam_dphi is not None and d.dlam_dphid is not None and d.dlam_du is not None
        n = self.n
        e = np.zeros((n, N_RESIDUALS))
        Eq = np.zeros((n, N_RESIDUALS, 7))
        Ev = np.zeros((n, N_RESIDUALS, 7))
        Ea = np.zeros((n, N_RESIDUALS, 7))
        Eu = np.zeros((n, N_RESIDUALS, 6))
        sw = np.sqrt(c.weights.acc)
        a = RESIDUAL_ROWS["acc"]
        e[:, a] = sw * ev.residual
        Eq[:, a] = -sw * d.dacc_dphi
        Ev[:, a] = -sw * d.dacc_dphid
        Ea[:, a] = sw * np.eye(7)[None]
        Eu[:, a] = -sw * d.dacc_du
        sy = np.sqrt(c.weights.closure)
        e[:, 7] = sy * ev.y
        Eq[:, 7] = sy * ev.dy
        sv = np.sqrt(c.weights.slip)
        e[:, 8] = sv * ev.slip
        Eq[:, 8] = sv * ev.dslip_dphi
        Ev[:, 8] = sv * ev.dslip_dphid
        # forces: rows active where a contact force is below its target
        ft = self.f_target
        low = d.grf_active & (d.grf < ft)
        sf = self.s_grf * low
        g = RESIDUAL_ROWS["grf"]
        e[:, g] = sf * (ft - d.grf)
        Eq[:, g] = -sf[..., None] * d.dgrf_dphi
        Ev[:, g] = -sf[..., None] * d.dgrf_dphid
        Eu[:, g] = -sf[..., None] * d.dgrf_du
        # joint angles
        q = ev.phi @ self.A_joint.T
        lo, hi = ch.q_lower + c.limits.angle_margin, ch.q_upper - c.limits.angle_margin
        sa = np.sqrt(c.limits.weight_angle)
        up, dn = q > hi, q < lo
        sign = sa * (up.astype(float) - dn.astype(float))           # (n, 6)
        r = RESIDUAL_ROWS["angle"]
        e[:, r] = sa * (np.maximum(q - hi, 0.0) + np.maximum(lo - q, 0.0))
        Eq[:, r] = sign[..., None] * self.A_joint[None]
        # torques
        um = ch.effort * (1.0 - c.limits.torque_margin)
        st = self.s_torque
        tsign = st * (np.sign(ev.torque) * (np.abs(ev.torque) > um))
        t = RESIDUAL_ROWS["torque"]
        e[:, t] = st * np.maximum(np.abs(ev.torque) - um, 0.0)
        Eu[:, t] = tsign[..., None] * np.eye(6)[None]
        # friction cone of the base pad: |fx| <= mu fz (with a margin)
        lam = d.lam
        mu = c.ground.friction
        viol = np.abs(lam[:, 0]) - mu * lam[:, 1] + self.f_margin * mu
        act = self.s_friction * (viol > 0)
        coef = np.stack([np.sign(lam[:, 0]), -mu * np.ones(n)], axis=1)  # d/d(fx, fz)
        e[:, 24] = act * np.maximum(viol, 0.0)
        Eq[:, 24] = act[:, None] * np.einsum("tc,tcj->tj", coef, d.dlam_dphi[:, :2])
        Ev[:, 24] = act[:, None] * np.einsum("tc,tcj->tj", coef, d.dlam_dphid[:, :2])
        Eu[:, 24] = act[:, None] * np.einsum("tc,tcj->tj", coef, d.dlam_du[:, :2])
        ss = np.sqrt(c.weights.step)
        e[:, 25] = ss * ev.step
        Eq[:, 25] = ss * ev.dstep_dphi
        return e, Eq, Ev, Ea, Eu
