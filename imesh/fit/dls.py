"""Per-frame joint fitting by damped least squares with joint position/velocity/acceleration
limits as bounds on the per-frame increment (docs/fitting.md).

For every frame ``i`` in order, warm started from the constant-velocity prediction of frames
``i-2, i-1``, the configuration ``q_i`` is refined by damped least-squares steps (Nakaoka &
Komura 2012, eq. 7) over the free-flyer base (6) and all joints, ``dq`` in the tangent space:

    dq = argmin |W (J dq - e)|^2 + mu^2 |q_j + dq_j - r_j|^2 + lambda^2 |dq|^2
         subject to the increment box below

``e`` stacks (eq. 8) the key-point position errors ``p_marker - p_robot`` [m] (rows of ``J``:
world-aligned point Jacobians) and the direction errors ``d - u`` of unit vectors
(``u = R_frame axis``, ``d`` the unit human direction ``to - from``; rows ``[J_omega] x u``, so
only the two DOF that tilt ``u`` count, and ``|d - u|`` is the angle for small errors). ``W`` is
diagonal (per-entry weights times FitConfig.position_weight / direction_weight). The ``mu``
rows (joints only; r = mostly the previous frame, a little the nominal pose) are the smoothing
and posture terms of FitConfig; lambda is adapted per step (Levenberg-Marquardt, see
``_solve_frame``), so the iteration converges to the minimizer of
``|W e|^2 + mu^2 |q_j - r_j|^2`` in the box, whatever the damping.

The joint part of the cumulative increment ``dq_i = q_i - q_{i-1}`` stays inside the box of Kim,
Kim & Oh 2005 (eqs 9, 13, 14; backward differences, ``dt = 1/fps``):

    position      q_min - q_{i-1}                 <= dq_i <= q_max - q_{i-1}
    velocity      -dt v_max                       <= dq_i <= dt v_max                 (i >= 1)
    acceleration  dt v_{i-1} - dt^2 a_max         <= dq_i <= dt v_{i-1} + dt^2 a_max  (i >= 2)

with ``v_{i-1} = (q_{i-1} - q_{i-2}) / dt``. Frame 0 has only the position box, frame 1 adds the
velocity box (one previous frame), frames >= 2 all three. Each step solves the bounded problem
exactly (primal-dual active set on the normal equations, :mod:`imesh.fit.boxqp`). With
``brake_before_limits`` a fourth, lowest-priority box keeps each joint slow enough to stop
before its position limits at ``a_max``.

Conflict policy: the boxes are intersected in priority order position, velocity, acceleration
(then braking). When a lower-priority box does not intersect the running intersection (a joint
moving fast towards its position limit cannot brake within ``a_max``), that joint is pinned to
the point of the running box closest to the dropped box (the least violation of the dropped
limit: maximal braking) and the frame is counted in ``FitResult.conflict_frames``. Position
limits therefore always hold; velocity limits hold whenever the previous frame is inside the
position limits (always after frame 0); acceleration limits hold on every non-conflict frame.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..core.motion import MarkerMotion
from ..core.robot_motion import RobotMotion
from .boxqp import solve_box_qp
from .errors import FitError
from .feasible import project_joint_trajectory
from .targets import CompiledTargets, DirectionTarget, KeypointTarget, compile_targets

log = logging.getLogger(__name__)

#: Codes of the limit that set a joint's bound in a frame.
POSITION, VELOCITY, ACCELERATION = 0, 1, 2
_BOUND_TOL = 1e-9
_LM_MIN = 1e-2  # smallest Levenberg-Marquardt factor
_RESIDUAL_DAMPING = 1.0  # weight of |W e|^2 in lambda^2
_STALL = 1e-3  # stop when sqrt(E) improves by less than this times the tolerance
_FIRST_FRAME_TOL = 1e-2
_CHORD_STEP = 1e-3  # [rad or m] largest step after which the Jacobian is reused
_MAX_CHORDS = 2  # chord steps per Jacobian
_JOINT_SCALE = 1e-3  # [m/rad] a joint step of 10 mrad counts as a 10 um change


@dataclass(frozen=True)
class FitConfig:
    """Settings of :func:`fit_motion`.

    Attributes:
        damping: lambda of eq. 7 at the start of each frame (weighted-residual units per unit
            of dq; with unit weights metres per radian). Each step uses
            ``lambda^2 = f (damping^2 + |W e|^2)`` with a Levenberg-Marquardt factor f in
            [0.01, 1e8]; larger damping is more cautious near singular poses.
        iterations: maximum damped least-squares solves per frame (frames >= 1).
        first_frame_iterations: maximum solves for frame 0 (starts from the geometric guess).
        tolerance: a frame is converged when the next step would change no weighted residual
            (key point [m], direction [rad], smoothing row) by more than this; frame 0 uses a
            hundredth of it.
        position_weight: multiplies every key-point residual (times its own weight) [1/m].
        direction_weight: multiplies every direction residual (times its own weight) [1/rad]:
            with both at 1, a direction error of 1 rad costs like a 1 m key-point error, so a
            markers.toml direction weight of 0.3 makes 1 degree cost like 5 mm.
        smoothing: constant part mu_0 of the smoothing weight mu: every frame i >= 1 adds
            ``mu^2 |q_j - q_{i-1},j|^2`` (joints only) to its objective [weighted-residual units
            per rad]. It anchors joints the targets do not determine (null space, e.g. a wrist
            yaw about the hand axis) against drift.
        adaptive_smoothing: gain k [1/m] of the residual-proportional part:
            ``mu = mu_0 + k * rms_{i-1}`` with rms_{i-1} the key-point RMS of the previous frame
            [m]. Targets the robot cannot meet (2 cm RMS) make the objective flat along
            redundant joint combinations (waist vs hips, forearm twist); without this term the
            per-frame optimum wanders along them and the joints chatter against their
            acceleration limits. Exact targets (rms -> 0) get mu -> mu_0 and no lag. The lag it
            costs is about ``(mu / sigma)^2`` of a frame's motion along Jacobian directions of
            singular value sigma (docs/fitting.md has the measurements).
        posture: eta, weight of the joint deviation from the nominal pose,
            ``eta^2 |q_j - q_nominal,j|^2`` in every frame i >= 1 [weighted-residual units per
            rad]: pulls joints that no target determines back towards the nominal pose instead
            of letting them drift into their limits; negligible for observed joints.
        enforce_velocity: apply the velocity box (Kim eq. 13).
        enforce_acceleration: apply the acceleration box (Kim eq. 14).
        acceleration_limit: overrides ``robot.a_max`` [rad/s^2]: one number for all joints or
            one per joint; None keeps the robot's (inf = unbounded).
        brake_before_limits: with the acceleration box on, also keep every joint slow enough to
            stop before its position limits at ``a_max`` (a braking-distance bound, lowest
            priority, counted as a position bound): without it a joint racing towards its
            limit meets a position/acceleration conflict.
        base_step_m, base_step_rad: trust region of the free-flyer in one damped step
            (linear [m], angular [rad]); many steps may still move it far (frame 0), but no
            single step can flip the base into another basin.
        base_speed_m_s, base_rate_rad_s: velocity box of the free-flyer (linear, angular), like
            Kim eq. 13 for the joints: without it, when rate-limited leg joints lag, the fit
            swings the unbounded base instead (seen: +-30 degrees of base yaw on a walk).
        lookahead: when velocity or acceleration limits apply, fit the frames with the position
            box only, then project the joint trajectory onto all the limits over the whole
            clip (:mod:`imesh.fit.feasible`): the result satisfies Kim's eqs 9, 13 and 14 in
            every frame and brakes ahead of fast motion. False: Kim's per-frame boxes inside
            the DLS (greedy: a joint that cannot follow its target saturates, overshoots and
            chases it; docs/fitting.md has the comparison).
        extrapolate: warm start frame i from the constant-velocity prediction of frames i-2 and
            i-1 (clipped into the box) instead of frame i-1; saves ~1 solve per frame.
    """

    damping: float = 1e-2
    iterations: int = 8
    first_frame_iterations: int = 300
    tolerance: float = 1e-5
    position_weight: float = 1.0
    direction_weight: float = 1.0
    smoothing: float = 1e-3
    adaptive_smoothing: float = 5.0
    posture: float = 3e-4
    enforce_velocity: bool = True
    enforce_acceleration: bool = True
    acceleration_limit: float | Sequence[float] | None = None
    brake_before_limits: bool = True
    extrapolate: bool = True
    lookahead: bool = True
    base_step_m: float = 0.05
    base_step_rad: float = 0.1
    base_speed_m_s: float = 3.0
    base_rate_rad_s: float = 3.0

    def __post_init__(self) -> None:
        positive = ("damping", "iterations", "first_frame_iterations", "tolerance")
        non_negative = ("position_weight", "direction_weight", "smoothing",
                        "adaptive_smoothing", "posture")
        for name in positive + non_negative:
            value = getattr(self, name)
            try:
                ok = bool(np.isfinite(value) and (value > 0 if name in positive else value >= 0))
            except TypeError:
                ok = False
            if not ok:
                kind = "positive" if name in positive else "non-negative"
                raise FitError(f"FitConfig.{name} = {value!r} is invalid: must be a finite "
                               f"{kind} number")
        if self.acceleration_limit is not None:
            arr = np.asarray(self.acceleration_limit, dtype=np.float64)
            if arr.ndim > 1 or np.any(np.isnan(arr)) or np.any(arr <= 0):
                raise FitError(f"FitConfig.acceleration_limit = {self.acceleration_limit!r} is "
                               "invalid: one positive number or one per joint [rad/s^2]")


@dataclass(frozen=True, eq=False)
class FitResult:
    """Fitted robot motion with per-frame evidence.

    Attributes:
        motion: the fitted configurations (T, nq).
        keypoints: the key points fitted (K entries).
        directions: the directions fitted (D entries).
        keypoint_error_m: (T, K) distance robot point - marker [m]; NaN where the marker is
            missing.
        keypoint_rms_m: (T,) RMS over the valid key points [m] (NaN when none is valid).
        keypoint_max_m: (T,) largest key-point error [m].
        direction_error_deg: (T, D) angle between the robot axis and the marker direction [deg];
            NaN where a marker is missing.
        iterations: (T,) DLS iterations taken per frame.
        at_position_bound: (T,) any joint on a bound set by its position limit.
        at_velocity_bound: (T,) any joint on a bound set by its velocity limit.
        at_acceleration_bound: (T,) any joint on a bound set by its acceleration limit.
        conflict: (T,) the boxes of some joint did not intersect (see the module policy).
        joint_bound_frames: (n,) per joint, frames in which it sat on any bound.
        seconds_per_frame: wall time of the frame loop divided by T [s].
        config: the settings used.
    """

    motion: RobotMotion
    keypoints: tuple[KeypointTarget, ...]
    directions: tuple[DirectionTarget, ...]
    keypoint_error_m: np.ndarray
    keypoint_rms_m: np.ndarray
    keypoint_max_m: np.ndarray
    direction_error_deg: np.ndarray
    iterations: np.ndarray
    at_position_bound: np.ndarray
    at_velocity_bound: np.ndarray
    at_acceleration_bound: np.ndarray
    conflict: np.ndarray
    joint_bound_frames: np.ndarray
    seconds_per_frame: float
    config: FitConfig = field(default_factory=FitConfig)

    @property
    def frames_at_position_bound(self) -> int:
        return int(self.at_position_bound.sum())

    @property
    def frames_at_velocity_bound(self) -> int:
        return int(self.at_velocity_bound.sum())

    @property
    def frames_at_acceleration_bound(self) -> int:
        return int(self.at_acceleration_bound.sum())

    @property
    def conflict_frames(self) -> int:
        return int(self.conflict.sum())

    @property
    def marker_rms_mm(self) -> float:
        """RMS over all frames and valid key points of the key-point error [mm]."""
        err = self.keypoint_error_m[np.isfinite(self.keypoint_error_m)]
        return float(1e3 * np.sqrt(np.mean(err**2))) if err.size else float("nan")

    def report(self) -> dict:
        """The JSON report of the fitting stage (same as :meth:`summary`)."""
        return self.summary()

    def summary(self) -> dict:
        """Scalar report (for JSON reports and benchmark tables)."""
        d = self.direction_error_deg
        dfin = d[np.isfinite(d)]
        kmax = self.keypoint_max_m[np.isfinite(self.keypoint_max_m)]
        return {
            "robot": self.motion.robot,
            "frames": self.motion.n_frames,
            "marker_rms_mm": self.marker_rms_mm,
            "keypoint_rms_m": 1e-3 * self.marker_rms_mm,
            "keypoint_max_mm": float(1e3 * kmax.max()) if kmax.size else float("nan"),
            "direction_rms_deg": float(np.sqrt(np.mean(dfin**2))) if dfin.size else 0.0,
            "direction_max_deg": float(dfin.max()) if dfin.size else 0.0,
            "mean_iterations": float(self.iterations.mean()),
            "frames_at_position_bound": self.frames_at_position_bound,
            "frames_at_velocity_bound": self.frames_at_velocity_bound,
            "frames_at_acceleration_bound": self.frames_at_acceleration_bound,
            "conflict_frames": self.conflict_frames,
            "seconds_per_frame": self.seconds_per_frame,
        }


# ------------------------------------------------------------------------------ limits
def joint_limits(robot, config: FitConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                      np.ndarray]:
    """Validated (q_lower, q_upper, v_max, a_max), each (n,); inf where unbounded."""
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
    if config.acceleration_limit is not None:
        acc = np.asarray(config.acceleration_limit, dtype=np.float64)
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
    if not config.enforce_velocity:
        vmax = np.full(n, np.inf)
    if not config.enforce_acceleration:
        amax = np.full(n, np.inf)
    return lower, upper, vmax, amax


def _check_within(robot, q: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                  what: str) -> None:
    joints = q[7:]
    bad = np.flatnonzero((joints < lower - _BOUND_TOL) | (joints > upper + _BOUND_TOL))
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


def _braking_reach(room: np.ndarray, brake: np.ndarray) -> np.ndarray:
    """Largest increment x towards a limit ``room`` away after which the joint can still stop
    before the limit with a deceleration of ``brake`` = dt^2 a_max per frame^2.

    Continuous braking distance v^2 / (2 a) with v = x / dt:
    ``x + x^2 / (2 brake) <= room``, so ``x = -brake + sqrt(brake^2 + 2 brake room)``
    (inf where a_max is unbounded, 0 at the limit).
    """
    with np.errstate(invalid="ignore", over="ignore"):
        x = -brake + np.sqrt(brake * brake + 2.0 * brake * np.maximum(room, 0.0))
    return np.where(np.isfinite(brake), x, np.inf)


def _intersect(lo, hi, src_lo, src_hi, lo2, hi2, code):
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


# ------------------------------------------------------------------------------ kinematics
def _cross_columns(m: np.ndarray, r: np.ndarray) -> np.ndarray:
    """(F, 3, n) columns of ``m`` crossed with ``r`` (F, 3): ``out[f, :, k] = m[f, :, k] x r[f]``.

    Written out by component: numpy.cross with axis arguments costs ~50 us per call here.
    """
    x, y, z = m[:, 0], m[:, 1], m[:, 2]
    rx, ry, rz = r[:, 0:1], r[:, 1:2], r[:, 2:3]
    return np.stack([y * rz - z * ry, z * rx - x * rz, x * ry - y * rx], axis=1)


class _Kinematics:
    """The few robot calls one DLS iteration needs, with the target frames fixed.

    One placement call for the union of key-point and direction frames per evaluation; per
    Jacobian, origin point Jacobians of the key-point frames and angular Jacobians of all frames,
    with the key-point offsets applied in numpy (``J_p = J_o - [R offset]x J_omega``).
    """

    def __init__(self, robot, targets: CompiledTargets):
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
        jp = j_lin + _cross_columns(ang_kp, self._lever)
        return jp, j_ang[self.dir_in_all]


# ------------------------------------------------------------------------------ initial guess
def _yaw_matrix(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def initial_guess(robot, kin: _Kinematics, targets: CompiledTargets, markers: MarkerMotion,
                  q_nominal: np.ndarray) -> np.ndarray:
    """First-frame configuration from the marker geometry: nominal joints, upright base.

    Base yaw: from the left-right direction ``hip_l - hip_r`` when both are key-point markers
    (matched against the same robot key points in the nominal pose); else the yaw that best
    aligns the horizontal key-point layout of the nominal pose with frame 0's markers
    (2-D Procrustes); else, with fewer than two usable key points, the horizontal walking
    direction of the first second. Base position: the ``pelvis`` key point (or one on the robot's
    waist frame, else the key-point centroid) placed on its marker.

    Args:
        robot: the robot.
        kin: its kinematics for the targets.
        targets: compiled key points.
        markers: the motion; frame 0 (or the first frame where markers are valid) is used.
        q_nominal: (nq,) nominal configuration (its joints are used).

    Returns:
        (nq,) configuration.
    """
    q = np.array(q_nominal, dtype=np.float64)
    q[:3] = 0.0
    q[3:7] = (0.0, 0.0, 0.0, 1.0)
    p0, _ = kin.points_and_axes(q)  # nominal key points with the base at the origin
    pos = markers.positions_m[:, targets.kp_markers]  # (T, K, 3)
    valid = markers.valid[:, targets.kp_markers]
    frame = int(np.argmax(valid.any(axis=1)))
    m = pos[frame]
    ok = valid[frame]
    names = [k.marker for k in targets.keypoints]
    yaw = None
    if "hip_l" in names and "hip_r" in names:
        il, ir = names.index("hip_l"), names.index("hip_r")
        if ok[il] and ok[ir]:
            h = m[il] - m[ir]
            r = p0[il] - p0[ir]
            if np.hypot(h[0], h[1]) > 1e-3 and np.hypot(r[0], r[1]) > 1e-3:
                yaw = np.arctan2(h[1], h[0]) - np.arctan2(r[1], r[0])
    if yaw is None and ok.sum() >= 2:
        a = p0[ok, :2] - p0[ok, :2].mean(axis=0)
        b = m[ok, :2] - m[ok, :2].mean(axis=0)
        cross = np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
        dot = np.sum(a * b)
        if np.hypot(cross, dot) > 1e-6:
            yaw = np.arctan2(cross, dot)
    if yaw is None:
        centre = np.nanmean(np.where(valid[..., None], pos, np.nan), axis=1)
        stop = min(markers.n_frames - 1, frame + int(round(markers.fps)))
        travel = centre[stop] - centre[frame]
        yaw = float(np.arctan2(travel[1], travel[0])) if np.all(np.isfinite(travel[:2])) and \
            np.hypot(travel[0], travel[1]) > 0.05 else 0.0
    rot = _yaw_matrix(float(yaw))
    anchor = None
    if "pelvis" in names and ok[names.index("pelvis")]:
        anchor = names.index("pelvis")
    else:
        waist = getattr(robot, "waist_frame", None)
        waist_id = robot.frame_id(waist) if waist else -1
        on_waist = [k for k, f in enumerate(targets.kp_frame_ids) if f == waist_id and ok[k]]
        anchor = on_waist[0] if on_waist else None
    if anchor is not None:
        q[:3] = m[anchor] - rot @ p0[anchor]
    elif ok.any():
        q[:3] = m[ok].mean(axis=0) - rot @ p0[ok].mean(axis=0)
    else:
        q[:3] = q_nominal[:3]
    half = 0.5 * float(yaw)
    q[3:7] = (0.0, 0.0, np.sin(half), np.cos(half))
    return q


def _residual(points, axes, target_p, w_p, ok_p, target_d, w_d):
    """Weighted residual W e (eq. 8 rows: key-point positions, then directions)."""
    e_p = np.where(ok_p[:, None], target_p - points, 0.0).reshape(-1) * w_p
    if axes.shape[0] == 0:
        return e_p
    return np.concatenate([e_p, (target_d - axes).reshape(-1) * w_d])


def _solve_frame(robot, kin: _Kinematics, q: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                 q_ref: np.ndarray, target_p, w_p, ok_p, target_d, w_d, unbounded,
                 config: FitConfig, max_it: int, *, first: bool = False, mu: float = 0.0,
                 q_prev: np.ndarray | None = None, base_reach: np.ndarray | None = None):
    """Levenberg-Marquardt iterations of the box-bounded DLS step (eq. 7) for one frame.

    Minimizes ``E(q) = |W e(q)|^2 + mu^2 |q_j - q_ref|^2`` (joints only; see FitConfig)
    by steps ``dq = argmin |W (J dq - e)|^2 + mu^2 |q_j + dq_j - q_ref|^2 + lambda^2 |dq|^2``
    inside the increment box. ``lambda^2 = f (damping^2 + |W e|^2)``: the residual term stands in
    for the second-order part of the Hessian that Gauss-Newton ignores (it grows with the
    residual, so inconsistent targets get damped steps while exact targets converge
    quadratically); the factor f starts at 1, grows tenfold when a step fails to lower E (the
    step is retried from the last accepted pose) and shrinks tenfold (to at least
    ``_LM_MIN``) after an accepted step. After a small step (< ``_CHORD_STEP``) that achieved at
    least half of its predicted decrease, the next step reuses the Jacobian (a chord step: one
    forward-kinematics call instead of a Jacobian; at most ``_MAX_CHORDS`` in a row). Frame 0
    (``first``) has no previous frame: no smoothing term, and a 100 times tighter tolerance,
    since later frames inherit its weakly observed joints.

    Stops when the next step would change no weighted residual (key point, direction) by more
    than ``config.tolerance`` and move no joint by more than ``tolerance / _JOINT_SCALE``
    (steps along directions no target sees do not keep it iterating), when an accepted step
    lowered sqrt(E) by less than 1e-3 of the tolerance, or after ``max_it`` solves.

    Args:
        robot, kin: the robot and its kinematics for the targets.
        q: (nq,) starting configuration, joints inside [lo, hi].
        lo, hi: (n,) absolute joint bounds of this frame [rad].
        q_ref: (n,) reference of the mu term [rad].
        target_p, w_p, ok_p: (K, 3) key-point targets [m], (3K,) row weights, (K,) validity.
        target_d, w_d: (D, 3) unit target directions, (3D,) row weights.
        unbounded: (6,) free-flyer bound of one step (linear [m], angular [rad]).
        config: the settings; max_it: solve budget; first: frame 0; mu: smoothing weight.
        q_prev, base_reach: the previous frame's configuration and the (6,) largest base
            displacement from it in this frame (base velocity bound times dt, in the base
            frame): the free-flyer gets a velocity box like the joints (None: no box).

    Returns:
        (q, key points (K, 3), direction axes (D, 3), solves) at the last accepted pose.
    """
    nv = robot.nv
    tol = config.tolerance * (_FIRST_FRAME_TOL if first else 1.0)
    damp2 = config.damping ** 2
    mu2 = 0.0 if first else mu * mu
    factor = 1.0
    points, axes = kin.points_and_axes(q)
    res = _residual(points, axes, target_p, w_p, ok_p, target_d, w_d)
    dev = q[7:] - q_ref
    fit_cost = float(res @ res)
    cost = fit_cost + mu2 * float(dev @ dev)
    it = 0
    chords = 0
    a_rows = None
    active = None
    while it < max_it and cost > 0.0:
        fresh = a_rows is None
        if a_rows is None:  # (fresh; spelled out so the type checker narrows a_rows)
            chords = 0
            jp, jw = kin.jacobians(q)
            a_rows = jp.reshape(-1, nv) * w_p[:, None]
            if axes.shape[0]:
                jd = _cross_columns(jw, axes)  # d u = omega x u
                a_rows = np.concatenate([a_rows, jd.reshape(-1, nv) * w_d[:, None]])
            h0 = a_rows.T @ a_rows
            if mu2:
                h0[6:, 6:].flat[:: nv - 5] += mu2
            diag0 = h0.diagonal().copy()
        g = a_rows.T @ res
        if mu2:
            g[6:] -= mu2 * dev
        base_lo, base_hi = -unbounded, unbounded
        if q_prev is not None and base_reach is not None:
            # first-order: the base displacement so far plus this step stays in the box
            moved = robot.difference(q_prev, q)[:6]
            base_lo = np.maximum(base_lo, np.minimum(-base_reach - moved, 0.0))
            base_hi = np.minimum(base_hi, np.maximum(base_reach - moved, 0.0))
        step_lo = np.concatenate([base_lo, lo - q[7:]])
        step_hi = np.concatenate([base_hi, hi - q[7:]])
        while True:
            h = h0.copy()
            h.flat[:: nv + 1] = diag0 + factor * (damp2 + _RESIDUAL_DAMPING * fit_cost)
            dq, _, active = solve_box_qp(h, g, step_lo, step_hi, guess=active)
            it += 1
            step = float(np.max(np.abs(dq)))
            # converged when the step would move no weighted residual (key point [m], direction
            # [rad], smoothing) by more than tol: steps along unobservable joint combinations
            # (driven by rounding noise when lambda is small) do not count
            change = max(float(np.max(np.abs(a_rows @ dq))),
                         _JOINT_SCALE * float(np.max(np.abs(dq[6:]))))
            if change < tol:
                return q, points, axes, it
            q_new = np.array(robot.integrate(q, dq), dtype=np.float64)
            q_new[7:] = np.clip(q_new[7:], lo, hi)
            p_new, a_new = kin.points_and_axes(q_new)
            r_new = _residual(p_new, a_new, target_p, w_p, ok_p, target_d, w_d)
            dev_new = q_new[7:] - q_ref
            fit_new = float(r_new @ r_new)
            c_new = fit_new + mu2 * float(dev_new @ dev_new)
            if c_new <= cost:
                lin = res - a_rows @ dq
                dev_lin = dev + dq[6:]
                predicted = cost - float(lin @ lin) - mu2 * float(dev_lin @ dev_lin)
                gain = np.sqrt(cost) - np.sqrt(c_new)
                # reuse the Jacobian only after a small step that did what the linear model
                # predicted: the chord step then converges nearly as fast as a fresh one
                reuse = (step < _CHORD_STEP and chords < _MAX_CHORDS
                         and (cost - c_new) >= 0.5 * predicted)
                q, points, axes, res, fit_cost = q_new, p_new, a_new, r_new, fit_new
                dev, cost = dev_new, c_new
                if gain < _STALL * tol:
                    return q, points, axes, it
                factor = max(_LM_MIN, 0.1 * factor)
                if reuse:
                    chords += 1
                else:
                    a_rows = None
                break
            if not fresh:  # a chord step failed: recompute the Jacobian at q first
                a_rows = None
                break
            factor *= 10.0
            if it >= max_it or factor > 1e8:
                return q, points, axes, it
    return q, points, axes, it


# ------------------------------------------------------------------------------ the frame loop

@dataclass(frozen=True, eq=False)
class _FrameTargets:
    """Per-frame target arrays of a fit (built once, shared by both passes)."""

    kp_pos: np.ndarray  # (T, K, 3) [m]
    kp_ok: np.ndarray  # (T, K)
    kp_w_rows: np.ndarray  # (3K,)
    dir_target: np.ndarray  # (T, D, 3) unit
    dir_ok: np.ndarray  # (T, D)
    dir_w_rows: np.ndarray  # (3D,)

    @classmethod
    def build(cls, markers: MarkerMotion, targets: CompiledTargets,
              config: FitConfig) -> _FrameTargets:
        n_frames = markers.n_frames
        kp_pos = markers.positions_m[:, targets.kp_markers]
        kp_ok = markers.valid[:, targets.kp_markers]
        if len(targets.dir_frame_ids):
            tail = markers.positions_m[:, targets.dir_from]
            head = markers.positions_m[:, targets.dir_to]
            vec = head - tail
            norm = np.linalg.norm(vec, axis=2)
            dir_ok = (markers.valid[:, targets.dir_from] & markers.valid[:, targets.dir_to]
                      & (norm > 1e-9))
            dir_target = np.where(dir_ok[..., None],
                                  vec / np.where(dir_ok, norm, 1.0)[..., None], 0.0)
        else:
            dir_ok = np.zeros((n_frames, 0), dtype=bool)
            dir_target = np.zeros((n_frames, 0, 3))
        return cls(kp_pos=kp_pos, kp_ok=kp_ok,
                   kp_w_rows=np.repeat(config.position_weight * targets.kp_weights, 3),
                   dir_target=dir_target, dir_ok=dir_ok,
                   dir_w_rows=np.repeat(config.direction_weight * targets.dir_weights, 3))


def _frame_errors(frames: _FrameTargets, t: int, points: np.ndarray, axes: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Key-point distances (K,) [m] and direction angles (D,) [deg] of frame t; NaN where the
    marker is missing."""
    kp = np.where(frames.kp_ok[t], np.linalg.norm(frames.kp_pos[t] - points, axis=1), np.nan)
    cosang = np.clip(np.einsum("di,di->d", axes, frames.dir_target[t]), -1.0, 1.0)
    return kp, np.where(frames.dir_ok[t], np.degrees(np.arccos(cosang)), np.nan)


@dataclass(eq=False)
class _Track:
    """Output arrays of one pass of the frame loop."""

    q: np.ndarray
    kp_err: np.ndarray
    dir_err: np.ndarray
    iterations: np.ndarray
    at_bound: np.ndarray
    conflict: np.ndarray
    joint_bound_frames: np.ndarray
    empty: int


def _track(robot, kin: _Kinematics, frames: _FrameTargets, config: FitConfig, q0: np.ndarray,
           init: np.ndarray | None, lower: np.ndarray, upper: np.ndarray, vmax: np.ndarray,
           amax: np.ndarray, fps: float) -> _Track:
    """The frame loop: the box of every frame, the warm start, the DLS solve."""
    n_frames = len(frames.kp_pos)
    nq = robot.nq
    dt = 1.0 / fps
    step_v = dt * vmax
    step_a = dt * dt * amax
    n_kp, n_dir = frames.kp_pos.shape[1], frames.dir_target.shape[1]
    # Trust region of the free-flyer per LM step: joints are boxed by their limits, the base is
    # not, and one poorly damped step could turn it by 90 degrees into another basin (seen on
    # the CMU walk: the base yaw jumped 40 degrees in one frame and never came back).
    unbounded = np.array([config.base_step_m] * 3 + [config.base_step_rad] * 3)
    base_reach = np.array([config.base_speed_m_s] * 3 + [config.base_rate_rad_s] * 3) / fps
    q_posture = np.clip(np.asarray(robot.q_nominal, dtype=np.float64)[7:], lower, upper)
    has_acc = bool(np.any(np.isfinite(step_a)))
    has_vel = bool(np.any(np.isfinite(step_v)))

    q_out = np.empty((n_frames, nq))
    kp_err = np.full((n_frames, n_kp), np.nan)
    dir_err = np.full((n_frames, n_dir), np.nan)
    iters = np.zeros(n_frames, dtype=np.int64)
    at_bound = np.zeros((n_frames, 3), dtype=bool)
    conflict = np.zeros(n_frames, dtype=bool)
    joint_bound_frames = np.zeros(len(lower), dtype=np.int64)
    zero_code = np.zeros(len(lower), dtype=np.int64)
    empty = 0
    prev_rms = float("nan")
    for t in range(n_frames):
        # ---- the box for q_t[7:] (absolute joint values), in priority order
        lo, hi = lower, upper
        src_lo, src_hi = zero_code, zero_code
        clash = False
        if t >= 1:
            qp = q_out[t - 1, 7:]
            if has_vel:
                lo, hi, src_lo, src_hi, c = _intersect(lo, hi, src_lo, src_hi, qp - step_v,
                                                       qp + step_v, VELOCITY)
                clash = bool(c.any())
            if t >= 2 and has_acc:
                centre = 2.0 * qp - q_out[t - 2, 7:]
                lo, hi, src_lo, src_hi, c = _intersect(lo, hi, src_lo, src_hi, centre - step_a,
                                                       centre + step_a, ACCELERATION)
                clash = clash or bool(c.any())
            if config.brake_before_limits and has_acc:
                # stay slow enough to stop before the position limits at a_max (lowest
                # priority: where the joint is already too fast, the acceleration box wins)
                lo, hi, src_lo, src_hi, _ = _intersect(
                    lo, hi, src_lo, src_hi, qp - _braking_reach(qp - lower, step_a),
                    qp + _braking_reach(upper - qp, step_a), POSITION)
        conflict[t] = clash
        # ---- warm start
        if t == 0:
            q = q0.copy()
        elif init is not None and init.ndim == 2:
            q = init[t].copy()
        elif t >= 2 and config.extrapolate:
            q = robot.integrate(q_out[t - 1], robot.difference(q_out[t - 2], q_out[t - 1]))
        else:
            q = q_out[t - 1].copy()
        q = np.array(q, dtype=np.float64)
        q[7:] = np.clip(q[7:], lo, hi)
        # ---- targets of this frame
        ok_p = frames.kp_ok[t]
        ok_d = frames.dir_ok[t]
        if not (ok_p.any() or ok_d.any()):
            empty += 1
        target_p = frames.kp_pos[t]
        w_p = np.where(np.repeat(ok_p, 3), frames.kp_w_rows, 0.0)
        w_d = np.where(np.repeat(ok_d, 3), frames.dir_w_rows, 0.0)
        target_d = frames.dir_target[t]
        max_it = config.first_frame_iterations if t == 0 else config.iterations
        mu = config.smoothing
        if t >= 1 and np.isfinite(prev_rms):
            mu += config.adaptive_smoothing * prev_rms
        if t == 0:
            q_ref = q[7:]
        else:  # mu^2 |q - q_prev|^2 + eta^2 |q - q_nominal|^2 = (mu^2 + eta^2) |q - q_ref|^2 + c
            mu2, eta2 = mu * mu, config.posture ** 2
            q_ref = (mu2 * q_out[t - 1, 7:] + eta2 * q_posture) / max(mu2 + eta2, 1e-300)
            mu = float(np.sqrt(mu2 + eta2))
        base_box = t >= 1 and config.enforce_velocity and np.isfinite(base_reach).any()
        q, points, axes, it = _solve_frame(robot, kin, q, lo, hi, q_ref, target_p, w_p, ok_p,
                                           target_d, w_d, unbounded, config, max_it,
                                           first=t == 0, mu=mu,
                                           q_prev=q_out[t - 1] if base_box else None,
                                           base_reach=base_reach)
        q_out[t] = q
        iters[t] = it
        kp_err[t], dir_err[t] = _frame_errors(frames, t, points, axes)
        if ok_p.any():
            prev_rms = float(np.sqrt(np.nanmean(kp_err[t] ** 2)))
        # ---- which limits are active
        joints = q[7:]
        on_lo = joints <= lo + _BOUND_TOL
        on_hi = joints >= hi - _BOUND_TOL
        for code in (POSITION, VELOCITY, ACCELERATION):
            at_bound[t, code] = bool(np.any((on_lo & (src_lo == code))
                                            | (on_hi & (src_hi == code))))
        joint_bound_frames += on_lo | on_hi
    return _Track(q=q_out, kp_err=kp_err, dir_err=dir_err, iterations=iters, at_bound=at_bound,
                  conflict=conflict, joint_bound_frames=joint_bound_frames, empty=empty)

def _limited(robot, kin: _Kinematics, frames: _FrameTargets, free: _Track, joints: np.ndarray,
             lower: np.ndarray, upper: np.ndarray, vmax: np.ndarray, amax: np.ndarray,
             fps: float) -> _Track:
    """The free pass with its joints replaced by the projection: errors and active limits."""
    q = free.q.copy()
    q[:, 7:] = joints
    n_frames = len(q)
    kp_err = np.full_like(free.kp_err, np.nan)
    dir_err = np.full_like(free.dir_err, np.nan)
    for t in range(n_frames):
        kp_err[t], dir_err[t] = _frame_errors(frames, t, *kin.points_and_axes(q[t]))
    # a limit is active where the trajectory uses more than 99.9 % of it
    on_pos = (joints <= lower + 1e-3 * (upper - lower)) | (joints >= upper - 1e-3 * (upper - lower))
    dt = 1.0 / fps
    on_vel = np.zeros_like(on_pos)
    on_acc = np.zeros_like(on_pos)
    on_vel[1:] = np.abs(np.diff(joints, axis=0)) >= 0.999 * dt * vmax
    on_acc[2:] = np.abs(joints[2:] - 2.0 * joints[1:-1] + joints[:-2]) >= 0.999 * dt * dt * amax
    at_bound = np.stack([on_pos.any(axis=1), on_vel.any(axis=1), on_acc.any(axis=1)], axis=1)
    return _Track(q=q, kp_err=kp_err, dir_err=dir_err, iterations=free.iterations,
                  at_bound=at_bound, conflict=np.zeros(n_frames, dtype=bool),
                  joint_bound_frames=(on_pos | on_vel | on_acc).sum(axis=0), empty=free.empty)


def _as_q_init(q_init, n_frames: int, nq: int) -> np.ndarray | None:
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


def fit_motion(robot, markers: MarkerMotion, *, keypoints: Iterable | None = None,
               directions: Iterable | None = None, config: FitConfig | None = None,
               q_init: np.ndarray | RobotMotion | None = None) -> FitResult:
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

    Returns:
        FitResult with the RobotMotion (same fps as ``markers``) and per-frame errors, bound
        activity and timing.

    Raises:
        MissingMarkerError: a key point or direction names a marker the motion lacks.
        UnknownFrameError: ... or a frame the robot lacks (both list valid names).
        FitError: inconsistent or empty limits, a nominal / initial pose outside the joint
            limits (names the joint, its limits and the value), a bad q_init or config.
    """
    config = config or FitConfig()
    targets = compile_targets(robot, markers.names, keypoints, directions,
                              source=markers.source or "motion")
    lower, upper, vmax, amax = joint_limits(robot, config)
    n_frames = markers.n_frames
    nq = robot.nq
    init = _as_q_init(q_init, n_frames, nq)
    kin = _Kinematics(robot, targets)
    if init is not None:
        q0 = init if init.ndim == 1 else init[0]
        _check_within(robot, q0, lower, upper, "the initial configuration q_init")
    else:
        q_nominal = np.asarray(robot.q_nominal, dtype=np.float64)
        _check_within(robot, q_nominal, lower, upper, "the nominal pose q_nominal")
        q0 = initial_guess(robot, kin, targets, markers, q_nominal)

    frames = _FrameTargets.build(markers, targets, config)
    limited = bool(np.any(np.isfinite(vmax)) or np.any(np.isfinite(amax)))
    t_start = time.perf_counter()
    projection = None
    if config.lookahead and limited and n_frames >= 3:
        # the markers with the position limits only (per-frame box), then the joint trajectory
        # projected onto all the limits over the whole clip (feasible.py): it satisfies Kim's
        # eqs 9, 13 and 14 in every frame and brakes ahead of fast target motion
        free = _track(robot, kin, frames, config, q0, init, lower, upper,
                      np.full_like(vmax, np.inf), np.full_like(amax, np.inf), markers.fps)
        projection = project_joint_trajectory(free.q[:, 7:], markers.fps, lower, upper,
                                              vmax, amax)
        out = _limited(robot, kin, frames, free, projection.q, lower, upper, vmax, amax,
                       markers.fps)
    else:
        out = _track(robot, kin, frames, config, q0, init, lower, upper, vmax, amax,
                     markers.fps)
    seconds = time.perf_counter() - t_start
    q_out, kp_err, dir_err, iters = out.q, out.kp_err, out.dir_err, out.iterations
    at_bound, conflict, joint_bound_frames, empty = (out.at_bound, out.conflict,
                                                     out.joint_bound_frames, out.empty)

    with np.errstate(invalid="ignore"):
        counts = np.isfinite(kp_err).sum(axis=1)
        sq = np.where(np.isfinite(kp_err), kp_err**2, 0.0).sum(axis=1)
        rms = np.where(counts > 0, np.sqrt(sq / np.maximum(counts, 1)), np.nan)
        kmax = np.where(counts > 0, np.nanmax(np.where(np.isfinite(kp_err), kp_err, -1.0),
                                              axis=1), np.nan)
    motion = RobotMotion(q=q_out, fps=markers.fps, robot=robot.name,
                         joint_names=tuple(robot.joint_names),
                         meta={"source": markers.source, "fit": "dls"})
    result = FitResult(
        motion=motion, keypoints=targets.keypoints, directions=targets.directions,
        keypoint_error_m=kp_err, keypoint_rms_m=rms, keypoint_max_m=kmax,
        direction_error_deg=dir_err, iterations=iters,
        at_position_bound=at_bound[:, POSITION], at_velocity_bound=at_bound[:, VELOCITY],
        at_acceleration_bound=at_bound[:, ACCELERATION], conflict=conflict,
        joint_bound_frames=joint_bound_frames, seconds_per_frame=seconds / n_frames,
        config=config,
    )
    if empty:
        log.warning("%s: %d of %d frames had no valid marker to fit (kept the warm start)",
                    markers.source or "motion", empty, n_frames)
    s = result.summary()
    log.info("fit %s to %s: %d frames, key-point RMS %.2f mm, %.2f iterations/frame, "
             "%.3f ms/frame, frames at position/velocity/acceleration bounds %d/%d/%d, "
             "conflicts %d", robot.name, markers.source or "motion", n_frames,
             s["marker_rms_mm"], s["mean_iterations"], 1e3 * result.seconds_per_frame,
             s["frames_at_position_bound"], s["frames_at_velocity_bound"],
             s["frames_at_acceleration_bound"], s["conflict_frames"])
    return result
