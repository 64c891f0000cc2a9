"""What a whole-body controller tracks, at any time: the reference's joints, centre of mass,
base orientation and sole poses as smooth functions of time, and its planned support.

The motion comes at its frame rate (30 fps for imesh's outputs); the controller runs at 500 Hz
or more, so every quantity is a cubic spline of the frames (positions, with their first and
second derivatives as velocity and acceleration feed-forward) or, for orientations, a constant-rate
interpolation between frames with the world angular velocity splined beside it. numpy/scipy only
(no dartpy).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..contacts.phases import SIDES
from .reference import Reference
from .so3 import exp_so3


@dataclass(frozen=True)
class TrackPoint:
    """The reference at one instant (world axes; angular quantities about world axes).

    Attributes:
        q_joints: (n,) float joint angles [rad]; ``qd_joints``, ``qdd_joints`` their rates
            [rad/s, rad/s^2].
        com: (3,) float CoM [m]; ``com_vel`` [m/s], ``com_acc`` [m/s^2].
        base_rotation: (3, 3) float world rotation of the base; ``base_omega`` (3,) [rad/s],
            ``base_alpha`` (3,) [rad/s^2].
        sole_positions: (2, 3) float [left, right] sole centres [m]; ``sole_vel``,
            ``sole_acc`` their derivatives.
        sole_rotations: (2, 3, 3) float; ``sole_omega``, ``sole_alpha`` (2, 3).
        momentum: (3,) float centroidal angular momentum about the CoM [kg m^2/s];
            ``momentum_rate`` (3,) its rate [N m] (pinocchio's, from the evaluator's central
            differences: the ``Ldot`` of the planned multibody ZMP).
        support: (2,) bool [left, right] planned support.
        moving: (2,) bool [left, right] planned slide or pivot (a support that moves).
        frame: the nearest motion frame.
    """

    q_joints: np.ndarray
    qd_joints: np.ndarray
    qdd_joints: np.ndarray
    com: np.ndarray
    com_vel: np.ndarray
    com_acc: np.ndarray
    base_rotation: np.ndarray
    base_omega: np.ndarray
    base_alpha: np.ndarray
    sole_positions: np.ndarray
    sole_vel: np.ndarray
    sole_acc: np.ndarray
    sole_rotations: np.ndarray
    sole_omega: np.ndarray
    sole_alpha: np.ndarray
    momentum: np.ndarray
    momentum_rate: np.ndarray
    support: np.ndarray
    moving: np.ndarray
    frame: int


class _Track:
    """Per-frame positions (T, D) as a cubic spline (values only) and their rates and
    accelerations as the evaluator's central differences (``np.gradient`` at the frame rate,
    twice), interpolated linearly; evaluated at one time without scipy's per-call overhead.

    The rates are not the spline's derivatives on purpose: the planner bounds the ZMP computed
    with central differences, an operator blind to a frame-to-frame zig-zag (its gain is 0 at
    the Nyquist frequency), and a spline's second derivative amplifies exactly that zig-zag
    (the G1 walk's CoM: +-7 m/s^2 from frame to frame where central differences give 0.5), so a
    controller fed the spline's accelerations asks for centres of pressure from edge to edge.
    """

    def __init__(self, values: np.ndarray, fps: float):
        from scipy.interpolate import CubicSpline  # for the physics check only

        T = len(values)
        self.fps = fps
        self.last = T - 1
        times = np.arange(T) / fps
        kind = "natural" if T < 4 else "not-a-knot"
        spline = CubicSpline(times, values, axis=0, bc_type=kind)
        self.x = spline.x
        self.c = spline.c  # (4, T - 1, D): highest power first
        self.rate = np.gradient(values, 1.0 / fps, axis=0)
        self.acc = np.gradient(self.rate, 1.0 / fps, axis=0)

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        i = int(np.searchsorted(self.x, t, side="right")) - 1
        i = min(max(i, 0), len(self.x) - 2)
        h = t - self.x[i]
        c0, c1, c2, c3 = self.c[:, i]
        value = ((c0 * h + c1) * h + c2) * h + c3
        w = min(max(h * self.fps, 0.0), 1.0)
        return (value, (1 - w) * self.rate[i] + w * self.rate[i + 1],
                (1 - w) * self.acc[i] + w * self.acc[i + 1])


def _angular_velocity(rot: Rotation, fps: float) -> np.ndarray:
    """(T, 3) world angular velocity of a rotation sequence by central differences [rad/s]."""
    T = len(rot)
    if T < 2:
        return np.zeros((T, 3))
    step = (rot[1:] * rot[:-1].inv()).as_rotvec() * fps  # world-frame increments, (T-1, 3)
    w = np.empty((T, 3))
    w[1:-1] = 0.5 * (step[1:] + step[:-1])
    w[0], w[-1] = step[0], step[-1]
    return w


class _Orientation:
    """A rotation sequence (T, 3, 3) interpolated at constant rate within each frame interval
    (``R_i exp(s log(R_i^T R_{i+1}))``, the same path as a Slerp)."""

    def __init__(self, matrices: np.ndarray, fps: float):
        self.R = np.asarray(matrices, dtype=float)
        self.fps = fps
        rot = Rotation.from_matrix(self.R)
        self.rel = ((rot[:-1].inv() * rot[1:]).as_rotvec() if len(rot) > 1
                    else np.zeros((0, 3)))

    def __call__(self, t: float) -> np.ndarray:
        x = t * self.fps
        i = int(min(max(np.floor(x), 0), len(self.R) - 2)) if len(self.R) > 1 else 0
        if len(self.R) < 2:
            return self.R[0]
        return self.R[i] @ exp_so3((x - i) * self.rel[i])


class ReferenceTrack:
    """The reference of a simulation as smooth functions of time.

    Args:
        robot: the robot (its CoM, sole frames and rectangles).
        ref: the motion placed on the ground (:class:`imesh.physics.reference.Reference`).

    Attributes:
        duration_s: the motion's duration [s]; times beyond it hold the last frame (at rest).
    """

    def __init__(self, robot, ref: Reference):
        self.ref = ref
        self.fps = ref.fps
        T = ref.n_frames
        self.n_frames = T
        self.duration_s = ref.duration_s
        frames = [robot.soles[s].frame for s in SIDES]
        centres = np.array([robot.soles[s].center for s in SIDES])
        kin = robot.trajectory_kinematics(ref.q, frames)
        pl = kin.placements  # (T, 2, 4, 4)
        sole_pos = pl[:, :, :3, 3] + np.einsum("tfij,fj->tfi", pl[:, :, :3, :3], centres)
        base_R = Rotation.from_quat(ref.q[:, 3:7]).as_matrix()
        self._single = T < 2
        self.n_joints = ref.q.shape[1] - 7
        # one track of [joints, com, left and right sole centres, base and sole angular
        # velocities (world)]
        omegas = [_angular_velocity(Rotation.from_matrix(m), ref.fps)
                  for m in (base_R, pl[:, 0, :3, :3], pl[:, 1, :3, :3])]
        stacked = np.concatenate([ref.q[:, 7:], kin.com, sole_pos.reshape(T, 6), *omegas],
                                 axis=1)
        self._first = stacked[0]
        if not self._single:
            self._vectors = _Track(stacked, ref.fps)
        self._base = _Orientation(base_R, ref.fps)
        self._sole_rot = [_Orientation(pl[:, k, :3, :3], ref.fps) for k in range(2)]
        self.com_height_m = float(np.mean(kin.com[:, 2]))
        _, dh, ag = robot.centroidal_trajectory(ref.q, ref.v, ref.fps)
        self._momentum = np.einsum("tij,tj->ti", ag[:, 3:], ref.v)
        self._momentum_rate = dh[:, 3:]

    def frame(self, t: float) -> int:
        """The motion frame nearest to time ``t`` [s] (clamped to the clip)."""
        return int(min(max(round(t * self.fps), 0), self.n_frames - 1))

    def at(self, t: float) -> TrackPoint:
        """The reference at time ``t`` [s]; before 0 and after the end it holds the first / last
        frame at rest."""
        rest = self._single or t <= 0.0 or t >= self.duration_s
        tc = float(min(max(t, 0.0), self.duration_s))
        if self._single:
            x = self._first
            dx = ddx = np.zeros_like(x)
        else:
            x, dx, ddx = self._vectors(tc)
        if rest:
            dx = ddx = np.zeros_like(x)
        n = self.n_joints
        # the angular velocities are tracked themselves: value and first derivative
        omega, alpha = (np.zeros(9), np.zeros(9)) if rest else (x[n + 9:], dx[n + 9:])
        f = self.frame(tc)
        x_f = min(max(tc * self.fps, 0.0), self.n_frames - 1.0)
        i = min(int(x_f), max(self.n_frames - 2, 0))
        w = x_f - i if self.n_frames > 1 else 0.0
        j = min(i + 1, self.n_frames - 1)
        momentum = (1 - w) * self._momentum[i] + w * self._momentum[j]
        momentum_rate = (1 - w) * self._momentum_rate[i] + w * self._momentum_rate[j]
        if rest:
            momentum = momentum_rate = np.zeros(3)
        return TrackPoint(
            q_joints=x[:n], qd_joints=dx[:n], qdd_joints=ddx[:n], com=x[n:n + 3],
            com_vel=dx[n:n + 3], com_acc=ddx[n:n + 3], base_rotation=self._base(tc),
            base_omega=omega[:3], base_alpha=alpha[:3],
            sole_positions=x[n + 3:n + 9].reshape(2, 3), sole_vel=dx[n + 3:n + 9].reshape(2, 3),
            sole_acc=ddx[n + 3:n + 9].reshape(2, 3),
            sole_rotations=np.array([o(tc) for o in self._sole_rot]),
            sole_omega=omega[3:].reshape(2, 3), sole_alpha=alpha[3:].reshape(2, 3),
            momentum=momentum, momentum_rate=momentum_rate, support=self.ref.support[f],
            moving=self.ref.moving[f], frame=f)
