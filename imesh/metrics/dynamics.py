"""What a reference motion asks of the robot before physics: joint torques and contact friction.

Inverse dynamics (pinocchio RNEA, free-flyer) gives the wrench the base would need and the joint
torques. The ground supplies the base wrench through the support soles: the sole wrenches ``f``
(world-aligned force and moment at each support sole frame) solve ``J_b^T f = tau_b`` (the six
base rows) in the least-norm sense, and the joint torques are ``tau_j - J_j^T f``. The friction
and yaw ratios split the ground's wrench the ZMP and the whole-body solve see
(:func:`ground_wrench`: the centroidal momentum's rate by differences of the samples), so the
balance figures share one definition of the motion's accelerations. The torque
ratio is ``max |tau_j| / effort_max``; the friction ratio is ``|f_xy| / (mu f_z)`` of each
support sole (infinite where a sole would have to pull, f_z <= 0). In single support the sole's
wrench is the ground's whole wrench, so the yaw ratio, its moment about the vertical over the
most a rectangular sole's friction holds (:func:`imesh.balance.cwc.sole_yaw_ratio`, the
contact wrench cone of Caron, Pham & Nakamura 2015), is the motion's; two soles apart hold far
more, and their least-norm split is not the ground's, so double support has no yaw ratio.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..balance.cwc import sole_yaw_ratio
from ..contacts.phases import SIDES
from .flight import GRAVITY

#: Friction coefficient of the friction ratio.
MU = 0.7


@dataclass(frozen=True, eq=False)
class ReferenceDynamics:
    """Torque and friction demands of a reference motion.

    Attributes:
        torque_ratio: largest |joint torque| / effort limit.
        torque_joint: the joint of that ratio; torque_frame: its frame.
        friction_ratio: largest tangential / (mu x normal) sole force ratio over the support
            frames (inf when a sole must pull).
        friction_frame: the frame of that ratio (-1 without support).
        torque_ratios: (T,) largest |joint torque| / effort limit of each frame.
        friction_ratios: (T,) largest friction ratio of each frame (0 without support).
        yaw_ratio: largest yaw ratio over the single-support frames (NaN without any).
        yaw_frame: the frame of that ratio (-1 without single support).
        yaw_ratios: (T,) yaw ratio of each single-support frame (0 elsewhere).
    """

    torque_ratio: float
    torque_joint: str
    torque_frame: int
    friction_ratio: float
    friction_frame: int
    torque_ratios: np.ndarray
    friction_ratios: np.ndarray
    yaw_ratio: float
    yaw_frame: int
    yaw_ratios: np.ndarray


def sole_wrench_map(J: np.ndarray) -> np.ndarray:
    """(..., 6k, 6) map from the base wrench ``tau_b`` to the least-norm sole wrenches ``f``
    with ``J_b^T f = tau_b``: ``pinv(J_b^T)``.

    Args:
        J: (..., 6k, nv) world-aligned Jacobians of the k support sole frames, stacked.
    """
    return np.linalg.pinv(np.swapaxes(J[..., :6], -1, -2))


def net_torque_map(J: np.ndarray) -> np.ndarray:
    """(..., nv - 6, nv) map ``P`` from the inverse-dynamics forces ``tau`` (base wrench, joint
    torques) to the joint torques with the ground carrying the base wrench through the support
    soles: ``P tau = tau_j - J_j^T pinv(J_b^T) tau_b`` (without support, ``P tau = tau_j``).

    Args:
        J: (..., 6k, nv) world-aligned Jacobians of the k >= 0 support sole frames, stacked
            (a stack of frames with the same k is mapped at once).
    """
    nv = J.shape[-1]
    P = np.zeros((*J.shape[:-2], nv - 6, nv))
    P[..., 6:] = np.eye(nv - 6)
    if J.shape[-2]:
        P[..., :6] = -np.swapaxes(J[..., 6:], -1, -2) @ sole_wrench_map(J)
    return P


def ground_wrench(q: np.ndarray, com: np.ndarray, dh: np.ndarray, mass: float) -> np.ndarray:
    """(T, 6) the wrench the ground must exert on the robot, as a base wrench ``tau_b`` (force
    and moment about the base's origin, in the base frame: the six rows of RNEA's free-flyer):
    ``f = m (c'' + g)`` and ``n = Ld`` about the CoM, moved to the base.

    Args:
        q: (T, nq) configurations; com: (T, 3) [m] their CoM and dh: (T, 6) the centroidal
            momentum's rate, by differences of the samples
            (:meth:`imesh.robot.Robot.centroidal_trajectory`); mass: [kg].
    """
    f = dh[:, :3] + mass * np.array([0.0, 0.0, GRAVITY])
    n = dh[:, 3:] + np.cross(com - q[:, :3], f)
    R = Rotation.from_quat(q[:, 3:7]).as_matrix()  # scipy and pinocchio: x, y, z, w
    return np.concatenate([np.einsum("tji,tj->ti", R, f), np.einsum("tji,tj->ti", R, n)], 1)


def reference_dynamics(robot, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                       support: np.ndarray, base_wrench: np.ndarray,
                       mu: float = MU) -> ReferenceDynamics:
    """Joint torques and sole forces the motion needs (see the module docstring).

    Args:
        robot: the robot.
        q: (T, nq) configurations; v, a: (T, nv) velocities and accelerations.
        support: (T, 2) bool [left, right] soles in support.
        base_wrench: (T, 6) the ground's wrench as a base wrench (:func:`ground_wrench`), which
            the support soles split for the friction and yaw ratios.
        mu: friction coefficient.
    """
    T = len(q)
    frames = [robot.soles[s].frame for s in SIDES]
    kin = robot.trajectory_kinematics(q, frames)
    ratio = np.zeros((T, robot.dof))
    friction = np.zeros(T)
    wrench = np.zeros((T, 6))  # the single support sole's wrench (world axes, at its frame)
    tau_all, _ = robot.inverse_dynamics_trajectory(q, v, a)
    for t in range(T):  # one small least-squares problem per frame
        feet = np.flatnonzero(support[t])
        J = kin.jacobians[t, feet].reshape(-1, robot.nv)  # (6k, nv)
        tau = net_torque_map(J) @ tau_all[t]
        if len(feet):
            fk = (sole_wrench_map(J) @ base_wrench[t]).reshape(-1, 6)
            fz = fk[:, 2]
            tang = np.linalg.norm(fk[:, :2], axis=1)
            with np.errstate(divide="ignore", invalid="ignore"):
                r = np.where(fz > 0, tang / (mu * np.maximum(fz, 1e-12)), np.inf)
            friction[t] = r.max()
            wrench[t] = fk[0]
        ratio[t] = np.abs(tau) / robot.effort_max
    yaw = np.zeros(T)
    for k, side in enumerate(SIDES):  # every single-support frame of a sole at once
        sel = support[:, k] & ~support[:, 1 - k]
        if not sel.any():
            continue
        sole = robot.soles[side]
        R = kin.placements[sel, k, :3, :3]  # (S, 3, 3)
        f, m = wrench[sel, :3], wrench[sel, 3:]
        m = m - np.cross(R @ sole.center, f)  # about the sole centre, not the frame's origin
        local = np.concatenate([np.einsum("sji,sj->si", R, f), np.einsum("sji,sj->si", R, m)], 1)
        yaw[sel] = sole_yaw_ratio(local, sole.half_extents[0], sole.half_extents[1], mu)
    tw, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)   # the worst frame, joint
    ft, fv = worst_frame(friction, np.any(support, axis=1))
    yt, yv = worst_frame(yaw, np.sum(support, axis=1) == 1)
    return ReferenceDynamics(torque_ratio=float(ratio[tw, j]), torque_joint=robot.joint_names[j],
                             torque_frame=int(tw), friction_ratio=fv, friction_frame=ft,
                             torque_ratios=ratio.max(axis=1), friction_ratios=friction,
                             yaw_ratio=yv, yaw_frame=yt, yaw_ratios=yaw)


def worst_frame(values: np.ndarray, frames) -> tuple[int, float]:
    """(frame, value) of the largest of ``values`` (T,) over the (T,) bool ``frames``;
    (-1, NaN) without any."""
    frames = np.asarray(frames, dtype=bool)
    if not frames.any():
        return -1, float("nan")
    t = int(np.argmax(np.where(frames, values, -np.inf)))
    return t, float(values[t])
