"""One frame's optimization problem of Kim, Kim & Oh 2005 (eqs 1-6) and its analytic gradient
(eqs 16-18), for one arm.

Variables: the increments ``dtheta = theta_i - theta_{i-1}`` of the arm joints (eq. 1). Objective:

    f(dtheta) = E_hand^T W E_hand + W_10 ||s_elbow||^2 + damping^2 |dtheta|^2        (eq. 2)

with ``E_hand`` the stacked wrist, hand and thumb errors ``r^ac - r^hr`` (eq. 3) and

    ||s_elbow||^2 = r^T r - (a_hat^T r)^2,   r = r_el^hr - r_sh^hr,  a_hat = unit(r_el/sh^ac)

the squared component of the robot's upper arm perpendicular to the actor's (eqs 4-6). Eq. 4 as
printed has the two terms the other way round (a non-positive number whose minimization would
*maximize* the misalignment); eq. 18 is corrected accordingly:

    d||s||^2/d dtheta = 2 J_r^T r - 2 (a_hat^T r) J_r^T a_hat,   J_r = J_el - J_sh.

The same objective is a sum of squares ``|R(dtheta)|^2`` with
``R = [sqrt(W) E_hand; sqrt(W_10) P r; damping dtheta]`` and ``P = I - a_hat a_hat^T``
(``|P r|^2 = ||s||^2``), which the Gauss-Newton solver uses; ``2 J_R^T R`` equals eq. 16.
"""

from __future__ import annotations

import numpy as np

from .geometry import ArmModel


class FrameObjective:
    """f of eq. 2 for one arm in one frame, as a function of the joint increments.

    Args:
        arm: the robot arm.
        q_prev: (nq,) float configuration of the previous frame (the arm joints at
            ``theta_{i-1}``; base, torso and the other arm at this frame's reference).
        targets_m: (3, 3) float [m] wrist, hand and thumb targets.
        weights: (3,) float W per hand point.
        upper_arm_dir: (3,) float unit actor upper-arm direction.
        upper_arm_weight: W_10.
        damping: [m/rad] weight of the increment residual.
    """

    def __init__(self, arm: ArmModel, q_prev: np.ndarray, targets_m: np.ndarray,
                 weights: np.ndarray, upper_arm_dir: np.ndarray, upper_arm_weight: float,
                 damping: float):
        self.arm = arm
        self.q_prev = np.array(q_prev, dtype=np.float64)
        self.columns = 7 + arm.joint_index
        self.theta_prev = self.q_prev[self.columns].copy()
        self.targets = np.asarray(targets_m, dtype=np.float64)
        self.weights = np.asarray(weights, dtype=np.float64)
        self.sqrt_w = np.repeat(np.sqrt(self.weights), 3)
        self.a_hat = np.asarray(upper_arm_dir, dtype=np.float64)
        self.w10 = float(upper_arm_weight)
        self.sqrt_w10 = np.sqrt(self.w10)
        self.projector = np.eye(3) - np.outer(self.a_hat, self.a_hat)
        self.damping = float(damping)
        self.evaluations = 0

    @property
    def n(self) -> int:
        return self.arm.n

    def configuration(self, dtheta: np.ndarray) -> np.ndarray:
        """(nq,) the full configuration with ``theta = theta_{i-1} + dtheta`` (eq. 8)."""
        q = self.q_prev.copy()
        q[self.columns] = self.theta_prev + dtheta
        return q

    # --- the paper's form ----------------------------------------------------------------------
    def terms(self, dtheta: np.ndarray) -> tuple[np.ndarray, float]:
        """(E_hand (3, 3) [m], ||s_elbow||^2 [m^2]) at ``dtheta`` (eqs 3, 4)."""
        p = self.arm.points(self.configuration(dtheta))
        self.evaluations += 1
        r = p[3] - p[4]
        return self.targets - p[:3], float(r @ r - (self.a_hat @ r) ** 2)

    def value(self, dtheta: np.ndarray) -> float:
        """f(dtheta) of eq. 2."""
        e, s2 = self.terms(dtheta)
        return float(np.sum(self.weights * np.sum(e * e, axis=1)) + self.w10 * s2
                     + self.damping ** 2 * float(dtheta @ dtheta))

    def value_and_gradient(self, dtheta: np.ndarray) -> tuple[float, np.ndarray]:
        """f and its analytic gradient (eqs 16-18) from the point Jacobians.

        Returns:
            (f, (n,) df/d dtheta).
        """
        p, jac = self.arm.points_and_jacobians(self.configuration(dtheta))
        self.evaluations += 1
        e = self.targets - p[:3]                                      # eq. 3
        de = -jac[:3]                                                 # eq. 17, (3, 3, n)
        r = p[3] - p[4]                                               # eq. 6
        jr = jac[3] - jac[4]
        ar = float(self.a_hat @ r)
        s2 = float(r @ r) - ar * ar                                   # eq. 4 (corrected)
        ds2 = 2.0 * (jr.T @ r) - 2.0 * ar * (jr.T @ self.a_hat)       # eq. 18 (corrected)
        f = (float(np.sum(self.weights * np.sum(e * e, axis=1))) + self.w10 * s2
             + self.damping ** 2 * float(dtheta @ dtheta))
        grad = (2.0 * np.einsum("k,kcn,kc->n", self.weights, de, e) + self.w10 * ds2
                + 2.0 * self.damping ** 2 * dtheta)                   # eq. 16
        return f, grad

    # --- the least-squares form ----------------------------------------------------------------
    def residuals(self, dtheta: np.ndarray) -> np.ndarray:
        """(9 + 3 + n,) R with ``|R|^2 = f``."""
        p = self.arm.points(self.configuration(dtheta))
        self.evaluations += 1
        return self._stack(p, dtheta)

    def _stack(self, p: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        return np.concatenate([self.sqrt_w * (self.targets - p[:3]).reshape(-1),
                               self.sqrt_w10 * (self.projector @ (p[3] - p[4])),
                               self.damping * dtheta])

    def residuals_and_jacobian(self, dtheta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """R and its Jacobian (9 + 3 + n, n)."""
        p, jac = self.arm.points_and_jacobians(self.configuration(dtheta))
        self.evaluations += 1
        n = self.n
        rows = np.concatenate([-self.sqrt_w[:, None] * jac[:3].reshape(9, n),
                               self.sqrt_w10 * (self.projector @ (jac[3] - jac[4])),
                               self.damping * np.eye(n)])
        return self._stack(p, dtheta), rows

    def upper_arm_error_deg(self, dtheta: np.ndarray) -> float:
        """Angle between the robot's and the actor's upper arm [deg]."""
        p = self.arm.points(self.configuration(dtheta))
        r = p[3] - p[4]
        c = float(self.a_hat @ r) / max(float(np.linalg.norm(r)), 1e-12)
        return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
