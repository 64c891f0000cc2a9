"""The whole-body solve of a long clip in overlapping windows of bounded length.

One SQP over all frames costs memory in proportion to the clip and iterates until its worst
frame converges. A long clip is therefore solved window by window (:func:`solve_windowed`):
the plan (footprints, support polygons, desired ZMP, targets) is made once for the whole clip,
so a support phase across a window border has one footprint; each window is a slice of it
(:func:`plan_window`) and an SQP of its own. Window k + 1 starts ``fixed_frames`` frames before
the end of what window k keeps, and those frames are held at window k's solution (the QP's
bounds): positions, velocities and accelerations run on across the border, and the
finite-difference ZMP and torques of the first free frames are measured with the previous
window's frames, as the evaluator measures them. The ``overlap_frames`` at the end of window k
that window k + 1 solves again are not kept: near its free end a window's differences are
one-sided. Window k + 1 starts its SQP from window k's solution where it has one.

Every window but the last has the same length (:func:`window_layout`), so memory is that of
one window and time is linear in the frames.

Both cores (``workers=2``): the first half of the clip is solved as such a chain of windows in
this process while a spawned process solves the second half's chain, which starts from the
initializer with a free first frame. One join window across the middle (:func:`join_layout`)
then holds its first ``fixed_frames`` at the first chain's solution and its last at the
second's (``Plan.fixed_end_frames``), starting from both chains' solutions (crossfaded where
the chains overlap, about the middle); what it solves replaces the chains' free ends.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import multiprocessing
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from ..errors import OptionError
from ..robot import load_robot
from .config import WholeBodyConfig, WindowOptions
from .plan import Plan
from .sqp import IterationReport, WholeBodySolution, solve_whole_body

log = logging.getLogger(__name__)

#: Frames a window holds at the previous window's solution: the evaluator's ZMP (gradient of
#: gradient) reaches two frames back, so the first two are measured one-sidedly and the next
#: two as the evaluator does.
FIXED_FRAMES = 4


def window_layout(n_frames: int, window_frames: int, overlap_frames: int,
                  fixed_frames: int = FIXED_FRAMES) -> list[tuple[int, int, int]]:
    """(start, stop, keep) per window: window k solves [start, stop), its result is kept on
    [start + fixed, keep) (from 0 for the first), and window k + 1 starts at ``keep - fixed``.

    Every window is ``window_frames`` long but the last, so the cost per frame does not follow
    the clip's length (equal windows of 450-900 frames made the time grow as frames^1.05). A
    last window shorter than half a window is folded: into the one before it where both fit in
    one window, else the last two share their frames equally (each longer than half a window).
    A clip of at most ``window_frames`` frames is one window.

    Raises:
        OptionError: a window too short for its overlap and fixed frames.
    """
    step_cost = overlap_frames + fixed_frames
    if window_frames < 2 * step_cost:
        raise OptionError("window_frames", window_frames,
                          f"at least twice overlap + fixed frames ({2 * step_cost})")
    if n_frames <= window_frames:
        return [(0, n_frames, n_frames)]
    step = window_frames - step_cost
    n = 1 + math.ceil((n_frames - window_frames) / step)
    bounds = [(k * step, min(k * step + window_frames, n_frames)) for k in range(n)]
    if 2 * (n_frames - bounds[-1][0]) < window_frames:
        first = bounds[-2][0]
        rest = n_frames - first
        if rest <= window_frames:
            bounds[-2:] = [(first, n_frames)]
        else:
            length = math.ceil((rest + step_cost) / 2)
            bounds[-2:] = [(first, first + length), (first + length - step_cost, n_frames)]
    return [(a, b, b if b == n_frames else b - overlap_frames) for a, b in bounds]


def plan_window(plan: Plan, start: int, stop: int, *, fixed_frames: int = 0,
                rest_ends: tuple[bool, bool] = (True, True),
                q_start: np.ndarray | None = None, fixed_end_frames: int = 0) -> Plan:
    """The frames [start, stop) of a plan (its half-planes renumbered), holding the first
    ``fixed_frames`` and the last ``fixed_end_frames`` at ``q_start``."""
    hp_frame, hp_n, hp_b = plan.halfplanes
    sel = (hp_frame >= start) & (hp_frame < stop)
    part = slice(start, stop)
    return dataclasses.replace(
        plan, marker_points=plan.marker_points[part], mesh_metric=plan.mesh_metric[part],
        target_directions=plan.target_directions[part], support=plan.support[part],
        sole_targets=plan.sole_targets[part],
        halfplanes=(hp_frame[sel] - start, hp_n[sel], hp_b[sel]),
        desired_zmp=plan.desired_zmp[part], zmp_weights=plan.zmp_weights[part],
        q_init=plan.q_init[part],
        clearance=None if plan.clearance is None else plan.clearance[part],
        normal_max=None if plan.normal_max is None else plan.normal_max[part],
        kinetic=None if plan.kinetic is None else plan.kinetic[part],
        points=(None if plan.points is None
                else dataclasses.replace(plan.points, active=plan.points.active[part])),
        cones=None if plan.cones is None else plan.cones.window(start, stop),
        obstacles=None if plan.obstacles is None else plan.obstacles.frames(start, stop),
        fixed_frames=fixed_frames, rest_ends=rest_ends, q_start=q_start,
        fixed_end_frames=fixed_end_frames)


def _combine(reports: list[IterationReport], frames: list[int]) -> IterationReport:
    """One report of the whole trajectory from the windows' (worst of each figure, the RMS
    over frames, the QP's time and iterations summed)."""
    w = np.asarray(frames, dtype=float)
    return IterationReport(
        step=max(r.step for r in reports),
        sole_error_m=max(r.sole_error_m for r in reports),
        sole_error_rad=max(r.sole_error_rad for r in reports),
        lowest_swing_m=min(r.lowest_swing_m for r in reports),
        zmp_outside_m=max(r.zmp_outside_m for r in reports),
        velocity_ratio=max(r.velocity_ratio for r in reports),
        acceleration_ratio=max(r.acceleration_ratio for r in reports),
        keypoint_rms_m=float(np.sqrt(np.sum(w * np.array([r.keypoint_rms_m for r in reports])
                                            ** 2) / w.sum())),
        qp_seconds=sum(r.qp_seconds for r in reports),
        qp_iterations=sum(r.qp_iterations for r in reports))


@dataclasses.dataclass(frozen=True, eq=False)
class _Chain:
    """The windows of one chain solved one after the other (:func:`_solve_chain`).

    Attributes:
        q: (n, nq) the chain's trajectory: every frame solved, the free ends' overlap included.
        first, last: each window's first and last IterationReport.
        iterates: every window's iterates after its first, in order.
        kept: (start, keep) of each window's kept frames in the chain's numbering.
        seconds: the windows' times summed, per key of WholeBodySolution.seconds.
        converged: every window converged.
    """

    q: np.ndarray
    first: list
    last: list
    iterates: list
    kept: list
    seconds: dict
    converged: bool


def _solve_chain(robot, plan: Plan, footprints: list, targets, config: WholeBodyConfig,
                 window_frames: int, overlap_frames: int,
                 progress: Callable[[int, int, str], None] | None = None,
                 name: str = "") -> _Chain:
    """The windows of ``plan`` (a whole clip or a slice of it, its rest ends already set) in
    order, each starting on the previous one's solution (module docstring)."""
    T = len(plan.q_init)
    layout = window_layout(T, window_frames, overlap_frames)
    q = plan.q_init.copy()
    first, last, iterates, kept = [], [], [], []
    seconds: dict[str, float] = {}
    converged = True
    prev = None  # (start, stop, solution) of the previous window
    for k, (start, stop, keep) in enumerate(layout):
        q_start = plan.q_init[start:stop].copy()
        if prev is not None:
            p_start, p_stop, p_q = prev
            q_start[:p_stop - start] = p_q[start - p_start:]
        sub = plan_window(plan, start, stop, fixed_frames=FIXED_FRAMES if k else 0,
                          rest_ends=(k == 0 and plan.rest_ends[0],
                                     k == len(layout) - 1 and plan.rest_ends[1]),
                          q_start=q_start)
        done_before = start + (FIXED_FRAMES if k else 0)

        def tick(it: int, total: int, k=k, keep=keep, done=done_before) -> None:
            if progress is not None:
                progress(done + (keep - done) * it // total, T,
                         f"{name}window {k + 1}/{len(layout)}, SQP iteration {it}")

        sol = solve_whole_body(robot, sub, footprints, targets, config, progress=tick)
        lo = FIXED_FRAMES if k else 0
        # the last window's free end too: a chain's caller decides what it keeps of it
        upto = stop if k == len(layout) - 1 else keep
        q[start + lo:upto] = sol.q[lo:upto - start]
        prev = (start, stop, sol.q)
        first.append(sol.history[0])
        last.append(sol.history[-1])
        iterates += sol.history[1:]
        kept.append((start + lo, keep))
        converged &= sol.converged
        for key, v in sol.seconds.items():
            seconds[key] = seconds.get(key, 0.0) + v
        if progress is not None:
            progress(keep, T, f"{name}window {k + 1}/{len(layout)} done")
        log.info("whole-body %swindow %d/%d: frames [%d, %d) kept to %d, %d iterations, %s",
                 name, k + 1, len(layout), start, stop, keep, len(sol.history) - 1,
                 "converged" if sol.converged else "not converged")
    return _Chain(q=q, first=first, last=last, iterates=iterates, kept=kept, seconds=seconds,
                  converged=converged)


def _robot_source(robot) -> tuple[str, str | None]:
    """How a worker process loads the same robot: its robot.toml and, for a model the user
    provides, the URDF (a pinocchio model is not sent between processes)."""
    urdf = str(robot.urdf) if robot.config.model.source == "user" else None
    return str(robot.config.path), urdf


def _chain_in_worker(robot_source: tuple[str, str | None], plan: Plan, footprints: list,
                     targets, config: WholeBodyConfig, window_frames: int,
                     overlap_frames: int, log_level: int = logging.WARNING) -> _Chain:
    """:func:`_solve_chain` in a worker process, the robot loaded there; its log records go to
    the worker's stderr (the caller's) at the caller's level of ``imesh``."""
    if not logging.getLogger().handlers:  # a spawned process starts without the caller's
        logging.basicConfig(format="%(levelname)s %(name)s: %(message)s")
    logging.getLogger("imesh").setLevel(log_level)
    toml, urdf = robot_source
    return _solve_chain(load_robot(toml, urdf=urdf), plan, footprints, targets, config,
                        window_frames, overlap_frames, name="chain 2 ")


def join_layout(n_frames: int, window_frames: int, overlap_frames: int,
                fixed_frames: int = FIXED_FRAMES) -> tuple[int, int, int, int]:
    """Where two chains of windows and the window joining them lie: (chain 1's stop, chain
    2's start, join start, join stop). Chain 1 solves [0, stop1), chain 2 [start2, n); the
    join window [j0, j1) (``min(window, 2 (overlap + fixed))`` frames about the middle) holds
    its first ``fixed_frames`` at chain 1's solution and its last at chain 2's, both at least
    ``overlap_frames`` away from the chains' free ends; the chains overlap by about
    ``overlap_frames`` about the middle, where the join starts from a :func:`crossfade` of
    the two.

    Raises:
        OptionError: a clip too short for two chains (not longer than one window).
    """
    if n_frames <= window_frames:
        raise OptionError("workers", 2, f"1 for a solve of at most window_frames "
                          f"({window_frames}) frames: it is one window")
    step_cost = overlap_frames + fixed_frames
    join = min(window_frames, 2 * step_cost)
    middle = n_frames // 2
    j0 = middle - join // 2
    j1 = j0 + join
    half = overlap_frames // 2
    return max(middle + half, j0 + step_cost), min(middle - half, j1 - step_cost), j0, j1


def crossfade(robot, q_a: np.ndarray, q_b: np.ndarray) -> np.ndarray:
    """(n, nq) configurations going from ``q_a`` to ``q_b`` over their n common frames:
    ``q_a,t (+) s_t (q_b,t (-) q_a,t)`` (the robot's ``integrate`` and ``difference``, so the
    base turns along the geodesic whatever the quaternions' signs), the weight ``s`` rising
    as a smoothstep ``3 x^2 - 2 x^3`` (zero slope at both ends)."""
    n = len(q_a)
    x = (np.arange(n) + 0.5) / n
    s = x * x * (3.0 - 2.0 * x)
    return np.array([robot.integrate(a, w * robot.difference(a, b))
                     for a, b, w in zip(q_a, q_b, s, strict=True)])


def solve_windowed(robot, plan: Plan, footprints: list, targets, config: WholeBodyConfig,
                   windows: WindowOptions,
                   progress: Callable[[int, int, str], None] | None = None
                   ) -> WholeBodySolution:
    """The whole-body solve of ``plan`` in windows (module docstring).

    Args:
        robot, plan, footprints, targets, config: as :func:`imesh.solve.solve_whole_body`.
        windows: the window length [frames] (:func:`window_layout`), the frames at a window's
            end solved again by the next, and the workers: 1, the windows in order; 2, two
            chains of windows, the first half's in this process and the second half's in a
            spawned one (starting from the initializer), then one window across their border
            held at both ends (:func:`join_layout`).
        progress: called as ``progress(frames done, frames, text)`` after every SQP iteration
            (with two workers: of this process's chain, then of the join).

    Returns:
        A WholeBodySolution of all frames; its history is the windows' iterates in order, the
        first and the last entry combined over the windows (:func:`_combine`).

    Raises:
        OptionError: two workers for a solve of one window.
    """
    window_frames, overlap_frames = windows.frames, windows.overlap_frames
    T = len(plan.q_init)
    if windows.workers == 1:
        chain = _solve_chain(robot, plan, footprints, targets, config, window_frames,
                             overlap_frames, progress)
        parts = [(chain, 0, 0, T)]  # (chain, offset, kept from, kept to) in clip frames
        q, n_windows = chain.q, len(chain.kept)
    else:
        stop1, start2, j0, j1 = join_layout(T, window_frames, overlap_frames)
        plan1 = plan_window(plan, 0, stop1, rest_ends=(plan.rest_ends[0], False))
        plan2 = plan_window(plan, start2, T, rest_ends=(False, plan.rest_ends[1]))
        def tick1(done: int, total: int, text: str) -> None:
            # this process's chain stands for both: the bar reaches the join's start with it
            if progress is not None:
                progress(done * (j0 + FIXED_FRAMES) // total, T, f"two chains: {text}")

        with ProcessPoolExecutor(max_workers=1,
                                 mp_context=multiprocessing.get_context("spawn")) as pool:
            future = pool.submit(_chain_in_worker, _robot_source(robot), plan2, footprints,
                                 targets, config, window_frames, overlap_frames,
                                 log.getEffectiveLevel())
            chain1 = _solve_chain(robot, plan1, footprints, targets, config, window_frames,
                                  overlap_frames, tick1, name="chain 1 ")
            chain2 = future.result()
        q = np.concatenate([chain1.q[:j0 + FIXED_FRAMES],
                            plan.q_init[j0 + FIXED_FRAMES:j1 - FIXED_FRAMES],
                            chain2.q[j1 - FIXED_FRAMES - start2:]])
        # the chains overlap on [start2, stop1), each with its free end there: the join
        # starts on a crossfade from one to the other (starting on a step between them, 0.9
        # rad at the waist on the 60 s dance, left 9.6 times G1's acceleration limit there)
        q_start = np.concatenate([chain1.q[j0:start2],
                                  crossfade(robot, chain1.q[start2:stop1],
                                            chain2.q[:stop1 - start2]),
                                  chain2.q[stop1 - start2:j1 - start2]])
        sub = plan_window(plan, j0, j1, fixed_frames=FIXED_FRAMES, rest_ends=(False, False),
                          q_start=q_start, fixed_end_frames=FIXED_FRAMES)

        def tick_join(it: int, total: int) -> None:
            if progress is not None:
                progress(j0 + FIXED_FRAMES + (j1 - j0 - 2 * FIXED_FRAMES) * it // total, T,
                         f"join window, SQP iteration {it}")

        sol = solve_whole_body(robot, sub, footprints, targets, config, progress=tick_join)
        q[j0 + FIXED_FRAMES:j1 - FIXED_FRAMES] = sol.q[FIXED_FRAMES:-FIXED_FRAMES]
        log.info("whole-body join window: frames [%d, %d), %d iterations, %s", j0, j1,
                 len(sol.history) - 1, "converged" if sol.converged else "not converged")
        join = _Chain(q=sol.q, first=[sol.history[0]], last=[sol.history[-1]],
                      iterates=sol.history[1:], kept=[(FIXED_FRAMES, j1 - j0 - FIXED_FRAMES)],
                      seconds=sol.seconds, converged=sol.converged)
        parts = [(chain1, 0, 0, j0 + FIXED_FRAMES), (chain2, start2, j1 - FIXED_FRAMES, T),
                 (join, j0, j0 + FIXED_FRAMES, j1 - FIXED_FRAMES)]
        n_windows = len(chain1.kept) + len(chain2.kept) + 1
    first, last, iterates, frames = [], [], [], []
    seconds: dict[str, float] = {}
    for chain, offset, lo, hi in parts:
        first += chain.first
        last += chain.last
        iterates += chain.iterates
        # each window's frames in the written trajectory weigh its figures
        frames += [max(min(b + offset, hi) - max(a + offset, lo), 0) for a, b in chain.kept]
        for key, v in chain.seconds.items():
            seconds[key] = seconds.get(key, 0.0) + v
    if progress is not None:
        progress(T, T, f"{n_windows} windows done")
    history = [_combine(first, frames), *iterates[:-1], _combine(last, frames)]
    seconds["windows"] = n_windows
    seconds["workers"] = windows.workers
    return WholeBodySolution(q=q, footprints=footprints, plan=plan, history=history,
                             converged=all(c.converged for c, *_ in parts), seconds=seconds,
                             config=config)
