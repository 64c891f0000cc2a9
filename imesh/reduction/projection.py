"""Stage (II) of each iteration: angles and torques still past their limits are pulled back by
the projection updates (eqs 8-11); the angle limits are on the robot's joint angles, moved with
the smallest change of the non-foot angles."""

from __future__ import annotations

import numpy as np

from .chain import PlanarChain
from .config import ReductionConfig


class Projection:
    """The projections of eqs 8-11, a part of :class:`~imesh.reduction.optimize.MotionOptimizer`.

    Attributes:
        chain, config: robot chain and settings.
        A_joint: (6, 7) joint angles from link angles.
        A_mid_pinv: (5, 6) pseudo-inverse of its non-foot columns.
        mid: indices of the five non-foot link angles.
    """

    chain: PlanarChain
    config: ReductionConfig
    A_joint: np.ndarray
    A_mid_pinv: np.ndarray
    mid: list[int]

    def stage2(self, phi: np.ndarray, torque: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Angle and torque limits by the projection updates (eqs 8-11)."""
        lim = self.config.limits
        ch = self.chain
        phi = phi.copy()
        q = phi @ self.A_joint.T
        lo, hi = ch.q_lower + 0.5 * lim.angle_margin, ch.q_upper - 0.5 * lim.angle_margin
        dq = np.where(q > hi, -lim.k_theta * (q - hi), 0.0) + \
            np.where(q < lo, -lim.k_theta * (q - lo), 0.0)
        if np.any(dq):
            # the smallest change of the non-foot angles that moves the joints by dq
            phi[:, self.mid] += dq @ self.A_mid_pinv.T
        um = ch.effort * (1.0 - 0.5 * lim.torque_margin)
        torque = torque - lim.k_u * (np.maximum(torque - um, 0.0) - np.maximum(-um - torque, 0.0))
        return phi, torque
