"""The frame loop of the arm imitation (Kim, Kim & Oh 2005, sec. 3) and its two entry points:

- :func:`imitate_arms`: a human clip -> the robot's arms, base, legs and torso fixed at the
  nominal pose (``imesh retarget CLIP --mode arms``);
- :func:`refine_arms`: the arm joints of a motion fitted by the main pipeline re-solved by this
  method against the adapted markers (``imesh retarget CLIP --fit sqp``).

Per arm and frame, warm started from the previous frame (eq. 1), the increments of the arm
joints minimize eq. 2 inside the box of eqs 9, 13, 14 (the fit's
:class:`imesh.fit.limits.IncrementBox`); :mod:`imesh.arms.bounds` checks the result.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass, field

import numpy as np

from ..core.limits import BOUND_TOL, JointLimits, LimitOptions
from ..core.motion import MarkerMotion
from ..core.robot_motion import RobotMotion
from ..fit.feasible import project_joint_trajectory
from ..fit.limits import ACCELERATION, POSITION, VELOCITY, IncrementBox, joint_limits
from ..human.filtering import lowpass
from ..morph.adapt import prepare_markers
from .bounds import Violations, check_limits
from .config import ArmsConfig
from .errors import ArmsError
from .geometry import ArmModel, arm_model
from .problem import FrameObjective
from .solvers import SOLVER_FUNCTIONS
from .targets import ArmTargets, arm_targets

log = logging.getLogger(__name__)

#: Thumb points count in the reported hand-point error where their weight is at least this
#: fraction of the configured one (elsewhere the point is undefined, see docs/arms.md).
THUMB_REPORT_FRACTION = 0.5


@dataclass(frozen=True, eq=False)
class ArmResult:
    """One arm's solution with the evidence.

    Attributes:
        arm: the robot arm.
        targets: the per-frame targets (scaling, hand points, actor upper-arm direction).
        limits: the arm joints' limits enforced (inf where a switch of ArmsConfig is off).
        theta: (T, n) float [rad] the arm joints.
        robot_points_m: (T, 5, 3) float [m] robot wrist, hand, thumb, elbow, shoulder.
        hand_error_m: (T, 3) float [m] distance of each hand point from its target.
        upper_arm_error_deg: (T,) float angle between robot and actor upper arm [deg].
        objective: (T,) float f of eq. 2 at the solution.
        box_lo, box_hi: (T, n) float [rad] each frame's bounds (eqs 9, 13, 14).
        posvel_lo, posvel_hi: (T, n) float [rad] position and velocity bounds only (Fig. 4).
        at_bound: (T, 3) bool any joint on a bound set by its position / velocity /
            acceleration limit.
        conflict: (T,) bool the boxes of some joint did not intersect.
        iterations: (T,) int solver iterations.
        evaluations: (T,) int kinematics evaluations.
        converged: (T,) bool the solver's stopping test was met.
        violations: frames outside the robot's limits (backward differences of ``theta``;
            every limit, also one the run did not enforce).
        seconds: wall time of this arm's frame loop [s].
    """

    arm: ArmModel
    targets: ArmTargets
    limits: JointLimits
    theta: np.ndarray
    robot_points_m: np.ndarray
    hand_error_m: np.ndarray
    upper_arm_error_deg: np.ndarray
    objective: np.ndarray
    box_lo: np.ndarray
    box_hi: np.ndarray
    posvel_lo: np.ndarray
    posvel_hi: np.ndarray
    at_bound: np.ndarray
    conflict: np.ndarray
    iterations: np.ndarray
    evaluations: np.ndarray
    converged: np.ndarray
    violations: Violations
    seconds: float

    @property
    def side(self) -> str:
        return self.arm.side

    @property
    def hand_mask(self) -> np.ndarray:
        """(T, 3) bool the hand points that count in the reported error (the thumb only where
        its direction is defined)."""
        return hand_mask(self.targets)

    @property
    def hand_rms_mm(self) -> float:
        """RMS over frames and counted hand points of the hand-point error [mm]."""
        return float(1e3 * np.sqrt(np.mean(self.hand_error_m[self.hand_mask] ** 2)))

    @property
    def upper_arm_rms_deg(self) -> float:
        """RMS over frames of the upper-arm orientation error [deg]."""
        return float(np.sqrt(np.mean(self.upper_arm_error_deg ** 2)))

    @property
    def ms_per_frame(self) -> float:
        return 1e3 * self.seconds / len(self.theta)

    def summary(self) -> dict:
        """Scalar report of this arm."""
        err = self.hand_error_m
        per_point = {name: float(1e3 * np.sqrt(np.mean(err[self.hand_mask[:, k], k] ** 2)))
                     if self.hand_mask[:, k].any() else None
                     for k, name in enumerate(("wrist", "hand", "thumb"))}
        return {
            "joints": list(self.arm.joints),
            "rho": self.targets.scaling.rho,
            "human_arm_length_m": self.targets.scaling.human_length_m,
            "robot_arm_length_m": self.targets.scaling.robot_length_m,
            "hand_rms_mm": self.hand_rms_mm,
            "hand_rms_mm_by_point": per_point,
            "hand_max_mm": float(1e3 * err[self.hand_mask].max()),
            "thumb_defined_fraction": float(self.hand_mask[:, 2].mean()),
            "upper_arm_rms_deg": self.upper_arm_rms_deg,
            "upper_arm_max_deg": float(self.upper_arm_error_deg.max()),
            "objective_mean": float(self.objective.mean()),
            "frames_outside": self.violations.counts(),
            "worst_velocity_ratio": self.violations.worst_velocity_ratio,
            "worst_acceleration_ratio": self.violations.worst_acceleration_ratio,
            "frames_at_position_bound": int(self.at_bound[:, POSITION].sum()),
            "frames_at_velocity_bound": int(self.at_bound[:, VELOCITY].sum()),
            "frames_at_acceleration_bound": int(self.at_bound[:, ACCELERATION].sum()),
            "conflict_frames": int(self.conflict.sum()),
            "mean_iterations": float(self.iterations[1:].mean()) if len(self.theta) > 1
            else float(self.iterations[0]),
            "mean_evaluations": float(self.evaluations[1:].mean()) if len(self.theta) > 1
            else float(self.evaluations[0]),
            "unconverged_frames": int((~self.converged).sum()),
            "ms_per_frame": self.ms_per_frame,
        }


@dataclass(frozen=True, eq=False)
class ArmsResult:
    """The robot motion with every arm's evidence.

    Attributes:
        motion: the RobotMotion (reference configurations with the arm joints replaced).
        arms: side -> ArmResult.
        config: the settings used.
        source: the human clip's name.
    """

    motion: RobotMotion
    arms: dict[str, ArmResult]
    config: ArmsConfig = field(default_factory=ArmsConfig)
    source: str = ""

    def report(self) -> dict:
        """The JSON report (``imesh retarget --mode arms --json``)."""
        arms = {side: a.summary() for side, a in self.arms.items()}
        return {
            "mode": "arms",
            "robot": self.motion.robot,
            "source": self.source,
            "frames": self.motion.n_frames,
            "fps": self.motion.fps,
            "solver": self.config.solver,
            "upper_arm_weight": self.config.upper_arm_weight,
            "arms": arms,
            "frames_outside": {k: sum(a["frames_outside"][k] for a in arms.values())
                               for k in ("position", "velocity", "acceleration")},
            "ms_per_frame_per_arm": float(np.mean([a["ms_per_frame"] for a in arms.values()])),
        }


def hand_mask(targets: ArmTargets) -> np.ndarray:
    """(T, 3) bool hand points counted in reported errors: wrist and hand always, the thumb
    where its weight is at least :data:`THUMB_REPORT_FRACTION` of the largest."""
    w = targets.weights
    mask = np.ones(w.shape, dtype=bool)
    top = float(w[:, 2].max(initial=0.0))
    mask[:, 2] = w[:, 2] >= THUMB_REPORT_FRACTION * top if top > 0 else False
    return mask


def arm_errors(arm: ArmModel, targets: ArmTargets, q: np.ndarray, limits: JointLimits,
               fps: float) -> dict:
    """Hand-point RMS [mm], upper-arm RMS [deg] and frames outside the limits of any motion's
    arm against these targets (e.g. the main pipeline's fit before :func:`refine_arms`)."""
    points = np.array([arm.points(qt) for qt in q])
    err = np.linalg.norm(points[:, :3] - targets.hand_m, axis=2)
    r = points[:, 3] - points[:, 4]
    cos = np.sum(r * targets.upper_arm_dir, axis=1) / np.linalg.norm(r, axis=1)
    upper = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    return {"hand_rms_mm": float(1e3 * np.sqrt(np.mean(err[hand_mask(targets)] ** 2))),
            "upper_arm_rms_deg": float(np.sqrt(np.mean(upper ** 2))),
            "frames_outside": check_limits(q[:, 7 + arm.joint_index], limits, fps).counts()}


def arm_limits(robot, arm: ArmModel, options: LimitOptions) -> JointLimits:
    """The arm joints' limits (the robot's through :func:`imesh.fit.limits.joint_limits`, with the
    velocity / acceleration switches and override of ``options``)."""
    return joint_limits(robot, options).take(arm.joint_index)


@dataclass(frozen=True, eq=False)
class _Loop:
    """Output of one pass of the frame loop."""

    theta: np.ndarray
    iterations: np.ndarray
    evaluations: np.ndarray
    converged: np.ndarray
    seconds: float


def _frame_loop(arm: ArmModel, targets: ArmTargets, q_ref: np.ndarray, start: np.ndarray,
                limits: JointLimits, fps: float, config: ArmsConfig) -> _Loop:
    """Kim's scheme: per frame, from the previous frame (eq. 1), minimize eq. 2 over the
    increments inside the box of eqs 9, 13, 14 (infinite limits drop their box)."""
    solver = SOLVER_FUNCTIONS[config.solver]
    T, n = targets.n_frames, arm.n
    cols = 7 + arm.joint_index
    boxes = IncrementBox.build(limits, fps, config.limits.brake_before_limits)
    theta = np.empty((T, n))
    iterations = np.zeros(T, dtype=np.int64)
    evaluations = np.zeros(T, dtype=np.int64)
    converged = np.zeros(T, dtype=bool)
    t0 = time.perf_counter()
    for t in range(T):
        prev = theta[t - 1] if t >= 1 else None
        prev2 = theta[t - 2] if t >= 2 else None
        box = boxes.at(prev, prev2)
        q_prev = q_ref[t].copy()
        q_prev[cols] = prev if prev is not None else start
        base = q_prev[cols]
        lo, hi = box.lo - base, box.hi - base                     # eqs 9, 13, 14 as increments
        x0 = prev - prev2 if config.extrapolate and prev2 is not None else np.zeros(n)
        obj = FrameObjective(arm, q_prev, targets.hand_m[t], targets.weights[t],
                             targets.upper_arm_dir[t], config.upper_arm_weight, config.damping)
        max_it = config.first_frame_iterations if t == 0 else config.iterations
        x, info = solver(obj, lo, hi, x0, max_it, config.tolerance_rad,
                         config.objective_tolerance)
        theta[t] = np.clip(base + x, box.lo, box.hi)
        iterations[t], evaluations[t], converged[t] = (info.iterations, info.evaluations,
                                                       info.converged)
    return _Loop(theta=theta, iterations=iterations, evaluations=evaluations,
                 converged=converged, seconds=time.perf_counter() - t0)


def _solve_arm(robot, arm: ArmModel, targets: ArmTargets, q_ref: np.ndarray, fps: float,
               config: ArmsConfig) -> ArmResult:
    limits = arm_limits(robot, arm, config.limits)
    # violations are always counted against every limit, also those the run did not enforce
    robot_limits = arm_limits(robot, arm, dataclasses.replace(
        config.limits, enforce_velocity=True, enforce_acceleration=True))
    T, n = targets.n_frames, arm.n
    cols = 7 + arm.joint_index
    start = q_ref[0, cols]
    bad = np.flatnonzero((start < limits.lower - BOUND_TOL) | (start > limits.upper + BOUND_TOL))
    if bad.size:
        k = int(bad[0])
        raise ArmsError(f"robot {robot.name!r}: the reference pose puts joint {arm.joints[k]} at "
                        f"{start[k]:.6g} rad, outside its limits [{limits.lower[k]:.6g}, "
                        f"{limits.upper[k]:.6g}] rad: frame 0 has no feasible box")
    if config.lookahead:
        loop = _frame_loop(arm, targets, q_ref, start, limits.position_only(), fps, config)
        t0 = time.perf_counter()
        proj = project_joint_trajectory(loop.theta, fps, limits.lower, limits.upper,
                                        limits.v_max, limits.a_max)
        theta = proj.q
        seconds = loop.seconds + time.perf_counter() - t0
    else:
        loop = _frame_loop(arm, targets, q_ref, start, limits, fps, config)
        theta, seconds = loop.theta, loop.seconds
    # evidence (outside the timed loop): the box each frame had (or, with the look-ahead, would
    # have had) after the final trajectory's previous frames, errors at the solution
    boxes = IncrementBox.build(limits, fps, config.limits.brake_before_limits)
    out = {k: np.empty((T, n)) for k in ("lo", "hi", "pv_lo", "pv_hi")}
    at_bound = np.zeros((T, 3), dtype=bool)
    conflict = np.zeros(T, dtype=bool)
    objective = np.zeros(T)
    points = np.empty((T, 5, 3))
    upper_deg = np.empty(T)
    for t in range(T):
        box = boxes.at(theta[t - 1] if t >= 1 else None, theta[t - 2] if t >= 2 else None)
        at_bound[t] = box.active(theta[t])[0]
        conflict[t] = box.conflict
        out["lo"][t], out["hi"][t] = box.lo, box.hi
        out["pv_lo"][t], out["pv_hi"][t] = box.posvel_lo, box.posvel_hi
        q_prev = q_ref[t].copy()
        q_prev[cols] = theta[t - 1] if t >= 1 else start
        obj = FrameObjective(arm, q_prev, targets.hand_m[t], targets.weights[t],
                             targets.upper_arm_dir[t], config.upper_arm_weight, config.damping)
        x = theta[t] - q_prev[cols]
        objective[t] = obj.value(x)
        points[t] = arm.points(obj.configuration(x))
        upper_deg[t] = obj.upper_arm_error_deg(x)
    hand_err = np.linalg.norm(points[:, :3] - targets.hand_m, axis=2)
    return ArmResult(arm=arm, targets=targets, limits=limits, theta=theta,
                     robot_points_m=points, hand_error_m=hand_err, upper_arm_error_deg=upper_deg,
                     objective=objective, box_lo=out["lo"], box_hi=out["hi"],
                     posvel_lo=out["pv_lo"], posvel_hi=out["pv_hi"], at_bound=at_bound,
                     conflict=conflict, iterations=loop.iterations,
                     evaluations=loop.evaluations, converged=loop.converged,
                     violations=check_limits(theta, robot_limits, fps), seconds=seconds)


def solve_arms(robot, markers: MarkerMotion, q_ref: np.ndarray, *,
               config: ArmsConfig | None = None) -> ArmsResult:
    """Solve the arms of ``config.sides`` frame by frame against standard human markers.

    Args:
        robot: an :class:`imesh.robot.Robot` (markers.toml with shoulder, elbow, wrist, hand
            keypoints per side; ``[arms]`` hand points or derivable ones).
        markers: human markers with the standard names (``shoulder_<s>``, ``elbow_<s>``,
            ``wrist_<s>``, ``hand_<s>``; with ``frame="torso"`` also pelvis and neck), gaps
            filled, T frames.
        q_ref: (T, nq) or (nq,) float reference configurations: everything but the solved arm
            joints is taken from it, and frame 0 starts from its arm joints.
        config: ArmsConfig.

    Returns:
        ArmsResult.

    Raises:
        ArmsError: missing markers or keypoints, a reference outside the joint limits.
    """
    config = config or ArmsConfig()
    T = markers.n_frames
    q_ref = np.asarray(q_ref, dtype=np.float64)
    if q_ref.ndim == 1:
        q_ref = np.tile(q_ref, (T, 1))
    if q_ref.shape != (T, robot.nq) or not np.isfinite(q_ref).all():
        raise ArmsError(f"q_ref must be finite with shape ({robot.nq},) or ({T}, {robot.nq}), "
                        f"got {q_ref.shape}")
    arms: dict[str, ArmResult] = {}
    q_out = q_ref.copy()
    for side in config.sides:
        arm = arm_model(robot, side)
        targets = arm_targets(markers, arm, q_ref, config)
        result = _solve_arm(robot, arm, targets, q_ref, markers.fps, config)
        q_out[:, 7 + arm.joint_index] = result.theta
        arms[side] = result
        s = result.summary()
        log.info("arms %s %s: rho %.3f, hand-point RMS %.1f mm, upper arm %.1f deg RMS, "
                 "%.3f ms/frame (%s), frames outside position/velocity/acceleration %d/%d/%d",
                 robot.name, side, s["rho"], s["hand_rms_mm"], s["upper_arm_rms_deg"],
                 s["ms_per_frame"], config.solver, *s["frames_outside"].values())
    motion = RobotMotion(q=q_out, fps=markers.fps, robot=robot.name,
                         joint_names=tuple(robot.joint_names))
    return ArmsResult(motion=motion, arms=arms, config=config, source=markers.source or "")


def human_arm_markers(motion: MarkerMotion, lowpass_hz: float | None) -> MarkerMotion:
    """Standard markers of any loaded clip (:func:`imesh.morph.adapt.prepare_markers`), low-passed
    as in the main pipeline."""
    human = prepare_markers(motion)
    return lowpass(human, lowpass_hz) if lowpass_hz is not None else human


def imitate_arms(robot, motion: MarkerMotion, *, config: ArmsConfig | None = None
                 ) -> ArmsResult:
    """Imitate a human clip's arm motion with the robot's arms (Kim, Kim & Oh 2005).

    Base, legs, torso and head stay at the robot's nominal pose; only the arm joints move.

    Args:
        robot: an :class:`imesh.robot.Robot`.
        motion: any loaded human motion (mapped to the standard markers, gaps filled,
            low-passed at ``config.lowpass_hz``).
        config: ArmsConfig.

    Returns:
        ArmsResult (``.motion`` is the RobotMotion, same fps as the clip).
    """
    config = config or ArmsConfig()
    human = human_arm_markers(motion, config.lowpass_hz)
    return solve_arms(robot, human, robot.q_nominal, config=config)


#: Defaults of :func:`refine_arms`: the adapted markers are in the robot's world already (no
#: torso mapping); they are low-passed like the clips of :func:`imitate_arms`.
REFINE_CONFIG = ArmsConfig(frame="world")


def refine_arms(robot, robot_motion: RobotMotion, markers: MarkerMotion,
                config: ArmsConfig | None = None) -> tuple[RobotMotion, dict]:
    """Re-solve the arm joints of a fitted motion with the SQP of Kim, Kim & Oh 2005.

    The fitting stage of the main pipeline for the arms (``imesh retarget --fit sqp``): base,
    legs, torso and head stay as fitted; each arm's joints are solved frame by frame against the
    adapted markers, with the scaling, objective and bounds of this package.

    Args:
        robot: the robot.
        robot_motion: the fitted motion (T frames, this robot's joints).
        markers: the adapted markers it was fitted to (standard names: shoulder_l, elbow_l,
            wrist_l, hand_l, ...; same frames and fps).
        config: ArmsConfig (default :data:`REFINE_CONFIG`).

    Returns:
        (the motion with the arm joints replaced, the report of :meth:`ArmsResult.report`).

    Raises:
        ArmsError: a motion of another robot or length, missing markers.
    """
    config = config or REFINE_CONFIG
    if robot_motion.robot != robot.name or tuple(robot_motion.joint_names) != tuple(
            robot.joint_names):
        raise ArmsError(f"refine_arms: the motion is of robot {robot_motion.robot!r} with "
                        f"{robot_motion.n_joints} joints, not of {robot.name!r}")
    if robot_motion.n_frames != markers.n_frames:
        raise ArmsError(f"refine_arms: the motion has {robot_motion.n_frames} frames, the markers "
                        f"{markers.n_frames}")
    if config.lowpass_hz is not None:
        markers = lowpass(markers, config.lowpass_hz)
    result = solve_arms(robot, markers, robot_motion.q, config=config)
    before = {side: arm_errors(a.arm, a.targets, robot_motion.q, a.limits, robot_motion.fps)
              for side, a in result.arms.items()}
    motion = result.motion
    report = result.report()
    report["mode"] = "refine"
    report["before"] = before  # the input motion's arms against the same targets
    return motion, report
