"""Derivatives of the residuals with respect to the design parameters (eq. 13 through F1 and
F2, eq. 28, then the band-limited basis): the Jacobian, the Gauss-Newton normal equations and
the gradient that stage (I) steps along."""

from __future__ import annotations

import numpy as np

from .objective import N_RESIDUALS, Evaluation, Objective
from .parametrization import Parametrization


class Linearization(Parametrization, Objective):
    """Jacobian, normal equations and gradient of the objective, a part of
    :class:`~imesh.reduction.optimize.MotionOptimizer`.

    Attributes:
        F1T, F2T: (n, nb) the derivative matrices applied to the trajectory basis.
    """

    F1T: np.ndarray
    F2T: np.ndarray

    def jacobian(self, Eq, Ev, Ea) -> np.ndarray:
        """(n, 26, nb, r) derivatives of the residuals w.r.t. the parameters (eq. 13 through
        F1 and F2, eq. 28, then the band-limited basis)."""
        Q = self.basis_matrix
        mid = self.mid
        T = self.fourier
        return (np.einsum("kb,kia->kiba", T, Eq[..., mid] @ Q)
                + np.einsum("kb,kia->kiba", self.F1T, Ev[..., mid] @ Q)
                + np.einsum("kb,kia->kiba", self.F2T, Ea[..., mid] @ Q))

    def full_jacobian(self, ev: Evaluation):
        """Residuals (n*26,) and their Jacobian w.r.t. all parameters (n*26, P_theta + P_u):
        trajectory parameters first (harmonic-major), then torque parameters."""
        e, Eq, Ev, Ea, Eu = self.residual_blocks(ev)
        Jt = self.jacobian(Eq, Ev, Ea)                          # (n, M, nb, r)
        Ju = np.einsum("kb,kiu->kibu", self.fourier_u, Eu)       # (n, M, nbu, 6)
        n = self.n
        J = np.concatenate([Jt.reshape(n * N_RESIDUALS, -1), Ju.reshape(n * N_RESIDUALS, -1)],
                           axis=1)
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
        if self.config.subspace.torque_harmonics is not None:
            e, J = self.full_jacobian(ev)
            return J.T @ J, J.T @ e, float(e @ e)
        e, Eq, Ev, Ea, Eu = self.residual_blocks(ev)
        n = self.n
        Jt = self.jacobian(Eq, Ev, Ea).reshape(n, N_RESIDUALS, -1)         # (n, M, Pt)
        Pt = Jt.shape[2]
        J2 = Jt.reshape(n * N_RESIDUALS, Pt)
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
        return self.split(g)
