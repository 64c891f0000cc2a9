"""Velocities and accelerations of a robot motion, for the ZMP and the dynamics metrics.

They follow pinocchio's convention (``v = [base linear velocity in the base frame, base angular
velocity in the base frame, joint rates]``, ``a = dv/dt``) and are computed by central
differences at the motion's frame rate (numpy and scipy only), so a plain
:class:`~imesh.core.robot_motion.RobotMotion` from any retargeting tool is scored on the same
terms.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def motion_derivatives(q: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """Velocities and accelerations of a configuration trajectory (pinocchio convention).

    Central differences inside, one-sided at the ends. The base twist is expressed in the base
    frame: linear ``R_t^T (p_{t+1} - p_{t-1}) / 2h``, angular ``log(R_{t-1}^T R_{t+1}) / 2h``
    (both base-frame quantities at frame t to second order).

    Args:
        q: (T, nq) float configurations ``[x, y, z, qx, qy, qz, qw, joints...]``.
        fps: frame rate [1/s].

    Returns:
        (v, a): (T, nv) float velocities and (T, nv) float accelerations, nv = nq - 1.
    """
    q = np.asarray(q, dtype=float)
    T = len(q)
    h = 1.0 / fps
    v = np.zeros((T, q.shape[1] - 1))
    if T < 2:
        return v, np.zeros_like(v)
    rot = Rotation.from_quat(q[:, 3:7])  # scipy order x, y, z, w: as pinocchio
    prev = np.r_[0, np.arange(T - 1)]
    nxt = np.r_[np.arange(1, T), T - 1]
    span = (nxt - prev) * h
    R = rot.as_matrix()
    dp = (q[nxt, :3] - q[prev, :3]) / span[:, None]
    v[:, :3] = np.einsum("tji,tj->ti", R, dp)  # R^T dp
    v[:, 3:6] = (rot[prev].inv() * rot[nxt]).as_rotvec() / span[:, None]
    v[:, 6:] = np.gradient(q[:, 7:], h, axis=0)
    a = np.gradient(v, h, axis=0)
    return v, a
