"""Fit a whole motion: :func:`fit_motion`, the driver of joint fitting (docs/fitting.md).

For every frame ``i`` in order, warm started from the constant-velocity prediction of frames
``i-2, i-1``, the configuration ``q_i`` is refined by damped least-squares steps (Nakaoka &
Komura 2012, eq. 7; :mod:`imesh.fit.dls`) on the key-point and direction rows of eq. 8
(:mod:`imesh.fit.residual`), inside the joint box of Kim, Kim & Oh 2005 (eqs 9, 13, 14;
:mod:`imesh.fit.limits`); :mod:`imesh.fit.track` is that frame loop. Frame 0 starts from a guess
from the marker geometry (:mod:`imesh.fit.initial`) unless ``q_init`` is given.

With FitConfig.lookahead (and velocity or acceleration limits), the loop runs with the position
box only, and the joint trajectory is then projected onto all the limits over the whole clip
(:mod:`imesh.fit.feasible`), so the result brakes ahead of fast motion instead of saturating.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable

import numpy as np

from ..core.limits import JointLimits
from ..core.motion import MarkerMotion
from ..core.robot_motion import RobotMotion
from ..robot.capsules.obstacles import Obstacles
from .config import FitConfig
from .dls import FitProblem
from .errors import FitError
from .feasible import project_joint_trajectory
from .initial import frame_guesses, initial_guess
from .kinematics import Kinematics
from .limits import ACCELERATION, POSITION, VELOCITY, IncrementBox, check_within, joint_limits
from .residual import FrameTargets
from .result import FitResult
from .targets import CompiledTargets, compile_targets
from .track import Track, track

log = logging.getLogger(__name__)


def _as_q_init(q_init: np.ndarray | RobotMotion | None, n_frames: int, nq: int
               ) -> np.ndarray | None:
    """``q_init`` of :func:`fit_motion` validated as a (nq,) or (T, nq) array with unit base
    quaternions (a copy), or None."""
    if q_init is None:
        return None
    arr = np.asarray(q_init.q if isinstance(q_init, RobotMotion) else q_init, dtype=np.float64)
    if arr.shape not in ((nq,), (n_frames, nq)):
        raise FitError(f"q_init must have shape ({nq},) or ({n_frames}, {nq}), got {arr.shape}")
    if not np.isfinite(arr).all():
        raise FitError("q_init has non-finite values")
    arr = arr.copy()
    quat = arr[..., 3:7]
    norm = np.linalg.norm(quat, axis=-1, keepdims=True)
    if np.any(norm < 1e-9):
        raise FitError("q_init has a zero base quaternion")
    arr[..., 3:7] = quat / norm
    return arr


def _limited(kin: Kinematics, frames: FrameTargets, free: Track, joints: np.ndarray,
             limits: JointLimits, fps: float) -> Track:
    """The free pass with its (T, n) joints replaced by the projection [rad]: errors and active
    ``limits`` (Kim eqs 9, 13, 14 at ``fps`` [Hz])."""
    lower, upper, vmax, amax = limits.lower, limits.upper, limits.v_max, limits.a_max
    q = free.q.copy()
    q[:, 7:] = joints
    n_frames = len(q)
    kp_err = np.full_like(free.kp_err, np.nan)
    dir_err = np.full_like(free.dir_err, np.nan)
    for t in range(n_frames):
        kp_err[t], dir_err[t] = frames.errors(t, *kin.points_and_axes(q[t]))
    # a limit is active where the trajectory uses more than 99.9 % of it
    on_pos = (joints <= lower + 1e-3 * (upper - lower)) | (joints >= upper - 1e-3 * (upper - lower))
    dt = 1.0 / fps
    on_vel = np.zeros_like(on_pos)
    on_acc = np.zeros_like(on_pos)
    on_vel[1:] = np.abs(np.diff(joints, axis=0)) >= 0.999 * dt * vmax
    on_acc[2:] = np.abs(joints[2:] - 2.0 * joints[1:-1] + joints[:-2]) >= 0.999 * dt * dt * amax
    at_bound = np.stack([on_pos.any(axis=1), on_vel.any(axis=1), on_acc.any(axis=1)], axis=1)
    return Track(q=q, kp_err=kp_err, dir_err=dir_err, iterations=free.iterations,
                 at_bound=at_bound, conflict=np.zeros(n_frames, dtype=bool),
                 joint_bound_frames=(on_pos | on_vel | on_acc).sum(axis=0), empty=free.empty,
                 restarts=free.restarts)


def fit_motion(robot, markers: MarkerMotion, *, keypoints: Iterable | None = None,
               directions: Iterable | None = None, config: FitConfig | None = None,
               q_init: np.ndarray | RobotMotion | None = None,
               obstacles: Obstacles | None = None) -> FitResult:
    """Fit robot configurations to adapted marker trajectories, frame by frame.

    Args:
        robot: an ``imesh.robot.Robot``.
        markers: adapted marker motion (T frames); missing samples are skipped per frame.
        keypoints: (marker, frame, offset [m], weight) entries (``KeypointTarget`` or plain
            tuples, or ``{marker: imesh.robot.Keypoint}``); None takes the robot's markers.toml
            (``robot.markers``, including the markers its arrangement adds).
        directions: (frame, axis, from marker, to marker, weight) entries
            (``DirectionTarget``, tuples or ``imesh.robot.Direction``); None takes the robot's
            markers.toml; ``[]`` fits positions only.
        config: settings (FitConfig()).
        q_init: initial guess: (nq,) for frame 0 (replaces the geometric guess), or (T, nq) /
            a RobotMotion giving every frame's starting point (e.g. a previous fit to refine;
            joints are clipped into each frame's box).
        obstacles: capsules moving over the T frames that the robot's capsules keep
            ``config.collision_margin_m`` from, as from each other (a partner robot's,
            :func:`imesh.robot.capsules.obstacles.robot_obstacles`); None: none.

    Returns:
        FitResult with the RobotMotion (same fps as ``markers``) and per-frame errors, bound
        activity and timing.

    Raises:
        MissingMarkerError: a key point or direction names a marker the motion lacks.
        UnknownFrameError: ... or a frame the robot lacks (both list valid names).
        FitError: inconsistent or empty limits, a nominal / initial pose outside the joint
            limits (names the joint, its limits and the value), a bad q_init or config,
            obstacles over another number of frames.
    """
    config = config or FitConfig()
    if obstacles is not None and obstacles.n_frames != markers.n_frames:
        raise FitError(f"obstacles over {obstacles.n_frames} frames for a motion of "
                       f"{markers.n_frames}: give them over the fitted frames")
    targets = compile_targets(robot, markers.names, keypoints, directions,
                              source=markers.source or "motion")
    limits = joint_limits(robot, config.limits)
    n_frames = markers.n_frames
    init = _as_q_init(q_init, n_frames, robot.nq)
    kin = Kinematics(robot, targets)
    q0 = _first_configuration(robot, kin, targets, markers, init, limits)

    frames = FrameTargets.build(markers, targets, config)
    problem = FitProblem.build(robot, kin, config, limits.lower, limits.upper, markers.fps,
                               obstacles)
    limited = bool(np.any(np.isfinite(limits.v_max)) or np.any(np.isfinite(limits.a_max)))
    options = config.limits
    t_start = time.perf_counter()
    fresh = None
    if np.isfinite(config.restart_rms_m) and (init is None or init.ndim == 1):
        q_nominal = np.asarray(robot.q_nominal, dtype=np.float64).copy()
        q_nominal[7:] = problem.q_posture
        fresh = frame_guesses(robot, kin, targets, frames.kp_pos, frames.kp_ok, q_nominal)
    if config.lookahead and limited and n_frames >= 3:
        # the markers with the position limits only (per-frame box), then the joint trajectory
        # projected onto all the limits over the whole clip (feasible.py): it satisfies Kim's
        # eqs 9, 13 and 14 in every frame and brakes ahead of fast target motion
        position_only = IncrementBox.build(limits.position_only(), markers.fps,
                                           options.brake_before_limits)
        free = track(problem, frames, position_only, q0, init, fresh)
        projection = project_joint_trajectory(free.q[:, 7:], markers.fps, limits.lower,
                                              limits.upper, limits.v_max, limits.a_max)
        out = _limited(kin, frames, free, projection.q, limits, markers.fps)
    else:
        out = track(problem, frames, IncrementBox.build(limits, markers.fps,
                                                        options.brake_before_limits),
                    q0, init, fresh)
    seconds = time.perf_counter() - t_start
    result = _result(robot, markers, targets, config, out, seconds)
    if out.empty:
        log.warning("%s: %d of %d frames had no valid marker to fit (kept the warm start)",
                    markers.source or "motion", out.empty, n_frames)
    s = result.summary()
    log.info("fit %s to %s: %d frames, key-point RMS %.2f mm, %.2f iterations/frame, "
             "%.3f ms/frame, frames at position/velocity/acceleration bounds %d/%d/%d, "
             "conflicts %d, restarts %d", robot.name, markers.source or "motion", n_frames,
             s["marker_rms_mm"], s["mean_iterations"], 1e3 * result.seconds_per_frame,
             s["frames_at_position_bound"], s["frames_at_velocity_bound"],
             s["frames_at_acceleration_bound"], s["conflict_frames"], out.restarts)
    return result


def _first_configuration(robot, kin: Kinematics, targets: CompiledTargets,
                         markers: MarkerMotion, init: np.ndarray | None,
                         limits: JointLimits) -> np.ndarray:
    """(nq,) start of frame 0: ``init``'s (checked against the position limits, eq. 9), else
    the geometric guess from the nominal pose (checked likewise)."""
    if init is not None:
        q0 = init if init.ndim == 1 else init[0]
        check_within(robot, q0, limits, "the initial configuration q_init")
        return q0
    q_nominal = np.asarray(robot.q_nominal, dtype=np.float64)
    check_within(robot, q_nominal, limits, "the nominal pose q_nominal")
    return initial_guess(robot, kin, targets, markers, q_nominal)


def _result(robot, markers: MarkerMotion, targets: CompiledTargets, config: FitConfig,
            out: Track, seconds: float) -> FitResult:
    """The FitResult of the final pass ``out`` of the frame loop, which took ``seconds`` [s]."""
    kp_err = out.kp_err
    with np.errstate(invalid="ignore"):
        counts = np.isfinite(kp_err).sum(axis=1)
        sq = np.where(np.isfinite(kp_err), kp_err**2, 0.0).sum(axis=1)
        rms = np.where(counts > 0, np.sqrt(sq / np.maximum(counts, 1)), np.nan)
        kmax = np.where(counts > 0, np.nanmax(np.where(np.isfinite(kp_err), kp_err, -1.0),
                                              axis=1), np.nan)
    motion = RobotMotion(q=out.q, fps=markers.fps, robot=robot.name,
                         joint_names=tuple(robot.joint_names))
    return FitResult(
        motion=motion, keypoints=targets.keypoints, directions=targets.directions,
        keypoint_error_m=kp_err, keypoint_rms_m=rms, keypoint_max_m=kmax,
        direction_error_deg=out.dir_err, iterations=out.iterations,
        at_position_bound=out.at_bound[:, POSITION], at_velocity_bound=out.at_bound[:, VELOCITY],
        at_acceleration_bound=out.at_bound[:, ACCELERATION], conflict=out.conflict,
        joint_bound_frames=out.joint_bound_frames, seconds_per_frame=seconds / markers.n_frames,
        config=config, restart_frames=out.restarts,
    )
