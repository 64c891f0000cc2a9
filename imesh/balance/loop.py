"""The balance loop (Nakaoka & Komura 2012, sec. V-C, V-D): desired ZMP -> Nishiwaki waist
correction -> a motion with the corrected waist -> ZMP again; until the ZMP error is below
tolerance or an iteration limit.

This module owns the loop and its report; producing the motion for a corrected waist is a
callable supplied by the pipeline (:func:`imesh.pipeline.retarget.retarget`,
``balance="nishiwaki"``): the paper's way, the corrected waist as a target of the morph and a new
fit. It is kept as the paper's mode; the default balance is the whole-body solve
(:mod:`imesh.solve`), which holds the ZMP, the footprints and the limits in one problem.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..contacts.phases import runs
from ..core.checks import require_count, require_finite
from ..errors import ImeshError, OptionError, SolverError
from ..human.filtering import lowpass_array
from ..metrics.soles import sole_tracks
from ..metrics.zmp import zmp_report, zmp_trajectory
from .nishiwaki import nishiwaki_correction

log = logging.getLogger(__name__)


class FlightPhaseError(ImeshError):
    """The motion has flight phases (both feet off the ground): the ZMP is undefined there.

    Attributes:
        phases: [(start, stop), ...] frame ranges (stop exclusive) of the flight phases.
    """

    def __init__(self, source: str, phases: list[tuple[int, int]], fps: float):
        self.phases = phases
        spans = ", ".join(f"frames {a}-{b - 1} ({a / fps:.2f}-{(b - 1) / fps:.2f} s)"
                          for a, b in phases)
        super().__init__(f"{source}: {len(phases)} flight phase(s) (both feet off the ground): "
                         f"{spans}. Balance needs ground contact; pass --allow-flight "
                         "(RetargetConfig(allow_flight=True)) to leave those frames without "
                         "support and ZMP constraints, or --balance none")


@dataclass(frozen=True)
class ConvergenceConfig:
    """When the balance loop stops.

    Attributes:
        iterations: largest number of waist corrections (each one morph and one fit).
        tolerance_mm: stop when the RMS distance between the multibody ZMP and the desired ZMP
            over the support frames is below this [mm] ...
        inside_target: ... and at least this fraction of the support frames has its ZMP inside
            the support polygon.
    """

    iterations: int = 10
    tolerance_mm: float = 10.0
    inside_target: float = 0.99

    def __post_init__(self) -> None:
        require_count(self, ("iterations",), minimum=0)
        require_finite(self, ("tolerance_mm",), positive=True)
        if not 0.0 <= self.inside_target <= 1.0:
            raise OptionError("inside_target", self.inside_target, "a fraction in [0, 1]")


@dataclass(frozen=True)
class BalanceConfig:
    """Settings of the balance loop.

    Attributes:
        convergence: when the loop stops.
        gain: fraction of the Nishiwaki correction applied per iteration (the CoM moves less
            than the waist; the iteration makes up the rest).
        transition_s: blending time of the desired ZMP between support phases [s].
        allow_flight: balance only the supported segments of a motion with flight phases
            instead of refusing it.
        error_lowpass_hz: the ZMP error is low-passed (zero phase) at this frequency before the
            Nishiwaki solve [Hz]; None: no filter. Each re-fit adds frame-to-frame jitter,
            which the correction would chase: the pipeline uses ~1.5 Hz.
        waist_weight: weight of the corrected waist position in the morph (a soft target as
            strong as the support-foot footprints; the Laplacian rows weigh ~1).
    """

    convergence: ConvergenceConfig = field(default_factory=ConvergenceConfig)
    gain: float = 1.0
    transition_s: float = 0.1
    allow_flight: bool = False
    error_lowpass_hz: float | None = None
    waist_weight: float = 1e3

    def __post_init__(self) -> None:
        require_finite(self, ("gain", "transition_s"), positive=True)


@dataclass(frozen=True)
class BalanceIteration:
    """ZMP state of one iterate (0 = before any correction).

    Attributes:
        iteration: 0 for the unbalanced motion, k after k corrections.
        zmp_error_mm: RMS |ZMP - desired ZMP| over the support frames [mm].
        zmp_inside_fraction: support frames with the ZMP inside the support polygon.
        max_outside_mm: largest distance of an outside ZMP from its polygon [mm].
        waist_shift_mm: largest horizontal waist shift from the unbalanced motion [mm].
        seconds: wall time of the morph and fit that produced this iterate [s].
    """

    iteration: int
    zmp_error_mm: float
    zmp_inside_fraction: float
    max_outside_mm: float
    waist_shift_mm: float
    seconds: float


@dataclass(frozen=True, eq=False)
class BalanceResult:
    """Outcome of the loop (the motion it returns is the best iterate).

    Attributes:
        iterations: per-iterate reports, the first is the unbalanced motion.
        best: index into ``iterations`` of the returned motion.
        converged: the tolerance was met.
        q: (T, nq) configurations of the best iterate.
        zmp_m, desired_m: (T, 2) [m] multibody and desired ZMP of the best iterate.
        zmp_before_m: (T, 2) [m] multibody ZMP of the unbalanced motion.
        com_m, com_before_m: (T, 3) [m] CoM of the best iterate and of the unbalanced motion.
        waist_shift_m: (T, 2) [m] horizontal waist correction of the best iterate.
        support: (T, 2) bool planned support.
        polygon_xy: per frame the (K, 2) support polygon (None without support).
        fps: frame rate [1/s].
    """

    iterations: tuple[BalanceIteration, ...]
    best: int
    converged: bool
    q: np.ndarray
    zmp_m: np.ndarray
    desired_m: np.ndarray
    zmp_before_m: np.ndarray
    com_m: np.ndarray
    com_before_m: np.ndarray
    waist_shift_m: np.ndarray
    support: np.ndarray
    polygon_xy: list
    fps: float

    @property
    def before(self) -> BalanceIteration:
        return self.iterations[0]

    @property
    def after(self) -> BalanceIteration:
        return self.iterations[self.best]

    def report(self) -> dict:
        """JSON-able summary with the per-iteration table."""
        return {
            "converged": self.converged,
            "iterations_run": len(self.iterations) - 1,
            "best_iteration": self.iterations[self.best].iteration,
            "zmp_error_mm_before": self.before.zmp_error_mm,
            "zmp_error_mm_after": self.after.zmp_error_mm,
            "zmp_inside_fraction_before": self.before.zmp_inside_fraction,
            "zmp_inside_fraction_after": self.after.zmp_inside_fraction,
            "per_iteration": [vars(it) for it in self.iterations],
        }


@dataclass(frozen=True, eq=False)
class ZmpState:
    """Multibody ZMP, desired ZMP and CoM of a motion against a planned support."""

    zmp_m: np.ndarray
    desired_m: np.ndarray
    com_m: np.ndarray
    error_mm: float
    inside_fraction: float
    max_outside_mm: float
    polygons: list


def zmp_state(robot, q: np.ndarray, fps: float, support: np.ndarray,
              transition_s: float = 0.1) -> ZmpState:
    """ZMP of a configuration trajectory (pinocchio centroidal dynamics) against a support.

    Args:
        robot: an :class:`imesh.robot.Robot`.
        q: (T, nq) configurations.
        fps: frame rate [1/s].
        support: (T, 2) bool planned support [left, right].
        transition_s: desired-ZMP blending time [s].
    """
    zmp = zmp_trajectory(robot, q, fps)
    soles = sole_tracks(robot, q, fps)
    rep = zmp_report(zmp, soles, support, transition_s)
    com = np.array([robot.com(qt) for qt in q])
    return ZmpState(zmp_m=zmp, desired_m=rep.desired_m, com_m=com, error_mm=rep.error_mm,
                    inside_fraction=rep.inside_fraction, max_outside_mm=rep.max_outside_mm,
                    polygons=rep.polygons)


def check_flight(source: str, support: np.ndarray, fps: float, config: BalanceConfig) -> None:
    """Raise FlightPhaseError when no foot supports in some frames (unless allowed)."""
    flight = ~np.asarray(np.asarray(support, dtype=bool).any(axis=1))
    phases = runs(flight)
    if phases and not config.allow_flight:
        raise FlightPhaseError(source, phases, fps)


def balance_loop(robot, q: np.ndarray, fps: float, support: np.ndarray, waist_xy: np.ndarray,
                 step: Callable[[np.ndarray], np.ndarray],
                 config: BalanceConfig | None = None) -> BalanceResult:
    """Iterate Nishiwaki waist corrections until the ZMP follows the desired ZMP.

    Args:
        robot: the robot.
        q: (T, nq) the unbalanced motion.
        fps: frame rate [1/s].
        support: (T, 2) bool planned support (the hard support-foot constraints' phases).
        waist_xy: (T, 2) [m] horizontal waist (pelvis marker) trajectory of the unbalanced
            adapted markers.
        step: ``step(waist_target_xy) -> q``: morph with the waist marker's horizontal position
            as a hard constraint, fit again, return the new (T, nq) motion.
        config: BalanceConfig.

    Returns:
        BalanceResult (its ``q`` is the best iterate: the lowest ZMP error).
    """
    config = config or BalanceConfig()
    support = np.asarray(support, dtype=bool)
    free = ~np.asarray(support.any(axis=1))
    state0 = zmp_state(robot, q, fps, support, config.transition_s)
    states = [state0]
    qs = [q]
    shifts = [np.zeros_like(waist_xy)]
    reports = [BalanceIteration(0, state0.error_mm, state0.inside_fraction,
                                state0.max_outside_mm, 0.0, 0.0)]
    target = np.asarray(waist_xy, dtype=np.float64).copy()

    stop = config.convergence

    def good(s: ZmpState) -> bool:
        return s.error_mm <= stop.tolerance_mm and s.inside_fraction >= stop.inside_target

    state = state0
    worse = 0
    log.info("balance: before: ZMP error %.1f mm, inside %.1f %%", state0.error_mm,
             100 * state0.inside_fraction)
    for k in range(1, stop.iterations + 1):
        if good(state):
            break
        t0 = time.perf_counter()
        com = state.com_m
        zdd = np.gradient(np.gradient(com[:, 2], 1.0 / fps), 1.0 / fps)
        change = np.where(free[:, None], 0.0, state.desired_m - state.zmp_m)
        if config.error_lowpass_hz is not None and config.error_lowpass_hz < 0.5 * fps:
            smooth = lowpass_array(change, fps, config.error_lowpass_hz, order=2)
            change = change if smooth is None else smooth
        dx = nishiwaki_correction(config.gain * change, com[:, 2], zdd, fps, free=free)
        target = target + dx
        try:
            q_new = step(target)
        except SolverError as exc:
            # the morph cannot meet this waist correction (hard constraints inconsistent with
            # it); any other error is a bug or bad input and propagates
            log.warning("balance: iteration %d failed (%s); keeping the best iterate", k, exc)
            break
        state = zmp_state(robot, q_new, fps, support, config.transition_s)
        shift = target - waist_xy
        reports.append(BalanceIteration(k, state.error_mm, state.inside_fraction,
                                        state.max_outside_mm,
                                        float(1e3 * np.abs(shift).max()),
                                        time.perf_counter() - t0))
        states.append(state)
        qs.append(q_new)
        shifts.append(shift)
        # diverging (the ZMP of the fitted motion does not follow the cart-table model): stop
        worse = worse + 1 if not state.error_mm < states[-2].error_mm else 0
        log.info("balance: iteration %d: ZMP error %.1f mm, inside %.1f %%, waist shift up to "
                 "%.0f mm (%.2f s)", k, state.error_mm, 100 * state.inside_fraction,
                 reports[-1].waist_shift_mm, reports[-1].seconds)
        if worse >= 2:
            log.warning("balance: the ZMP error grew in two iterations in a row; stopping")
            break
    # the best iterate: the lowest ZMP error among those that keep at least the unbalanced
    # motion's inside fraction (the loop must not trade one for the other)
    def key(i: int) -> float:
        ok = not (states[i].inside_fraction < state0.inside_fraction)
        return states[i].error_mm if ok and np.isfinite(states[i].error_mm) else np.inf

    best = min(range(len(states)), key=key)
    if not np.isfinite(key(best)):
        best = 0
    s = states[best]
    return BalanceResult(iterations=tuple(reports), best=best, converged=good(s), q=qs[best],
                         zmp_m=s.zmp_m, desired_m=s.desired_m, zmp_before_m=state0.zmp_m,
                         com_m=s.com_m, com_before_m=state0.com_m, waist_shift_m=shifts[best],
                         support=support, polygon_xy=s.polygons, fps=fps)
