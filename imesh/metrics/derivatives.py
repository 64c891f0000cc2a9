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

from ..core.skew import skew


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


def _inverse_right_jacobian(phi: np.ndarray) -> np.ndarray:
    """(T, 3, 3) ``Jr^-1(phi)`` of SO(3): ``log(exp(phi) exp(d)) = phi + Jr^-1(phi) d + o(d)``."""
    theta = np.linalg.norm(phi, axis=-1)
    small = theta < 1e-6
    t = np.where(small, 1.0, theta)
    coeff = np.where(small, 1.0 / 12.0,
                     1.0 / t ** 2 - (1.0 + np.cos(t)) / (2.0 * t * np.sin(t)))
    K = skew(phi)
    return np.eye(3) + 0.5 * K + coeff[:, None, None] * (K @ K)


def velocity_jacobians(q: np.ndarray, fps: float) -> np.ndarray:
    """(T, 3, nv, nv) derivatives of :func:`motion_derivatives`' velocity ``v_t`` with respect to
    tangent perturbations ``dq_s`` (pinocchio's ``integrate``: base translation and rotation in
    the base frame) of the frames it differences: ``s = prev(t), t, next(t)`` (index 0, 1, 2;
    at the ends ``prev`` or ``next`` is ``t`` itself and the blocks add up).

    The base's rows carry its turn between the frames: ``v_lin = R_t^T (p_n - p_p) / span``
    moves with ``R_t^T R_n / span`` and ``-R_t^T R_p / span`` and, through ``R_t``, with
    ``[v_lin]x``; ``w = log(R_p^T R_n) / span`` with ``Jr^-1(phi) / span`` and
    ``-Jl^-1(phi) / span``. A spinning base turns 0.5 rad a frame (CMU 05_06's jete turns at
    30 fps), where taking these blocks as +-I / span misses a quarter of them.
    """
    q = np.asarray(q, dtype=float)
    T, nv = len(q), q.shape[1] - 1
    out = np.zeros((T, 3, nv, nv))
    if T < 2:
        return out
    h = 1.0 / fps
    prev = np.r_[0, np.arange(T - 1)]
    nxt = np.r_[np.arange(1, T), T - 1]
    span = (nxt - prev) * h
    rot = Rotation.from_quat(q[:, 3:7])
    R = rot.as_matrix()
    inv_span = (1.0 / span)[:, None, None]
    j = np.arange(6, nv)
    out[:, 0, j, j] = -1.0 / span[:, None]
    out[:, 2, j, j] = 1.0 / span[:, None]
    v_lin = np.einsum("tji,tj->ti", R, q[nxt, :3] - q[prev, :3]) / span[:, None]
    out[:, 0, :3, :3] = -np.einsum("tji,tjk->tik", R, R[prev]) * inv_span
    out[:, 2, :3, :3] = np.einsum("tji,tjk->tik", R, R[nxt]) * inv_span
    out[:, 1, :3, 3:6] = skew(v_lin)
    phi = (rot[prev].inv() * rot[nxt]).as_rotvec()
    out[:, 2, 3:6, 3:6] = _inverse_right_jacobian(phi) * inv_span
    out[:, 0, 3:6, 3:6] = -_inverse_right_jacobian(-phi) * inv_span  # Jl^-1(phi)
    return out
