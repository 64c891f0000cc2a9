"""The objective of the whole-body QP: tracking, smoothness, damping (DESIGN.md,
"Whole-body spacetime solve"; weights in :class:`~imesh.solve.config.WholeBodyConfig`).

Per frame t (the block-diagonal part, :func:`frame_blocks`):

* interaction mesh + key points: ``e_t^T (W_t + w_L L_t^T L_t) e_t`` with
  ``e_t = X_t + J_X dq_t - M_t`` the key points' offsets from the adapted markers, ``W_t`` their
  squared weights (Nakaoka eq. 7-8) and ``L_t`` the Laplacian of the frame's interaction mesh
  over the key-point markers (Nakaoka eq. 1-2; the metric is ``Plan.mesh_metric``);
* directions: ``w_d^2 |u_t - d_t - [u_t]x J_w dq_t|^2`` (the key directions of the fit);
* ``w_r |dq_t|^2`` (step damping) and ``w_i |q_j + dq_j - q_init,j|^2`` (pull to the
  initializer, joints);
* the linear prices of the elastic rows' slacks (:class:`~imesh.solve.operators.Layout`).

Across frames (:func:`add_smoothness`): ``w_a |Delta^2 y|^2`` of the world-aligned coordinates
``y`` (:func:`world_coordinates`: base position, the base's accumulated rotation vector,
joints), second differences at 30 fps. The ZMP's dead-band cost is in :mod:`.zmp`.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .config import WholeBodyConfig
from .operators import Layout, block_diagonal, difference_operator, log3
from .plan import Linearization, Plan


def frame_blocks(lin: Linearization, plan: Plan, q: np.ndarray, config: WholeBodyConfig,
                 lay: Layout) -> tuple[sp.csr_matrix, np.ndarray]:
    """(P, c) of the per-frame terms: block diagonal P (one (nx, nx) block per frame) and c."""
    T, K = lin.points.shape[:2]
    nv, nx = lay.nv, lay.nx
    Jp = lin.point_jacobians.reshape(T, K, 3 * nv)
    e = lin.points - plan.marker_points  # (T, K, 3)
    GJ = np.matmul(plan.mesh_metric, Jp).reshape(T, K * 3, nv)
    Jflat = lin.point_jacobians.reshape(T, K * 3, nv)
    H = np.zeros((T, nx, nx))
    g = np.zeros((T, nx))
    H[:, :nv, :nv] = np.matmul(np.transpose(Jflat, (0, 2, 1)), GJ)
    Ge = np.matmul(plan.mesh_metric, e).reshape(T, K * 3)
    g[:, :nv] = np.einsum("tri,tr->ti", Jflat, Ge)
    if lin.axes.shape[1]:
        u = lin.axes
        Jw = lin.axis_jacobians  # (T, D, 3, nv): du = omega x u = -u x omega
        Ad = -np.cross(u[..., None, :], np.swapaxes(Jw, -1, -2)).swapaxes(-1, -2)
        w = (config.costs.direction * plan.direction_weights) ** 2
        r = u - plan.target_directions
        H[:, :nv, :nv] += np.einsum("tdan,d,tdam->tnm", Ad, w, Ad)
        g[:, :nv] += np.einsum("tdan,d,tda->tn", Ad, w, r)
    H[:, np.arange(nv), np.arange(nv)] += config.costs.damping
    H[:, np.arange(6, nv), np.arange(6, nv)] += config.costs.init
    g[:, 6:nv] += config.costs.init * (q[:, 7:] - plan.q_init[:, 7:])
    # the slacks' prices: above the multipliers of a feasible problem, so a slack is 0
    # wherever its rows can be met
    g[:, lay.offset["zmp_slack"]] = config.slack.balance
    g[:, lay.offset["sole_slack"]:lay.offset["sole_slack"] + 2] = config.slack.elastic
    g[:, lay.offset["ground_slack"]] = config.slack.elastic
    g[:, lay.offset["accel_slack"]] = config.slack.elastic
    g[:, lay.offset["torque_slack"]] = config.slack.balance
    g[:, lay.offset["collision_slack"]] = config.slack.elastic
    return block_diagonal(H), g.ravel()


def add_smoothness(P: sp.spmatrix, c: np.ndarray, lin: Linearization, plan: Plan,
                   q: np.ndarray, config: WholeBodyConfig, lay: Layout
                   ) -> tuple[sp.spmatrix, np.ndarray]:
    """(P, c) plus ``w_a |Delta^2 (y + S dq)|^2`` at 30 fps, y the world coordinates of ``q``
    and S their change with the update (:func:`world_map`); unchanged below 3 frames."""
    T, nv, nx = lay.n_frames, lay.nv, lay.nx
    if T >= 3 and config.costs.accel > 0:
        Rb = lin.base_rotations
        S = np.zeros((T, nv, nx))
        S[:, :, :nv] = world_map(Rb, nv)
        scale = (plan.fps / 30.0) ** 2
        D2 = sp.kron(difference_operator(T, 2), sp.identity(nv), format="csr") * scale
        A_s = D2 @ block_diagonal(S)
        r_s = D2 @ world_coordinates(q, Rb).ravel()
        P = P + config.costs.accel * (A_s.T @ A_s)
        c = c + config.costs.accel * (A_s.T @ r_s)
    return P, c


def world_map(rotations: np.ndarray, nv: int) -> np.ndarray:
    """(T, nv, nv) maps of a tangent update (base twist in the base frame, joints) to the change
    of :func:`world_coordinates`: ``blockdiag(R_t, R_t, I)``."""
    out = np.zeros((len(rotations), nv, nv))
    out[:, :3, :3] = rotations
    out[:, 3:6, 3:6] = rotations
    out[:, np.arange(6, nv), np.arange(6, nv)] = 1.0
    return out


def world_coordinates(q: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """(T, nv) coordinates whose second differences measure accelerations: base position,
    the base's accumulated world rotation vector, joints."""
    T = len(q)
    steps = log3(rotations[1:] @ np.transpose(rotations[:-1], (0, 2, 1)))  # world increments
    phi = np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)]) if T else np.zeros((0, 3))
    return np.concatenate([q[:, :3], phi, q[:, 7:]], axis=1)
