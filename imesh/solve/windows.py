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

Memory is that of one window; time is linear in the frames.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable

import numpy as np

from ..errors import OptionError
from .problem import Plan, WholeBodyConfig
from .sqp import IterationReport, WholeBodySolution, solve_whole_body

log = logging.getLogger(__name__)

#: Frames a window holds at the previous window's solution: the evaluator's ZMP (gradient of
#: gradient) reaches two frames back, so the first two are measured one-sidedly and the next
#: two as the evaluator does.
FIXED_FRAMES = 4


def window_layout(n_frames: int, window_frames: int, overlap_frames: int,
                  fixed_frames: int = FIXED_FRAMES) -> list[tuple[int, int, int]]:
    """(start, stop, keep) per window, of equal lengths at most ``window_frames``: window k
    solves [start, stop), its result is kept on [start + fixed, keep) (from 0 for the first),
    and window k + 1 starts at ``keep - fixed``.

    Raises:
        OptionError: a window too short for its overlap and fixed frames.
    """
    step_cost = overlap_frames + fixed_frames
    if window_frames < 2 * step_cost:
        raise OptionError("window_frames", window_frames,
                          f"at least twice overlap + fixed frames ({2 * step_cost})")
    if n_frames <= window_frames:
        return [(0, n_frames, n_frames)]
    n = 1 + math.ceil((n_frames - window_frames) / (window_frames - step_cost))
    length = math.ceil((n_frames + (n - 1) * step_cost) / n)
    layout, start = [], 0
    for k in range(n):
        stop = n_frames if k == n - 1 else min(n_frames, start + length)
        keep = stop if stop == n_frames else stop - overlap_frames
        layout.append((start, stop, keep))
        start = keep - fixed_frames
    return layout


def plan_window(plan: Plan, start: int, stop: int, *, fixed_frames: int = 0,
                rest_ends: tuple[bool, bool] = (True, True),
                q_start: np.ndarray | None = None) -> Plan:
    """The frames [start, stop) of a plan (its half-planes renumbered), holding the first
    ``fixed_frames`` at ``q_start``."""
    hp_frame, hp_n, hp_b = plan.halfplanes
    sel = (hp_frame >= start) & (hp_frame < stop)
    part = slice(start, stop)
    return dataclasses.replace(
        plan, marker_points=plan.marker_points[part], mesh_metric=plan.mesh_metric[part],
        target_directions=plan.target_directions[part], support=plan.support[part],
        sole_targets=plan.sole_targets[part],
        halfplanes=(hp_frame[sel] - start, hp_n[sel], hp_b[sel]),
        desired_zmp=plan.desired_zmp[part], q_init=plan.q_init[part],
        clearance=None if plan.clearance is None else plan.clearance[part],
        fixed_frames=fixed_frames, rest_ends=rest_ends, q_start=q_start)


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


def solve_windowed(robot, plan: Plan, footprints: list, targets, config: WholeBodyConfig,
                   window_frames: int, overlap_frames: int,
                   progress: Callable[[int, int, str], None] | None = None
                   ) -> WholeBodySolution:
    """The whole-body solve of ``plan`` in windows (module docstring).

    Args:
        robot, plan, footprints, targets, config: as :func:`imesh.solve.solve_whole_body`.
        window_frames: largest window [frames].
        overlap_frames: frames at a window's end solved again by the next window.
        progress: called as ``progress(frames done, frames, text)`` after every SQP iteration.

    Returns:
        A WholeBodySolution of all frames; its history is the windows' iterates in order, the
        first and the last entry combined over the windows (:func:`_combine`).
    """
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
                          rest_ends=(k == 0, k == len(layout) - 1), q_start=q_start)
        done_before = start + (FIXED_FRAMES if k else 0)

        def tick(it: int, total: int, k=k, start=start, keep=keep, done=done_before) -> None:
            if progress is not None:
                progress(done + (keep - done) * it // total, T,
                         f"window {k + 1}/{len(layout)}, SQP iteration {it}")

        sol = solve_whole_body(robot, sub, footprints, targets, config, progress=tick)
        lo = FIXED_FRAMES if k else 0
        q[start + lo:keep] = sol.q[lo:keep - start]
        prev = (start, stop, sol.q)
        first.append(sol.history[0])
        last.append(sol.history[-1])
        iterates += sol.history[1:]
        kept.append(keep - start - lo)
        converged &= sol.converged
        for key, v in sol.seconds.items():
            seconds[key] = seconds.get(key, 0.0) + v
        if progress is not None:
            progress(keep, T, f"window {k + 1}/{len(layout)} done")
        log.info("whole-body window %d/%d: frames [%d, %d) kept to %d, %d iterations, %s",
                 k + 1, len(layout), start, stop, keep, len(sol.history) - 1,
                 "converged" if sol.converged else "not converged")
    history = [_combine(first, kept), *iterates[:-1], _combine(last, kept)]
    seconds["windows"] = len(layout)
    return WholeBodySolution(q=q, footprints=footprints, plan=plan, history=history,
                             converged=converged, seconds=seconds, config=config)
