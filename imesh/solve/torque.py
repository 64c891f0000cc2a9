"""Joint torques within the effort limits: the torque rows of the whole-body QP.

The torques a motion asks are the evaluator's (``torque_ratio_ref``,
:func:`imesh.metrics.dynamics.reference_dynamics`): inverse dynamics
``tau_t = RNEA(q_t, v_t, a_t)`` with the evaluator's finite differences ``v = G q``,
``a = G G q`` (``G`` = ``numpy.gradient``), and the base wrench carried by the support soles
(least-norm split), so the joints carry ``P_t tau_t`` (:func:`~imesh.metrics.dynamics.
net_torque_map`). Linearized at the current trajectory,

    d(P_t tau_t) = P_t (dtau/dq dq_t + dtau/dv sum_s G_ts dq_s + dtau/da sum_s (G G)_ts dq_s),

plus ``d(P_t) tau_t`` (the split moves with the soles' Jacobians; forward differences over
q_t); the velocities' and accelerations' partials follow the evaluator's differences of the
base (:func:`_derivative_blocks`: differenced like joints, the base was 2x off on a walk and
the SQP zig-zagged). A row couples frames t-2..t+2, so the QP stays banded.

Rows are a working set: only joints and frames whose torque is above ``ACTIVE`` of the limit
get one (a walk has a handful); the exact torques are evaluated again at every trial step in
the merit, which prices what is left above the limit.

Where the evaluator's support detection (:func:`~imesh.metrics.support.detect_support`,
which needs a slow sole) does not count a planned support foot, at a fast touch-down, the
frame is also held with the feet it does count (G1 wave: 0.95 with the planned support, 1.66
with the evaluator's, which leaves out the landing foot at one frame). Leaving out every foot
at the ends of its support runs instead asks the stance ankle to hold the whole double-support
ZMP shift at each touch-down: the G1 walk's solve did not converge with that (21 iterations,
marker RMS 47 -> 111 mm).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contacts.phases import SIDES
from ..metrics.dynamics import net_torque_map
from ..metrics.soles import SoleTracks
from ..metrics.support import detect_support
from .operators import gradient_operator

#: torques above this fraction of the (margin-reduced) limit get a row
ACTIVE = 0.7

#: frames a row reaches on each side (the second difference of numpy.gradient spans t-2..t+2)
REACH = 2


@dataclass(frozen=True, eq=False)
class TorqueLinearization:
    """Joint torques of a trajectory against the effort limits, and the working-set rows.

    Attributes:
        ratio: (T, n) signed net joint torque over its effort limit (of the support split
            that asks more of the joint).
        frames: (R,) frame of each row; joints: (R,) joint index (0..n-1) of each row.
        values: (R,) the row's current ratio (its support split's).
        columns: (R, 2 REACH + 1) frames the row's coefficients apply to (t-2..t+2 clipped to
            the clip; a clipped entry has zero coefficients).
        coefficients: (R, 2 REACH + 1, nv) d(ratio) / d(dq_s) for those frames.
    """

    ratio: np.ndarray
    frames: np.ndarray
    joints: np.ndarray
    values: np.ndarray
    columns: np.ndarray
    coefficients: np.ndarray

    def excess(self, limit: float) -> np.ndarray:
        """(T,) how far each frame's largest |ratio| is above ``limit`` (0 where below)."""
        return np.maximum(np.abs(self.ratio).max(axis=1, initial=0.0) - limit, 0.0)


def linearize_torques(robot, q: np.ndarray, v: np.ndarray, a: np.ndarray, fps: float,
                      support: np.ndarray, sole_poses: np.ndarray, sole_jacobians: np.ndarray,
                      limit: float, dv_dq: np.ndarray) -> TorqueLinearization:
    """Net joint torques of the trajectory and the rows of those above ``ACTIVE * limit``,
    with the planned support and, where it counts fewer feet, the evaluator's (see the module
    docstring).

    Args:
        robot: the robot.
        q: (T, nq) configurations; v, a: (T, nv) the evaluator's velocities and
            accelerations of q (:func:`imesh.metrics.derivatives.motion_derivatives`).
        fps: frame rate [1/s].
        support: (T, 2) bool planned support [left, right].
        sole_poses: (T, 2, 4, 4) world poses of the sole frames [left, right].
        sole_jacobians: (T, 2, 6, nv) world-aligned Jacobians of the sole frames.
        limit: the ratio the rows keep (1 - the torque margin).
        dv_dq: (T, 3, nv, nv) the velocities' derivatives
            (:func:`imesh.metrics.derivatives.velocity_jacobians` of q).
    """
    tau, _ = robot.inverse_dynamics_trajectory(q, v, a)
    splits = [support]
    counted = support & evaluator_support(robot, sole_poses, fps)
    if (counted != support).any():
        splits.append(np.where(counted.any(axis=1, keepdims=True), counted, support))
    parts = [_linearize_split(robot, q, v, a, fps, s, sole_jacobians, limit, tau, dv_dq)
             for s in splits]
    ratio = parts[0].ratio
    for p in parts[1:]:
        ratio = np.where(np.abs(p.ratio) > np.abs(ratio), p.ratio, ratio)
    return TorqueLinearization(ratio=ratio, **{
        name: np.concatenate([getattr(p, name) for p in parts])
        for name in ("frames", "joints", "values", "columns", "coefficients")})


def evaluator_support(robot, sole_poses: np.ndarray, fps: float) -> np.ndarray:
    """(T, 2) bool the support the evaluator detects from the sole poses (T, 2, 4, 4)."""
    corners, centers = {}, {}
    for k, side in enumerate(SIDES):
        sole = robot.soles[side]
        R, p = sole_poses[:, k, :3, :3], sole_poses[:, k, :3, 3]
        corners[side] = np.einsum("tij,cj->tci", R, sole.corners()) + p[:, None]
        centers[side] = np.einsum("tij,j->ti", R, sole.center) + p
    return detect_support(SoleTracks(corners=corners, centers=centers, fps=fps)).support


def _linearize_split(robot, q, v, a, fps, support, sole_jacobians, limit, tau, dv_dq
                     ) -> TorqueLinearization:
    """:func:`linearize_torques` with one support split; ``tau`` (T, nv) the RNEA forces."""
    T, nv = v.shape
    # P_t per support pattern, batched (np.linalg.pinv takes stacks)
    P = np.zeros((T, nv - 6, nv))
    for pattern in ((False, False), (True, False), (False, True), (True, True)):
        at = np.flatnonzero((support == pattern).all(axis=1))
        if len(at) == 0:
            continue
        feet = np.flatnonzero(pattern)
        J = sole_jacobians[at][:, feet].reshape(len(at), 6 * len(feet), nv)
        P[at] = net_torque_map(J)
    ratio = np.einsum("tjn,tn->tj", P, tau) / robot.effort_max
    tt, jj = np.nonzero(np.abs(ratio) > ACTIVE * limit)
    W = 2 * REACH + 1
    if len(tt) == 0:
        return TorqueLinearization(ratio=ratio, frames=tt, joints=jj, values=ratio[tt, jj],
                                   columns=np.zeros((0, W), int),
                                   coefficients=np.zeros((0, W, nv)))
    active = np.unique(tt)
    want = np.zeros(T, bool)
    want[active] = True
    _, dtau = robot.inverse_dynamics_trajectory(q[want], v[want], a[want],
                                                derivatives=np.ones(len(active), bool))
    # (A, 3, n, nv): the net torque's partials at the active frames; the split's own change
    # with q_t (the soles' levers move with the legs: 17 % of the change at the ankles) by
    # forward differences of the sole Jacobians, one batched pass over nv steps per frame
    Pd = np.einsum("ajn,akns->akjs", P[active], dtau)
    Pd[:, 0] += _split_derivative(robot, q[active], support[active], tau[active], P[active])
    Bv, Ba = _derivative_blocks(dv_dq, fps)
    slot = np.searchsorted(active, tt)
    offsets = np.arange(-REACH, REACH + 1)
    coef = (np.einsum("rn,rwnm->rwm", Pd[slot, 1, jj], Bv[tt])
            + np.einsum("rn,rwnm->rwm", Pd[slot, 2, jj], Ba[tt]))
    coef[:, REACH] += Pd[slot, 0, jj]
    columns = tt[:, None] + offsets
    outside = (columns < 0) | (columns >= T)
    coef[outside] = 0.0
    columns = np.clip(columns, 0, T - 1)
    coef /= robot.effort_max[jj][:, None, None]
    return TorqueLinearization(ratio=ratio, frames=tt, joints=jj, values=ratio[tt, jj],
                               columns=columns, coefficients=coef)



def _derivative_blocks(dv_dq: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """(T, W, nv, nv) ``dv_t / d dq_{t+o}`` and ``da_t / d dq_{t+o}``, o = -REACH..REACH, of
    the evaluator's finite differences (:func:`imesh.metrics.derivatives.motion_derivatives`):
    ``v``'s from ``dv_dq`` (:func:`~imesh.metrics.derivatives.velocity_jacobians`, the base's
    turn between the frames included), ``a = G v``. At the ends a neighbour that is the frame
    itself adds to offset 0.
    """
    T, _, nv, _ = dv_dq.shape
    W = 2 * REACH + 1
    coo = gradient_operator(T, 1.0 / fps).tocoo()
    wG = np.zeros((T, W))
    wG[coo.row, coo.col - coo.row + REACH] = coo.data
    frames = np.arange(T)
    Jv = dv_dq  # (T, 3, nv, nv): prev, t, next
    Bv = np.zeros((T, W, nv, nv))
    Bv[:, REACH] = Jv[:, 1]
    for k, o in ((0, -1), (2, 1)):
        inside = (frames + o >= 0) & (frames + o < T)
        Bv[inside, REACH + o] = Jv[inside, k]
        Bv[~inside, REACH] += Jv[~inside, k]
    # a_t = sum_u G_tu v_u: offsets o1 (t -> u) and o2 (u -> s) add up
    Ba = np.zeros_like(Bv)
    for o1 in range(-1, 2):
        u = np.clip(frames + o1, 0, T - 1)
        w = wG[:, o1 + REACH][:, None, None]
        for o2 in range(-1, 2):
            Ba[:, o1 + o2 + REACH] += w * Bv[u, o2 + REACH]
    return Bv, Ba


def sole_chain_columns(robot) -> np.ndarray:
    """Tangent indices whose change moves the soles' world-aligned Jacobians: the base's
    rotation and the joints on the chains from the base to the sole frames. The base's
    translation and every other joint leave them as they are."""
    model = robot.model
    cols = {3, 4, 5}
    for side in SIDES:
        frame = model.frames[robot.frame_id(robot.soles[side].frame)]
        for j in model.supports[frame.parentJoint]:
            joint = model.joints[j]
            if j > 1 and joint.nv:  # not the universe nor the free flyer
                cols.update(range(joint.idx_v, joint.idx_v + joint.nv))
    return np.array(sorted(cols))


def _split_derivative(robot, q: np.ndarray, support: np.ndarray, tau: np.ndarray,
                      P: np.ndarray, step: float = 1e-6) -> np.ndarray:
    """(A, n, nv) ``d(P(q) tau) / dq`` with tau fixed, at A frames (forward differences over
    :func:`sole_chain_columns`; the other columns are 0: P depends on q through the soles'
    Jacobians only)."""
    A, nv = len(q), P.shape[-1]
    cols = sole_chain_columns(robot)
    C = len(cols)
    eye = step * np.eye(nv)[cols]
    moved = np.array([robot.integrate(q[i], eye[k]) for i in range(A) for k in range(C)])
    frames = [robot.soles[s].frame for s in SIDES]
    J = robot.trajectory_kinematics(moved, frames).jacobians.reshape(A, C, 2, 6, nv)
    sub = np.zeros((A, P.shape[1], C))
    for pattern in ((True, False), (False, True), (True, True)):
        at = np.flatnonzero((support == pattern).all(axis=1))
        if len(at) == 0:
            continue
        feet = np.flatnonzero(pattern)
        Jp = J[at][:, :, feet].reshape(len(at), C, 6 * len(feet), nv)
        Pm = net_torque_map(Jp)  # (a, C, n, nv): the split after each step
        sub[at] = np.transpose(np.einsum("akjs,as->akj", Pm, tau[at])
                               - np.einsum("ajs,as->aj", P[at], tau[at])[:, None], (0, 2, 1))
    out = np.zeros((A, P.shape[1], nv))
    out[:, :, cols] = sub / step
    return out
