"""Forward kinematics and Jacobians of the target frames: the robot calls of one damped
least-squares iteration (the rows of ``J`` in Nakaoka & Komura 2012, eq. 7-8)."""

from __future__ import annotations

import numpy as np

from .targets import CompiledTargets


def cross_columns(m: np.ndarray, r: np.ndarray) -> np.ndarray:
    """(F, 3, n) columns of ``m`` crossed with ``r`` (F, 3): ``out[f, :, k] = m[f, :, k] x r[f]``.

    Written out by component: numpy.cross with axis arguments costs ~50 us per call here.
    """
    x, y, z = m[:, 0], m[:, 1], m[:, 2]
    rx, ry, rz = r[:, 0:1], r[:, 1:2], r[:, 2:3]
    return np.stack([y * rz - z * ry, z * rx - x * rz, x * ry - y * rx], axis=1)


class Kinematics:
    """The few robot calls one DLS iteration needs, with the target frames fixed.

    One placement call for the union of key-point and direction frames per evaluation; per
    Jacobian, origin point Jacobians of the key-point frames and angular Jacobians of all frames,
    with the key-point offsets applied in numpy (``J_p = J_o - [R offset]x J_omega``).
    """

    def __init__(self, robot, targets: CompiledTargets) -> None:
        self.robot = robot
        frames = list(dict.fromkeys(targets.kp_frame_ids + targets.dir_frame_ids))
        kp_frames = list(dict.fromkeys(targets.kp_frame_ids))
        self.frames = frames
        self.kp_frames = kp_frames
        self.kp_in_all = np.array([frames.index(f) for f in targets.kp_frame_ids], dtype=np.int64)
        self.kp_in_kp = np.array([kp_frames.index(f) for f in targets.kp_frame_ids],
                                 dtype=np.int64)
        self.dir_in_all = np.array([frames.index(f) for f in targets.dir_frame_ids],
                                   dtype=np.int64)
        self.kp_offsets = targets.kp_offsets
        self.dir_axes = targets.dir_axes
        self.has_placements = hasattr(robot, "frame_placements")
        self.has_frame_jacobians = hasattr(robot, "frame_jacobians")
        self._lever = np.zeros((len(targets.kp_frame_ids), 3))

    def points_and_axes(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(K, 3) key points [m] and (D, 3) world unit axes of the direction frames at ``q``.

        Also remembers the key-point levers ``R offset`` for :meth:`jacobians` at the same q.
        """
        robot = self.robot
        if self.has_placements:
            m = robot.frame_placements(q, self.frames)
            rot, trans = m[:, :3, :3], m[:, :3, 3]
        else:
            trans = robot.frame_positions(q, self.frames)
            rot = robot.frame_rotations(q, self.frames)
        self._lever = np.einsum("kij,kj->ki", rot[self.kp_in_all], self.kp_offsets)
        points = trans[self.kp_in_all] + self._lever
        axes = np.einsum("dij,dj->di", rot[self.dir_in_all], self.dir_axes)
        return points, axes

    def jacobians(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(K, 3, nv) key-point Jacobians and (D, 3, nv) angular Jacobians (world-aligned) at
        the q of the last :meth:`points_and_axes` call."""
        robot = self.robot
        if self.has_frame_jacobians:
            jac = robot.frame_jacobians(q, self.frames)
            j_lin, j_ang = jac[self.kp_in_all, :3], jac[:, 3:]
        else:
            j_ang = robot.frame_angular_jacobians(q, self.frames)
            j_lin = robot.point_jacobians(q, self.kp_frames)[self.kp_in_kp]
        ang_kp = j_ang[self.kp_in_all]
        # v_p = v_o + omega x r  ->  J_p = J_o + J_omega x r (column-wise)
        jp = j_lin + cross_columns(ang_kp, self._lever)
        return jp, j_ang[self.dir_in_all]
