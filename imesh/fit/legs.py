"""Planted support feet: the legs solved so that each support sole stands flat and still.

The whole-body fit (:mod:`imesh.fit.dls`) weighs the feet against every other key point, so a
support sole drifts by millimetres to centimetres where the markers disagree (on the CMU wave the
left foot of JVRC-1 drifts 1-2 cm while the fit trades it against knee key points), and its free
base picks up the frame-to-frame jitter of the marker fit, which the multibody ZMP amplifies by
``1 + (2 pi f)^2 z / g`` (x 30 at 3 Hz). This stage works on the fitted joint trajectory:

1. the base trajectory is low-passed over the whole clip (zero phase, ``base_lowpass_hz``);
2. each support phase gets one footprint: the sole flat on the ground (sole rectangle on z = 0)
   at the median position and the circular-mean heading of the fitted sole over the middle half
   of the phase; on the support ramps (:func:`imesh.support.phase_blend`) the fitted sole is
   moved by the phase edge's offset (footprint - fitted) times the ramp weight, so the target
   is continuous and keeps the fitted heel strike and toe-off; swing frames keep the fitted
   sole pose; no target corner goes below the ground;
3. each leg's 6 joints are solved per frame by damped Newton steps on the 6-DOF sole pose error
   (position [m] and rotation vector [rad], world-aligned Jacobians), within the position limits;
4. the joint trajectory is projected onto the velocity and acceleration limits
   (:func:`imesh.fit.feasible.project_joint_trajectory`).

The upper body keeps its fitted joint angles (it rides on the smoothed base). The balance loop
(:mod:`imesh.balance`) reuses steps 3-4 with a corrected base (:func:`resolve_legs`).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace

import numpy as np
from scipy.ndimage import distance_transform_edt
from scipy.spatial.transform import Rotation

from ..contacts import SIDES, runs
from ..errors import OptionError
from ..filtering import lowpass_array
from ..support import middle_half, phase_blend
from .feasible import project_joint_trajectory

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PlantConfig:
    """Settings of the planted-feet stage.

    Attributes:
        base_lowpass_hz: cut-off of the zero-phase low-pass of the base position and
            orientation [Hz]; None keeps the fitted base.
        base_yaw_lowpass_hz: cut-off of the base heading's low-pass [Hz]. The fitted pelvis
            yaws with the stride (CMU walk: +-20 deg in the source, +-30 deg after the morph,
            while the chest stays within 7 deg); a robot's hip yaw range (JVRC-1: 0.52 rad)
            cannot turn planted feet that far, so the base keeps the slow heading and the
            torso joints keep the chest's fitted rotation.
        min_knee_rad: the base is lowered (one constant drop over the clip; halved or none
            where the ankles cannot follow) so that no support leg needs its knee straighter
            than this [rad]: near the stretched knee a millimetre
            of base height is degrees of knee angle, and the human walk's straight stance leg
            would shake the robot's knees at their acceleration limits.
        ramp_s: support ramp length [s] (the blend from the fitted sole to the footprint).
        planted_weight: extra weight of a planted leg's joints in the limit projection
            (:func:`imesh.fit.feasible.project_joint_trajectory`; the others weigh 1).
        reach_tolerance_m, reach_tolerance_deg: where a leg misses its footprint by more than
            this, the sole is let go towards its fitted pose (``Planted.unplanted``) ...
        release_rounds: ... in at most this many rounds of leg solves.
        iterations: Newton steps per frame and leg at most.
        tolerance_m: stop when the sole error is below this (position [m], rotation [rad]).
        damping: Levenberg damping of the 6 x 6 leg solve (squared, [m^2]).
    """

    base_lowpass_hz: float | None = 6.0
    base_yaw_lowpass_hz: float | None = 0.5
    min_knee_rad: float = 0.8
    ramp_s: float = 0.12
    planted_weight: float = 1e3
    reach_tolerance_m: float = 2e-3
    reach_tolerance_deg: float = 2.0
    release_rounds: int = 3
    iterations: int = 30
    tolerance_m: float = 1e-6
    damping: float = 1e-6

    def __post_init__(self) -> None:
        if self.base_lowpass_hz is not None and not (np.isfinite(self.base_lowpass_hz)
                                                     and self.base_lowpass_hz > 0):
            raise OptionError("base_lowpass_hz", self.base_lowpass_hz, "a positive frequency")
        if not (isinstance(self.iterations, int) and self.iterations >= 1):
            raise OptionError("iterations", self.iterations, "an integer >= 1")
        for name in ("ramp_s", "tolerance_m", "damping"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise OptionError(name, value, "a number >= 0")


@dataclass(frozen=True, eq=False)
class FootTargets:
    """World poses the soles must take.

    Attributes:
        poses: (T, 2, 4, 4) float [left, right] sole-frame world poses [m].
        blend: (T, 2) float in [0, 1]: 1 where the sole is planted, 0 in swing.
        torso: (T, 4, 4) float world poses of the torso frame (the ``chest`` key point's
            frame) whose rotation the torso joints keep; None: the torso joints are kept.
    """

    poses: np.ndarray
    blend: np.ndarray
    torso: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class Planted:
    """Result of :func:`plant_feet` / :func:`resolve_legs`.

    Attributes:
        q: (T, nq) float configurations within all joint limits.
        targets: the sole targets.
        position_error_m: (T, 2) float sole position error after the leg solve, before the
            limit projection [m].
        rotation_error_rad: (T, 2) float sole rotation error, same [rad].
        newton_steps: leg Newton steps over all frames.
        base_drop_m: how far the base was lowered [m] (:func:`base_drop`).
        unplanted: (T, 2) bool frames whose sole was let go (footprint out of reach).
        seconds: wall time [s].
    """

    q: np.ndarray
    targets: FootTargets
    position_error_m: np.ndarray
    rotation_error_rad: np.ndarray
    newton_steps: int
    seconds: float
    base_drop_m: float = 0.0
    unplanted: np.ndarray | None = None


def _log3(r: np.ndarray) -> np.ndarray:
    """(3,) rotation vector of a rotation matrix (angles below pi); one 3 x 3 matrix per call
    in the per-frame Newton loop, where scipy's Rotation costs ~10x more per call."""
    c = np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(c)
    w = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    # w = 2 sin(angle) axis; angle / (2 sin angle) -> 1/2 for small angles
    return w * (0.5 if angle < 1e-6 else angle / (2.0 * np.sin(angle)))


def sole_poses(robot, q: np.ndarray) -> np.ndarray:
    """(T, 2, 4, 4) float [left, right] world poses of the sole frames."""
    frames = [robot.soles[s].frame for s in SIDES]
    return np.array([robot.frame_placements(qt, frames) for qt in q])


def smooth_base(q: np.ndarray, fps: float, cutoff_hz: float | None,
                yaw_cutoff_hz: float | None = None) -> np.ndarray:
    """(T, nq) ``q`` with the base position and orientation low-passed (zero phase).

    The base rotation is split into a heading (yaw about the world z) and a tilt,
    ``R = Rz(yaw) R_tilt``; the unwrapped yaw is low-passed at ``yaw_cutoff_hz``, the tilt's
    quaternion (signs made continuous, renormalized) and the position at ``cutoff_hz``.
    """
    out = q.copy()
    nyquist = 0.5 * fps
    if cutoff_hz is not None and cutoff_hz < nyquist:
        pos = lowpass_array(q[:, :3], fps, cutoff_hz, order=2)
        out[:, :3] = q[:, :3] if pos is None else pos
    rot = Rotation.from_quat(q[:, 3:7])
    yaw = np.unwrap(rot.as_euler("ZYX")[:, 0])
    tilt = (Rotation.from_euler("Z", -yaw[:, None]) * rot).as_quat()
    if cutoff_hz is not None and cutoff_hz < nyquist:
        flip = np.cumsum(np.r_[0, np.sum(tilt[1:] * tilt[:-1], axis=1) < 0]) % 2 == 1
        tilt[flip] *= -1.0
        smooth = lowpass_array(tilt, fps, cutoff_hz, order=2)
        if smooth is not None:
            tilt = smooth / np.linalg.norm(smooth, axis=1, keepdims=True)
    if yaw_cutoff_hz is not None and yaw_cutoff_hz < nyquist:
        smooth = lowpass_array(yaw, fps, yaw_cutoff_hz, order=2)
        yaw = yaw if smooth is None else smooth
    out[:, 3:7] = (Rotation.from_euler("Z", yaw[:, None]) * Rotation.from_quat(tilt)).as_quat()
    return out


def foot_targets(robot, q: np.ndarray, support: np.ndarray, fps: float,
                 ramp_s: float = 0.12, hold: np.ndarray | None = None) -> FootTargets:
    """Sole targets: footprints in the support phases, the fitted soles in swing.

    Args:
        robot: the robot.
        q: (T, nq) the fitted motion (its sole poses give footprints and swing poses).
        support: (T, 2) bool planned support [left, right].
        fps: frame rate [1/s].
        ramp_s: blend time between the fitted sole and the footprint [s].
        hold: (T, 2) float in [0, 1] multiplying the blend (0: the fitted sole where the leg
            cannot reach the footprint); None: 1.
    """
    fitted = sole_poses(robot, q)
    poses = fitted.copy()
    q0 = robot.q_nominal
    n = len(q)
    ramp = int(round(ramp_s * fps))
    blend = np.zeros((n, 2))
    for k, side in enumerate(SIDES):
        sole = robot.soles[side]
        nominal = robot.frame_placements(q0, [sole.frame])[0]
        r0 = nominal[:3, :3]  # the flat sole's rotation at heading 0
        center_z = float((nominal[:3, :3] @ sole.center + nominal[:3, 3])[2])
        phases = runs(support[:, k])
        s, owner = phase_blend(n, phases, ramp)
        if hold is not None:
            s = s * hold[:, k]
        blend[:, k] = s
        if not phases:
            continue
        rot = fitted[:, k, :3, :3]
        heading = rot @ r0.T  # rotation from the flat sole to the fitted one
        yaw = np.arctan2(heading[:, 1, 0], heading[:, 0, 0])
        centers = np.einsum("tij,j->ti", rot, sole.center) + fitted[:, k, :3, 3]
        planted = np.empty((len(phases), 4, 4))
        for i, (start, stop) in enumerate(phases):
            a, b = middle_half(start, stop)
            psi = np.arctan2(np.sin(yaw[a:b]).mean(), np.cos(yaw[a:b]).mean())
            r = np.array([[np.cos(psi), -np.sin(psi), 0], [np.sin(psi), np.cos(psi), 0],
                          [0, 0, 1.0]]) @ r0
            c = np.r_[np.median(centers[a:b, :2], axis=0), center_z]
            planted[i] = np.eye(4)
            planted[i, :3, :3] = r
            planted[i, :3, 3] = c - r @ sole.center
        # Within a phase the sole is at its footprint. On the ramps the fitted sole (which
        # already rolls over the toe or the heel: the morph's support targets) is moved by the
        # offset footprint - fitted of the nearest phase frame, scaled by the ramp weight: the
        # target is continuous and keeps the fitted heel strike and toe-off.
        held = np.flatnonzero(owner >= 0)
        starts = np.array([a for a, _ in phases])[owner[held]]
        stops = np.array([b for _, b in phases])[owner[held]]
        edge = np.clip(held, starts, stops - 1)  # the nearest frame inside the phase
        target = planted[owner[held]]
        w = s[held]
        d_rot = Rotation.from_matrix(np.einsum("tij,tkj->tik", target[:, :3, :3], rot[edge]))
        poses[held, k, :3, :3] = np.einsum(
            "tij,tjk->tik", Rotation.from_rotvec(d_rot.as_rotvec() * w[:, None]).as_matrix(),
            rot[held])
        poses[held, k, :3, 3] = (fitted[held, k, :3, 3]
                                 + w[:, None] * (target[:, :3, 3] - fitted[edge, k, :3, 3]))
        # no corner below the ground (a fitted heel strike can dip into it)
        corners = (np.einsum("tij,cj->tci", poses[:, k, :3, :3], sole.corners())
                   + poses[:, k, None, :3, 3])
        poses[:, k, 2, 3] += np.maximum(0.0, -corners[..., 2].min(axis=1))
    return FootTargets(poses=poses, blend=blend)


@dataclass(frozen=True, eq=False)
class _ChainTask:
    """A frame moved by a chain of joints to world poses (or rotations only)."""

    frame: int
    chain: np.ndarray  # indices into q[7:]
    poses: np.ndarray  # (T, 4, 4)
    rotation_only: bool = False


def _torso_chain(robot) -> tuple[int, np.ndarray] | None:
    """(frame, joints) of the torso: the ``chest`` key point's frame and the joints moving it;
    None if the robot has no chest key point or no torso joints."""
    markers = robot.markers
    if markers is None or "chest" not in markers.keypoints:
        return None
    frame = robot.frame_id(markers.keypoints["chest"].frame)
    chain = robot.supporting_joints(frame)
    return (frame, chain) if len(chain) else None


def torso_poses(robot, q: np.ndarray) -> np.ndarray | None:
    """(T, 4, 4) world poses of the torso frame over ``q`` (None without torso joints): the
    rotations the torso joints keep, so the upper body does not turn with a smoothed base."""
    torso = _torso_chain(robot)
    if torso is None:
        return None
    return np.array([robot.frame_placements(qt, [torso[0]])[0] for qt in q])


def _solve_chains(robot, q: np.ndarray, tasks: list[_ChainTask], lower: np.ndarray,
                  upper: np.ndarray, config: PlantConfig
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Per frame, per task: damped Newton on the frame's pose error over its chain's joints,
    clipped to the position limits (the chains are disjoint, so the tasks do not interact).

    Returns:
        (q, position errors (T, n_tasks) [m], rotation errors (T, n_tasks) [rad], steps).
    """
    q = q.copy()
    n = len(q)
    frames = [task.frame for task in tasks]
    pos_err = np.zeros((n, len(tasks)))
    rot_err = np.zeros((n, len(tasks)))
    steps = 0

    def errors(placements, t):
        out = []
        for k, task in enumerate(tasks):
            goal = task.poses[t]
            dp = np.zeros(3) if task.rotation_only else goal[:3, 3] - placements[k, :3, 3]
            out.append(np.r_[dp, _log3(goal[:3, :3] @ placements[k, :3, :3].T)])
        return out

    for t in range(n):
        qt = q[t]
        for _ in range(config.iterations):
            robot.forward(qt)
            e = errors(robot.frame_placements(None, frames), t)
            active = [k for k in range(len(tasks)) if np.abs(e[k]).max() > config.tolerance_m]
            if not active:
                break
            steps += 1
            jp = robot.point_jacobians(None, frames)
            jw = robot.frame_angular_jacobians(None, frames)
            for k in active:
                chain = tasks[k].chain
                cols = 6 + chain
                rows = slice(3, 6) if tasks[k].rotation_only else slice(0, 6)
                jac = np.vstack([jp[k][:, cols], jw[k][:, cols]])[rows]
                err = e[k][rows]
                # Levenberg-Marquardt damping |e|^2 + lambda (Sugihara 2011): converges to the
                # closest reachable pose when the target is out of reach (a stretched knee)
                m = len(chain)
                dq = np.linalg.solve(jac.T @ jac + (err @ err + config.damping) * np.eye(m),
                                     jac.T @ err)
                idx = 7 + chain
                qt[idx] = np.clip(qt[idx] + dq, lower[chain], upper[chain])
        e = errors(robot.frame_placements(qt, frames), t)
        pos_err[t] = [np.linalg.norm(x[:3]) for x in e]
        rot_err[t] = [np.linalg.norm(x[3:]) for x in e]
    return q, pos_err, rot_err, steps


def _leg_tasks(robot, targets: FootTargets) -> list[_ChainTask]:
    tasks = []
    for k, side in enumerate(SIDES):
        frame = robot.frame_id(robot.soles[side].frame)
        tasks.append(_ChainTask(frame=frame, chain=robot.supporting_joints(frame),
                                poses=targets.poses[:, k]))
    return tasks


@dataclass(frozen=True)
class _Leg:
    """A 6-joint leg: hip (first joint, fixed on the base), knee (4th), ankle (5th, fixed on
    the sole frame), measured in the nominal pose."""

    knee: int  # index into q[7:]
    knee_sign: float  # +1 if the knee bends towards positive angles
    thigh: float  # [m]
    shank: float  # [m]
    hip_in_base: np.ndarray  # (3,) [m]
    ankle_in_sole: np.ndarray  # (3,) [m]

    @classmethod
    def of(cls, robot, side: str) -> _Leg | None:
        sole = robot.soles[side]
        chain = robot.supporting_joints(sole.frame)
        if len(chain) != 6:  # not a hip-knee-ankle leg
            return None
        q0 = robot.q_nominal
        names = [robot.joint_names[i] for i in chain]
        hip0, knee0, ankle0 = robot.frame_positions(q0, [names[0], names[3], names[4]])
        sole0 = robot.frame_placements(q0, [sole.frame])[0]
        base0 = Rotation.from_quat(q0[3:7]).as_matrix()
        bend = q0[7 + chain[3]]
        return cls(knee=int(chain[3]), knee_sign=-1.0 if bend < 0 else 1.0,
                   thigh=float(np.linalg.norm(knee0 - hip0)),
                   shank=float(np.linalg.norm(ankle0 - knee0)),
                   hip_in_base=base0.T @ (hip0 - q0[:3]),
                   ankle_in_sole=sole0[:3, :3].T @ (ankle0 - sole0[:3, 3]))

    def hip_ankle(self, q: np.ndarray, poses: np.ndarray) -> np.ndarray:
        """(T, 3) [m] ankle target minus hip for base poses q (T, nq) and sole poses."""
        hip = q[:, :3] + Rotation.from_quat(q[:, 3:7]).as_matrix() @ self.hip_in_base
        return poses[:, :3, :3] @ self.ankle_in_sole + poses[:, :3, 3] - hip

    def reach(self, knee_rad) -> np.ndarray:
        """Hip-ankle distance [m] at a knee angle."""
        a, b = self.thigh, self.shank
        return np.sqrt(a * a + b * b + 2 * a * b * np.cos(knee_rad))

    def knee_for(self, distance: np.ndarray) -> np.ndarray:
        """Knee angle [rad] (signed like the nominal bend) for hip-ankle distances."""
        a, b = self.thigh, self.shank
        c = np.clip((distance**2 - a * a - b * b) / (2 * a * b), -1.0, 1.0)
        return self.knee_sign * np.arccos(c)


def base_drop(robot, q: np.ndarray, targets: FootTargets, min_knee_rad: float) -> float:
    """[m] >= 0 how far to lower the base so that every planted leg keeps its knee bent by at
    least ``min_knee_rad``.

    With thigh ``a`` and shank ``b`` the hip-ankle distance at knee angle ``k`` is
    ``r(k) = sqrt(a^2 + b^2 + 2 a b cos k)``; for each frame with a planted sole (blend 1) the
    drop ``dz - sqrt(r^2 - dxy^2)`` brings the hip to distance ``r`` of the ankle.
    """
    drop = 0.0
    for k, side in enumerate(SIDES):
        held = targets.blend[:, k] >= 1.0
        leg = _Leg.of(robot, side)
        if leg is None or not held.any():
            continue
        d = -leg.hip_ankle(q[held], targets.poses[held, k])
        reach = leg.reach(min_knee_rad)
        need = d[:, 2] - np.sqrt(np.maximum(reach**2 - np.sum(d[:, :2] ** 2, axis=1), 0.0))
        drop = max(drop, float(need.max()))
    return max(drop, 0.0)


def resolve_legs(robot, q: np.ndarray, targets: FootTargets, fps: float, limits: tuple,
                 config: PlantConfig | None = None) -> Planted:
    """Solve the legs of ``q`` (its base and upper body kept) for sole targets, then project
    the joints onto the limits.

    Args:
        robot: the robot.
        q: (T, nq) configurations (base and upper body as wanted; legs a warm start).
        targets: FootTargets.
        fps: frame rate [1/s].
        limits: (q_lower, q_upper, v_max, a_max), each (n,) (the fit's limits).
        config: PlantConfig.
    """
    config = config or PlantConfig()
    t0 = time.perf_counter()
    lower, upper, vmax, amax = limits
    tasks = _leg_tasks(robot, targets)
    q = q.copy()
    for k, side in enumerate(SIDES):
        # start each frame's Newton iteration with the knee bent as far as the hip-ankle
        # distance says: from a stretched knee (a singular Jacobian, the joint on its limit)
        # the iteration stalls short of a target it could reach
        leg = _Leg.of(robot, side)
        if leg is not None:
            distance = np.linalg.norm(leg.hip_ankle(q, targets.poses[:, k]), axis=1)
            q[:, 7 + leg.knee] = np.clip(leg.knee_for(distance), lower[leg.knee],
                                         upper[leg.knee])
    torso = _torso_chain(robot)
    if targets.torso is not None and torso is not None:
        tasks.append(_ChainTask(frame=torso[0], chain=torso[1], poses=targets.torso,
                                rotation_only=True))
    solved, pos_err, rot_err, steps = _solve_chains(robot, q, tasks, lower, upper, config)
    pos_err, rot_err = pos_err[:, :2], rot_err[:, :2]
    if len(q) >= 3:
        # the limits are met by the swing legs and the upper body first: a planted leg's
        # joints weigh planted_weight times more (times the blend on the ramps)
        weights = np.ones((len(q), robot.nq - 7))
        for k, task in enumerate(tasks[:2]):
            weights[:, task.chain] += config.planted_weight * targets.blend[:, k, None]
        solved[:, 7:] = project_joint_trajectory(solved[:, 7:], fps, lower, upper, vmax,
                                                 amax, weights=weights).q
    return Planted(q=solved, targets=targets, position_error_m=pos_err,
                   rotation_error_rad=rot_err, newton_steps=steps,
                   seconds=time.perf_counter() - t0)


def _unreachable(out: Planted, config: PlantConfig) -> np.ndarray:
    """(T, 2) bool sole samples the leg solve missed by more than the reach tolerances."""
    return ((out.position_error_m > config.reach_tolerance_m)
            | (out.rotation_error_rad > np.radians(config.reach_tolerance_deg)))


def plant_feet(robot, q: np.ndarray, fps: float, support: np.ndarray, limits: tuple,
               config: PlantConfig | None = None) -> Planted:
    """Smooth the base, plant the support soles and solve the legs (module docstring).

    Args:
        robot: the robot.
        q: (T, nq) the fitted motion.
        fps: frame rate [1/s].
        support: (T, 2) bool planned support [left, right] (the flat support phases).
        limits: (q_lower, q_upper, v_max, a_max) of the fit.
        config: PlantConfig.

    Returns:
        Planted; its ``q`` is within every joint limit.
    """
    config = config or PlantConfig()
    t0 = time.perf_counter()
    support = np.asarray(support, dtype=bool)
    torso = torso_poses(robot, q)
    targets = replace(foot_targets(robot, q, support, fps, config.ramp_s), torso=torso)
    smooth = smooth_base(np.asarray(q, dtype=np.float64), fps, config.base_lowpass_hz,
                         config.base_yaw_lowpass_hz)
    # The drop bends the knees, and the ankles must follow: where an ankle runs out of range
    # (HRP-4C's dorsiflexion on the CMU wave) a smaller drop is taken: the largest of
    # drop, drop/2, 0 with at most 1 % unreachable sole samples, else the one with the fewest.
    full = base_drop(robot, smooth, targets, config.min_knee_rad)
    best = None
    for drop in (full, 0.5 * full, 0.0) if full > 0 else (0.0,):
        trial = smooth.copy()
        trial[:, 2] -= drop
        out = resolve_legs(robot, trial, targets, fps, limits, config)
        n_bad = int(_unreachable(out, config).sum())
        if best is None or n_bad < best[0]:
            best = (n_bad, drop, trial, out)
        if n_bad <= 0.01 * out.position_error_m.size:  # the release below handles a few
            break
    _, drop, smooth, out = best
    # Where the leg cannot reach the footprint (the fit slid or twisted the foot because a
    # joint was on its limit: the CMU wash's squats twist the hips past JVRC-1's hip yaw range)
    # the sole is let go towards its fitted pose, over the support ramp around those frames.
    unplanted = np.zeros((len(q), 2), dtype=bool)
    for _ in range(config.release_rounds):
        bad = _unreachable(out, config) & (targets.blend > 0)
        if not bad.any():
            break
        unplanted |= bad
        ramp = max(1, int(round(config.ramp_s * fps)))
        hold = np.ones((len(q), 2))
        for k in range(2):
            if unplanted[:, k].any():
                u = np.clip(distance_transform_edt(~unplanted[:, k]) / (ramp + 1.0), 0, 1)
                hold[:, k] = u * u * (3 - 2 * u)
        targets = replace(foot_targets(robot, q, support, fps, config.ramp_s, hold),
                          torso=torso)
        out = resolve_legs(robot, smooth, targets, fps, limits, config)
    if unplanted.any():
        log.warning("planted feet: %d of %d support frames let go towards the fitted soles "
                    "(footprint out of the legs' reach)", int(unplanted.sum()),
                    int(support.sum()))
    log.info("planted feet: base lowered %.1f mm, sole error after the leg solve max %.2f mm / "
             "%.3f deg, %d Newton steps, %.2f s", 1e3 * drop, 1e3 * out.position_error_m.max(),
             np.degrees(out.rotation_error_rad.max()), out.newton_steps,
             time.perf_counter() - t0)
    return Planted(q=out.q, targets=targets, position_error_m=out.position_error_m,
                   rotation_error_rad=out.rotation_error_rad, newton_steps=out.newton_steps,
                   unplanted=unplanted,
                   seconds=time.perf_counter() - t0, base_drop_m=drop)
