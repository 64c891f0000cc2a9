"""The frame loop: every frame in order gets its joint box (Kim, Kim & Oh 2005, eqs 9, 13, 14), a
warm start and its damped least-squares solve (Nakaoka & Komura 2012, eq. 7), then the errors
of its targets and the limits it sits on.

The warm start of frame ``i`` is the constant-velocity prediction of frames ``i-2, i-1``
(FitConfig.extrapolate), clipped into the frame's box. The smoothing weight ``mu`` grows with
the previous frame's key-point RMS (FitConfig.adaptive_smoothing); the smoothing and posture
terms are folded into one reference (see :func:`_smoothing`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .config import FitConfig
from .dls import FitProblem, FrameProblem, solve_frame, target_cost
from .limits import IncrementBox
from .residual import FrameTargets


@dataclass(eq=False)
class Track:
    """Output arrays of one pass of the frame loop (T frames, K key points, D directions, n
    joints).

    Attributes:
        q: (T, nq) configurations.
        kp_err: (T, K) key-point errors [m] (NaN where the marker is missing).
        dir_err: (T, D) direction errors [deg] (NaN where a marker is missing).
        iterations: (T,) box-QP solves per frame.
        at_bound: (T, 3) some joint on a bound set by the position / velocity / acceleration
            limit (columns indexed by the codes of :mod:`imesh.fit.limits`).
        conflict: (T,) some joint's boxes did not intersect.
        joint_bound_frames: (n,) per joint, frames in which it sat on any bound.
        empty: frames without any valid marker.
        restarts: frames whose solution came from a restart at their own markers.
    """

    q: np.ndarray
    kp_err: np.ndarray
    dir_err: np.ndarray
    iterations: np.ndarray
    at_bound: np.ndarray
    conflict: np.ndarray
    joint_bound_frames: np.ndarray
    empty: int
    restarts: int = 0


def _warm_start(problem: FitProblem, q_out: np.ndarray, t: int, q0: np.ndarray,
                init: np.ndarray | None, jumped: bool = False) -> np.ndarray:
    """(nq,) starting configuration of frame ``t`` (a new array) from the frames fitted so far
    ``q_out[:t]``, the frame-0 configuration ``q0`` and the optional (T, nq) ``init``.
    ``jumped``: frame ``t - 1`` came from a restart, so frames ``t - 2, t - 1`` are two basins,
    not a velocity: the start is frame ``t - 1`` itself (extrapolating the jump flung the
    base into a third basin: CMU 05_06's penché on G1 turned 100-190 degrees a frame)."""
    robot = problem.robot
    if t == 0:
        q = q0.copy()
    elif init is not None and init.ndim == 2:
        q = init[t].copy()
    elif t >= 2 and problem.config.extrapolate and not jumped:
        q = robot.integrate(q_out[t - 1], robot.difference(q_out[t - 2], q_out[t - 1]))
    else:
        q = q_out[t - 1].copy()
    return np.array(q, dtype=np.float64)


def _smoothing(config: FitConfig, q_posture: np.ndarray, prev_rms: float, q: np.ndarray,
               q_out: np.ndarray, t: int) -> tuple[np.ndarray, float]:
    """(n,) reference q_ref [rad] and weight mu of the joint term of frame ``t``.

    ``mu = mu_0 + k rms_{t-1}`` (FitConfig.smoothing, adaptive_smoothing); frame 0 has no
    previous frame and keeps its start ``q`` as the reference (the term is off there).
    """
    mu = config.smoothing
    if t >= 1 and np.isfinite(prev_rms):
        mu += config.adaptive_smoothing * prev_rms
    if t == 0:
        return q[7:], mu
    # mu^2 |q - q_prev|^2 + eta^2 |q - q_nominal|^2 = (mu^2 + eta^2) |q - q_ref|^2 + c
    mu2, eta2 = mu * mu, config.posture ** 2
    q_ref = (mu2 * q_out[t - 1, 7:] + eta2 * q_posture) / max(mu2 + eta2, 1e-300)
    return q_ref, float(np.sqrt(mu2 + eta2))


def _restart(problem: FitProblem, frame: FrameProblem, q_warm: np.ndarray, fresh: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int] | None:
    """The frame solved again from ``fresh`` (nq,), its start from its own markers
    (:func:`imesh.fit.initial.frame_guesses`), when that finds a better basin than the warm
    start's solution ``q_warm`` (nq,).

    The fresh start is solved without the smoothing term (it would hold the joints to the
    previous frame's basin) and without the base's velocity box, for
    ``FitConfig.restart_iterations`` solves; it wins when its key-point and direction cost
    ``|W e|^2`` (with the self-collision penalty's residuals: a start whose arms pass through
    the torso does not win by its key points) is below ``FitConfig.restart_gain`` times the
    warm one's. The winner is then
    polished with the frame's own problem (smoothing and base box included) and kept unless
    the polish gave the gain back.

    Returns:
        (q, key points, direction axes, solves) of the new solution, or None (keep the warm
        start's).
    """
    config, rows, kin = problem.config, frame.rows, problem.kin
    start = fresh.copy()
    start[7:] = np.clip(start[7:], frame.lo, frame.hi)
    free = FrameProblem(lo=frame.lo, hi=frame.hi, rows=rows, q_ref=start[7:], mu=0.0,
                        max_it=config.restart_iterations, first=True, q_prev=None,
                        index=frame.index)
    q_new, points, axes, it = solve_frame(problem, free, start)
    bound = config.restart_gain * target_cost(problem, frame, q_warm,
                                              *kin.points_and_axes(q_warm))
    if not target_cost(problem, frame, q_new, points, axes) < bound:
        return None
    q_pol, p_pol, a_pol, it_pol = solve_frame(problem, frame, q_new)
    if target_cost(problem, frame, q_pol, p_pol, a_pol) < bound:
        return q_pol, p_pol, a_pol, it + it_pol
    return q_new, points, axes, it + it_pol


def track(problem: FitProblem, frames: FrameTargets, limits: IncrementBox, q0: np.ndarray,
          init: np.ndarray | None, fresh: np.ndarray | None = None) -> Track:
    """Fit every frame in order inside the boxes of ``limits``.

    A frame whose key-point RMS from its warm start stays above ``FitConfig.restart_rms_m`` is
    solved again from ``fresh[t]``, its own markers' geometric start (:func:`_restart`): a
    warm-started damped least-squares iteration only finds the basin it starts in, and after
    a turn or a leap it can follow the markers from the wrong one for the rest of the clip.

    Args:
        problem: what is fixed over the frames.
        frames: the targets of every frame.
        limits: the joint limits in per-frame units.
        q0: (nq,) starting configuration of frame 0.
        init: (T, nq) starting configuration of every frame, or None (warm starts).
        fresh: (T, nq) starts from each frame's own markers for the restarts (NaN rows: none),
            or None (no restarts).

    Returns:
        The configurations, per-frame errors and bound activity.
    """
    config = problem.config
    n_frames = len(frames.kp_pos)
    n_kp, n_dir = frames.kp_pos.shape[1], frames.dir_target.shape[1]
    base_box = config.limits.enforce_velocity and bool(np.isfinite(problem.base_reach).any())
    q_out = np.empty((n_frames, problem.robot.nq))
    kp_err = np.full((n_frames, n_kp), np.nan)
    dir_err = np.full((n_frames, n_dir), np.nan)
    iters = np.zeros(n_frames, dtype=np.int64)
    at_bound = np.zeros((n_frames, 3), dtype=bool)
    conflict = np.zeros(n_frames, dtype=bool)
    joint_bound_frames = np.zeros(len(limits.lower), dtype=np.int64)
    empty = 0
    restarts = 0
    prev_rms = float("nan")
    jumped = False
    for t in range(n_frames):
        box = limits.at(q_out[t - 1, 7:] if t >= 1 else None,
                        q_out[t - 2, 7:] if t >= 2 else None)
        conflict[t] = box.conflict
        q = _warm_start(problem, q_out, t, q0, init, jumped)
        q[7:] = np.clip(q[7:], box.lo, box.hi)
        rows = frames.rows(t)
        if rows.empty:
            empty += 1
        q_ref, mu = _smoothing(config, problem.q_posture, prev_rms, q, q_out, t)
        frame = FrameProblem(
            lo=box.lo, hi=box.hi, rows=rows, q_ref=q_ref, mu=mu,
            max_it=config.first_frame_iterations if t == 0 else config.iterations,
            first=t == 0, q_prev=q_out[t - 1] if t >= 1 and base_box else None, index=t)
        q, points, axes, it = solve_frame(problem, frame, q)
        kp_err[t], dir_err[t] = frames.errors(t, points, axes)
        jumped = False
        if (fresh is not None and t >= 1 and rows.ok_p.any() and np.isfinite(fresh[t]).all()
                and np.sqrt(np.nanmean(kp_err[t] ** 2)) > config.restart_rms_m):
            better = _restart(problem, frame, q, fresh[t])
            if better is not None:
                q, points, axes, it_more = better
                it += it_more
                restarts += 1
                jumped = True
                kp_err[t], dir_err[t] = frames.errors(t, points, axes)
        q_out[t] = q
        iters[t] = it
        if rows.ok_p.any():
            prev_rms = float(np.sqrt(np.nanmean(kp_err[t] ** 2)))
        at_bound[t], on_bound = box.active(q[7:])
        joint_bound_frames += on_bound
    return Track(q=q_out, kp_err=kp_err, dir_err=dir_err, iterations=iters, at_bound=at_bound,
                 conflict=conflict, joint_bound_frames=joint_bound_frames, empty=empty,
                 restarts=restarts)
