"""Joint limits as bounds on each frame's joint values (Kim, Kim & Oh 2005, eqs 9, 13, 14).

The joint part of the cumulative increment ``dq_i = q_i - q_{i-1}`` stays inside the box of Kim
et al. (backward differences, ``dt = 1/fps``):

    position      q_min - q_{i-1}          <= dq_i <= q_max - q_{i-1}           (eq. 9)
    velocity      -dt v_max                <= dq_i <= dt v_max                  (eq. 13, i >= 1)
    acceleration  dt v_{i-1} - dt^2 a_max  <= dq_i <= dt v_{i-1} + dt^2 a_max   (eq. 14, i >= 2)

with ``v_{i-1} = (q_{i-1} - q_{i-2}) / dt``. Frame 0 has only the position box, frame 1 adds the
velocity box (one previous frame), frames >= 2 all three. With ``brake_before_limits`` a fourth,
lowest-priority box keeps each joint slow enough to stop before its position limits at
``a_max``. :class:`IncrementBox` holds the limits of one fit (or of one arm,
:mod:`imesh.arms.solve`) and gives each frame's box.

Conflict policy: the boxes are intersected in priority order position, velocity, acceleration
(then braking). When a lower-priority box does not intersect the running intersection (a joint
moving fast towards its position limit cannot brake within ``a_max``), that joint is pinned to
the point of the running box closest to the dropped box (the least violation of the dropped
limit: maximal braking) and the frame is counted in ``FitResult.conflict_frames``. Position
limits therefore always hold; velocity limits hold whenever the previous frame is inside the
position limits (always after frame 0); acceleration limits hold on every non-conflict frame.
The limits are a :class:`imesh.core.limits.JointLimits`; :func:`joint_limits` reads a robot's
under the switches of :class:`imesh.core.limits.LimitOptions`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.limits import BOUND_TOL, JointLimits, LimitOptions
from .errors import FitError

#: Codes of the limit that set a joint's bound in a frame.
POSITION, VELOCITY, ACCELERATION = 0, 1, 2


def joint_limits(robot, options: LimitOptions) -> JointLimits:
    """The robot's joint limits (Kim eqs 9, 13, 14) under ``options``, validated.

    Args:
        robot: the robot (``joint_names``, ``q_lower``, ``q_upper``, ``v_max``, ``a_max``).
        options: which limits apply; ``acceleration_limit`` replaces the robot's ``a_max``.

    Returns:
        The (n,) limits of the robot's n joints [rad, rad/s, rad/s^2]; inf where unbounded or
        not enforced.

    Raises:
        FitError: a robot without one configuration variable per joint, limits of another
            shape, empty position limits or a non-positive velocity / acceleration limit.
    """
    names = list(robot.joint_names)
    n = len(names)
    if robot.nq - 7 != n or robot.nv - 6 != n:
        raise FitError(
            f"robot {robot.name!r}: fitting needs one configuration variable per joint after "
            f"the free-flyer (nq - 7 == nv - 6 == {n} joint names), got nq={robot.nq}, "
            f"nv={robot.nv}"
        )
    lower = np.asarray(robot.q_lower, dtype=np.float64).reshape(-1)
    upper = np.asarray(robot.q_upper, dtype=np.float64).reshape(-1)
    vmax = np.asarray(robot.v_max, dtype=np.float64).reshape(-1)
    if options.acceleration_limit is not None:
        acc = np.asarray(options.acceleration_limit, dtype=np.float64)
        amax = np.full(n, float(acc)) if acc.ndim == 0 else acc.reshape(-1)
    else:
        amax = np.asarray(robot.a_max, dtype=np.float64).reshape(-1)
    for key, arr in (("q_lower", lower), ("q_upper", upper), ("v_max", vmax), ("a_max", amax)):
        if arr.shape != (n,):
            raise FitError(f"robot {robot.name!r}: {key} has shape {arr.shape}, expected ({n},) "
                           "(one per joint)")
    for j, name in enumerate(names):
        lo, hi = lower[j], upper[j]
        if np.isnan(lo) or np.isnan(hi) or lo > hi:
            raise FitError(f"robot {robot.name!r}: joint {name} has empty position limits "
                           f"[{lo}, {hi}] rad", joint=name, lower=float(lo), upper=float(hi))
        for what, arr in (("velocity limit v_max [rad/s]", vmax),
                          ("acceleration limit a_max [rad/s^2]", amax)):
            if np.isnan(arr[j]) or arr[j] <= 0:
                raise FitError(f"robot {robot.name!r}: joint {name} has {what} {arr[j]}; it must "
                               "be > 0 (inf for unbounded)", joint=name, lower=float(lo),
                               upper=float(hi), value=float(arr[j]))
    if not options.enforce_velocity:
        vmax = np.full(n, np.inf)
    if not options.enforce_acceleration:
        amax = np.full(n, np.inf)
    return JointLimits(lower=lower, upper=upper, v_max=vmax, a_max=amax)


def check_within(robot, q: np.ndarray, limits: JointLimits, what: str) -> None:
    """Raise FitError naming the first joint of ``q`` (nq,) outside the position limits of
    ``limits`` [rad] (eq. 9): the starting pose of frame 0 must lie inside the position box."""
    joints = q[7:]
    lower, upper = limits.lower, limits.upper
    bad = np.flatnonzero((joints < lower - BOUND_TOL) | (joints > upper + BOUND_TOL))
    if bad.size:
        j = int(bad[0])
        name = robot.joint_names[j]
        more = f" (and {bad.size - 1} more joints)" if bad.size > 1 else ""
        raise FitError(
            f"robot {robot.name!r}: {what} puts joint {name} at {joints[j]:.6g} rad, outside its "
            f"limits [{lower[j]:.6g}, {upper[j]:.6g}] rad{more}: frame 0 has no feasible "
            "increment box; fix the limits or the initial pose",
            joint=name, lower=float(lower[j]), upper=float(upper[j]), value=float(joints[j]),
            frame=0,
        )


def braking_reach(room: np.ndarray, brake: np.ndarray) -> np.ndarray:
    """Largest increment x towards a limit ``room`` away after which the joint can still stop
    before the limit with a deceleration of ``brake`` = dt^2 a_max per frame^2.

    Continuous braking distance v^2 / (2 a) with v = x / dt:
    ``x + x^2 / (2 brake) <= room``, so ``x = -brake + sqrt(brake^2 + 2 brake room)``
    (inf where a_max is unbounded, 0 at the limit).
    """
    with np.errstate(invalid="ignore", over="ignore"):
        x = -brake + np.sqrt(brake * brake + 2.0 * brake * np.maximum(room, 0.0))
    return np.where(np.isfinite(brake), x, np.inf)


def intersect(lo: np.ndarray, hi: np.ndarray, src_lo: np.ndarray, src_hi: np.ndarray,
              lo2: np.ndarray, hi2: np.ndarray, code: int
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Intersect box [lo, hi] with [lo2, hi2] (lower priority); pin joints where disjoint.

    Returns new (lo, hi, src_lo, src_hi, conflict mask).
    """
    new_lo = np.maximum(lo, lo2)
    new_hi = np.minimum(hi, hi2)
    src_lo = np.where(lo2 > lo, code, src_lo)
    src_hi = np.where(hi2 < hi, code, src_hi)
    conflict = new_lo > new_hi
    if conflict.any():
        # the point of [lo, hi] closest to the dropped box [lo2, hi2]
        pin = np.where(hi2 < lo, lo, hi)
        new_lo = np.where(conflict, pin, new_lo)
        new_hi = np.where(conflict, pin, new_hi)
        keep_lo = np.where(hi2 < lo, src_lo, src_hi)
        src_lo = np.where(conflict, keep_lo, src_lo)
        src_hi = np.where(conflict, keep_lo, src_hi)
    return new_lo, new_hi, src_lo, src_hi, conflict


@dataclass(frozen=True, eq=False)
class FrameBox:
    """The box of one frame's joint values (absolute, not increments), with the limit that set
    each bound.

    Attributes:
        lo, hi: (n,) absolute joint bounds [rad]: the intersection of Kim's eqs 9, 13, 14 (and
            the braking box).
        posvel_lo, posvel_hi: (n,) the position and velocity bounds only [rad] (eqs 9, 13: the
            time-varying limits of Kim's Fig. 4).
        src_lo, src_hi: (n,) code (POSITION, VELOCITY, ACCELERATION) of the limit that set each.
        conflict: some joint's boxes did not intersect (pinned, see the module's policy).
    """

    lo: np.ndarray
    hi: np.ndarray
    posvel_lo: np.ndarray
    posvel_hi: np.ndarray
    src_lo: np.ndarray
    src_hi: np.ndarray
    conflict: bool

    def active(self, joints: np.ndarray) -> tuple[list[bool], np.ndarray]:
        """Which limits the (n,) joint values [rad] sit on: per code (POSITION, VELOCITY,
        ACCELERATION) whether any joint is on a bound it set, and the (n,) joints on any bound."""
        on_lo = joints <= self.lo + BOUND_TOL
        on_hi = joints >= self.hi - BOUND_TOL
        codes = [bool(np.any((on_lo & (self.src_lo == code)) | (on_hi & (self.src_hi == code))))
                 for code in (POSITION, VELOCITY, ACCELERATION)]
        return codes, on_lo | on_hi


@dataclass(frozen=True, eq=False)
class IncrementBox:
    """The joint limits of one fit in per-frame units; :meth:`at` gives a frame's box.

    Attributes:
        lower, upper: (n,) position limits q_min, q_max [rad].
        step_v: (n,) ``dt v_max``, the largest joint change in one frame [rad] (inf: unbounded).
        step_a: (n,) ``dt^2 a_max``, the largest change of that change between frames [rad].
        brake: also apply the braking-distance box (LimitOptions.brake_before_limits).
        has_vel, has_acc: some joint has a finite velocity / acceleration limit.
    """

    lower: np.ndarray
    upper: np.ndarray
    step_v: np.ndarray
    step_a: np.ndarray
    brake: bool
    has_vel: bool
    has_acc: bool

    @classmethod
    def build(cls, limits: JointLimits, fps: float, brake: bool) -> IncrementBox:
        """From the (n,) ``limits`` (e.g. of :func:`joint_limits`) at ``fps`` [Hz]; ``brake``:
        add the braking-distance box."""
        dt = 1.0 / fps
        step_v = dt * limits.v_max
        step_a = dt * dt * limits.a_max
        return cls(lower=limits.lower, upper=limits.upper, step_v=step_v, step_a=step_a,
                   brake=brake,
                   has_vel=bool(np.any(np.isfinite(step_v))),
                   has_acc=bool(np.any(np.isfinite(step_a))))

    def at(self, prev: np.ndarray | None, prev2: np.ndarray | None) -> FrameBox:
        """The box of frame i's joint values from the (n,) joints of frames i-1 and i-2 [rad]
        (None before the clip starts), intersected in priority order: position (eq. 9), then
        from frame 1 velocity (eq. 13), from frame 2 acceleration (eq. 14), then braking."""
        lo, hi = self.lower, self.upper
        src_lo = src_hi = np.zeros(len(lo), dtype=np.int64)
        clash = False
        if prev is not None and self.has_vel:
            lo, hi, src_lo, src_hi, c = intersect(lo, hi, src_lo, src_hi, prev - self.step_v,
                                                  prev + self.step_v, VELOCITY)
            clash = bool(c.any())
        pv_lo, pv_hi = lo, hi
        if prev is not None:
            if prev2 is not None and self.has_acc:
                centre = 2.0 * prev - prev2
                lo, hi, src_lo, src_hi, c = intersect(lo, hi, src_lo, src_hi,
                                                      centre - self.step_a,
                                                      centre + self.step_a, ACCELERATION)
                clash = clash or bool(c.any())
            if self.brake and self.has_acc:
                # stay slow enough to stop before the position limits at a_max (lowest
                # priority: where the joint is already too fast, the acceleration box wins)
                lo, hi, src_lo, src_hi, _ = intersect(
                    lo, hi, src_lo, src_hi, prev - braking_reach(prev - self.lower, self.step_a),
                    prev + braking_reach(self.upper - prev, self.step_a), POSITION)
        return FrameBox(lo=lo, hi=hi, posvel_lo=pv_lo, posvel_hi=pv_hi, src_lo=src_lo,
                        src_hi=src_hi, conflict=clash)
