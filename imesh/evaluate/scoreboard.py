"""The quality scoreboard of a robot motion: every metric of DESIGN.md, for imesh outputs and for
other retargeters' outputs alike.

:func:`evaluate_motion` returns a dict whose keys are exactly :data:`METRIC_NAMES`; each value
is a JSON-ready dict ``{"value": number | bool | None, "unit": str, ...details}``, with a
``"reason"`` when the value is None (not computable: no source markers given, physics not run,
no support frame...). :func:`metric_values` flattens it to ``{name: value}``.

Support phases come from the robot motion itself (soles within 1 cm of the ground and slower
than 0.5 m/s, with hysteresis), so plain arrays from other tools are scored on the same terms.

Motion files (:func:`load_motion_file`):

- imesh robot motions (``.npz``/``.csv`` written by
  :func:`imesh.io.robot_motion.save_robot_motion`), including files of other tools written in that
  layout;
- plain ``.npz`` arrays: ``joint_names`` (n,) str, ``joint_positions`` (T, n) [rad],
  ``base_position`` (T, 3) [m] (world, Z up, ground z = 0), the base orientation as
  ``base_quat_xyzw`` or ``base_quat_wxyz`` (T, 4) (the key names the order), ``fps`` (or pass
  fps=), optionally ``robot`` (must match). The base is the URDF root link.

The command line (``imesh evaluate``) is :func:`add_parser` + :func:`run`.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import time
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..core.motion import MarkerMotion
from ..core.robot_motion import RobotMotion
from ..errors import (
    ImeshError,
    InvalidMotionError,
    MotionFileError,
    SourceMismatchError,
    _listing,
)
from ..io.npz import load_npz
from ..io.robot_motion import NPZ_KEYS, load_robot_motion
from ..metrics.collision import (
    SELF_COLLISION_DEPTH_M,
    PairHit,
    check_capsule_collisions,
    check_ground,
)
from ..metrics.dynamics import MU, reference_dynamics
from ..metrics.kinematics import (
    SKID_THRESHOLD_MM,
    SupportDetection,
    detect_support,
    foot_skid,
    limit_violations,
    motion_derivatives,
    planted_feet,
    sole_deviation,
    sole_tracks,
    zmp_report,
    zmp_trajectory,
)
from ..metrics.markers import close_pair_error, keypoint_motion, marker_rms_mm

log = logging.getLogger(__name__)

#: The metric names of DESIGN.md, in report order (the keys of every report).
METRIC_NAMES: tuple[str, ...] = (
    "marker_rms_mm", "close_pair_error", "self_collision_frames", "ground_penetration_mm",
    "foot_skid_mm_per_frame", "limit_violation_frames", "zmp_inside_fraction", "zmp_error_mm",
    "physics_fell", "physics_survived_s", "tracking_rms_rad", "torque_ratio_max",
    "seconds_per_frame", "sole_deviation_mm", "sole_tilt_deg", "torque_ratio_ref",
    "friction_ratio_max",
)

UNITS: dict[str, str] = {
    "sole_deviation_mm": "mm", "sole_tilt_deg": "deg", "torque_ratio_ref": "ratio",
    "friction_ratio_max": "ratio",
    "marker_rms_mm": "mm", "close_pair_error": "height fraction",
    "self_collision_frames": "frames", "ground_penetration_mm": "mm",
    "foot_skid_mm_per_frame": "mm/frame at 30 fps", "limit_violation_frames": "frames",
    "zmp_inside_fraction": "fraction", "zmp_error_mm": "mm", "physics_fell": "bool",
    "physics_survived_s": "s", "tracking_rms_rad": "rad", "torque_ratio_max": "ratio",
    "seconds_per_frame": "s/frame",
}

_QUAT_KEYS = {"base_quat_xyzw": (0, 1, 2, 3), "base_quat_wxyz": (1, 2, 3, 0)}


# ----------------------------------------------------------------------------------------------
# loading


def load_motion_file(path: str | os.PathLike, robot, fps: float | None = None) -> RobotMotion:
    """Read a robot motion to evaluate: an imesh robot motion or plain arrays (module docstring).

    Args:
        path: ``.npz`` or ``.csv`` file.
        robot: the :class:`imesh.robot.Robot` the motion is for (names and joints are checked;
            columns are reordered into ``robot.joint_names`` order).
        fps: frame rate for files that store none [1/s].

    Raises:
        MotionFileError: unreadable file, wrong shapes or joint count, unknown or missing joint
            names (listing the valid ones), non-finite values, a motion of another robot.
    """
    path = Path(path)
    adapted = None
    if path.suffix.lower() == ".npz" and path.is_file():
        arrays = load_npz(path, "robot motion")
        if not set(NPZ_KEYS) <= set(arrays):
            return _load_plain_npz(path, arrays, robot, fps)
        adapted = _stored_markers(path, arrays)
    motion = load_robot_motion(path, robot)
    if adapted is not None:
        if adapted.n_frames != motion.n_frames:
            raise MotionFileError(str(path), f"adapted_positions_m has {adapted.n_frames} "
                                  f"frames, the motion {motion.n_frames}")
        motion = dataclasses.replace(motion, meta={**motion.meta, "adapted_markers": adapted})
    if fps is not None and abs(fps - motion.fps) > 1e-6 * motion.fps:
        log.warning("%s: the file says %g fps; using %g fps as asked", path, motion.fps, fps)
        motion = RobotMotion(q=motion.q, fps=fps, robot=motion.robot,
                             joint_names=motion.joint_names, meta=motion.meta)
    return motion


def _stored_markers(path: Path, arrays: Mapping[str, np.ndarray]) -> MarkerMotion | None:
    """The adapted markers an imesh motion file carries (``save_robot_motion(markers=)``)."""
    if "adapted_positions_m" not in arrays:
        return None
    try:
        pos = np.asarray(arrays["adapted_positions_m"], dtype=np.float64)
        names = tuple(str(n) for n in np.asarray(arrays["adapted_marker_names"]).reshape(-1))
        return MarkerMotion(positions_m=pos, fps=float(arrays["fps"]), names=names,
                            # any array when pos is not (T, M, 3): MarkerMotion rejects pos
                            valid=np.asarray(np.isfinite(pos).all(axis=-1)) if pos.ndim == 3
                            else pos,
                            source=f"{path}:adapted_positions_m")
    except (KeyError, TypeError, ValueError, ImeshError) as exc:
        raise MotionFileError(str(path), f"unreadable adapted markers ({exc})") from None


def _load_plain_npz(path: Path, data: Mapping[str, np.ndarray], robot, fps: float | None
                    ) -> RobotMotion:
    keys = set(data)
    quat_keys = [k for k in _QUAT_KEYS if k in keys]
    need = ["joint_names", "joint_positions", "base_position"]
    missing = [k for k in need if k not in keys] + ([] if quat_keys else ["base_quat_xyzw"])
    if missing or len(quat_keys) > 1:
        raise MotionFileError(str(path), f"missing keys {missing}; a motion .npz has "
                              "joint_names (n,), joint_positions (T, n) [rad], base_position "
                              "(T, 3) [m], base_quat_xyzw or base_quat_wxyz (T, 4), fps and "
                              f"optionally robot; this file has {sorted(keys)}"
                              if missing else "give one base quaternion key, not both")
    try:
        names = tuple(str(n) for n in np.asarray(data["joint_names"]).reshape(-1))
        joints = np.asarray(data["joint_positions"], dtype=float)
        base = np.asarray(data["base_position"], dtype=float)
        quat = np.asarray(data[quat_keys[0]], dtype=float)
        file_fps = float(data["fps"]) if "fps" in keys else None
        name = str(data["robot"]) if "robot" in keys else robot.name
    except (TypeError, ValueError) as exc:
        raise MotionFileError(str(path), f"wrong array types ({exc})") from None
    if name != robot.name:
        raise MotionFileError(str(path), f"this is a motion of robot {name!r}, not of "
                              f"{robot.name!r}")
    fps = fps if fps is not None else file_fps
    if fps is None:
        raise MotionFileError(str(path), "the file has no fps: pass the frame rate (--fps)")
    if joints.ndim != 2 or joints.shape[1] != len(names):
        raise MotionFileError(str(path), f"joint_positions has shape {joints.shape}, expected "
                              f"(T, {len(names)}) for {len(names)} joint names")
    if quat.ndim == 2 and quat.shape[1] == 4:
        quat = quat[:, list(_QUAT_KEYS[quat_keys[0]])]
    unknown = [n for n in names if n not in robot.joint_names]
    if unknown:
        raise MotionFileError(str(path), f"unknown joint names {_listing(unknown)}; valid "
                              f"joints of {robot.name}: {_listing(robot.joint_names, 100)}")
    absent = [n for n in robot.joint_names if n not in names]
    if absent or len(names) != len(robot.joint_names):
        raise MotionFileError(str(path), f"{len(names)} joint columns, robot {robot.name} has "
                              f"{robot.dof} joints; missing {_listing(absent)}")
    order = [names.index(n) for n in robot.joint_names]
    try:
        return RobotMotion.from_parts(base, quat, joints[:, order], fps=fps, robot=robot.name,
                                      joint_names=robot.joint_names)
    except InvalidMotionError as exc:
        raise MotionFileError(str(path), str(exc)) from None


def _check_motion(robot, motion: RobotMotion) -> None:
    if motion.robot != robot.name:
        raise ImeshError(f"the motion is for robot {motion.robot!r}, not {robot.name!r}")
    if tuple(motion.joint_names) != tuple(robot.joint_names):
        raise ImeshError(f"the motion's joints differ from robot {robot.name!r}'s: "
                         f"{_listing(motion.joint_names)} vs {_listing(robot.joint_names)}")


def arranged_source(source, robot) -> MarkerMotion:
    """The human source motion arranged for the robot (the pipeline's first stages:
    standard markers, gaps filled, arrangement per markers.toml, scaled to the robot).

    Args:
        source: a motion file path, a loaded MarkerMotion (raw, standard or already arranged:
            a motion whose markers all are key points of the robot is used as is) or an
            :class:`imesh.human.arrange.Arrangement`.
        robot: the robot.
    """
    from ..human.arrange import arrange_for_robot
    from ..morph.adapt import prepare_markers

    if isinstance(source, str | os.PathLike):
        from ..io import load_motion

        source = load_motion(source)
    elif not isinstance(source, MarkerMotion) and isinstance(getattr(source, "motion", None),
                                                             MarkerMotion):
        source = source.motion  # an imesh.human.arrange.Arrangement
    keypoints = robot.keypoint_arrays()[0]
    if all(n in keypoints for n in source.names):
        return source
    return arrange_for_robot(prepare_markers(source), robot).motion


def _markers(markers, what: str) -> MarkerMotion:
    if isinstance(markers, str | os.PathLike):
        from ..io.npz import load_marker_motion

        return load_marker_motion(markers)  # MotionFileError on anything unreadable
    return markers


def _align(markers: MarkerMotion, fps: float, n_frames: int, what: str,
           resample: bool = False) -> tuple[MarkerMotion, str]:
    """Markers at the motion's fps and frame count; a note if they were changed.

    Without ``resample`` a frame-rate or frame-count mismatch is refused: the markers are then
    not of the take the motion was made from. With it, the markers are resampled to the motion's
    fps and the first common frames are compared.

    Raises:
        SourceMismatchError: fps or frame count differ and ``resample`` is False.
    """
    fps_differs = abs(markers.fps - fps) > 1e-6 * fps
    if not resample and (fps_differs or markers.n_frames != n_frames):
        key = "fps" if fps_differs else "frames"
        raise SourceMismatchError(
            f"{what} {markers.source or ''} has {markers.n_frames} frames at {markers.fps:g} "
            f"fps, the motion {n_frames} frames at {fps:g} fps: not the take the motion was made "
            "from? valid: the same frame count and fps, or --resample (resample=True) to "
            "compare the first common frames at the motion's fps",
            what=key, expected=fps if fps_differs else n_frames,
            found=markers.fps if fps_differs else markers.n_frames)
    note = ""
    if fps_differs:
        note = f"markers resampled from {markers.fps:g} fps; "
        markers = markers.resample(fps)
    if markers.n_frames != n_frames:
        note += f"{markers.n_frames} marker frames vs {n_frames} motion frames: first " \
                f"{min(markers.n_frames, n_frames)} compared"
    return markers, note


# ----------------------------------------------------------------------------------------------
# evaluation


def _clean(value):
    """JSON-ready: numpy scalars to Python, NaN/inf to None, recursively."""
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return _clean(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _metric(name: str, value, **details) -> dict:
    value = _clean(value)
    out = {"value": value, "unit": UNITS[name], **details}
    if value is None:
        out["reason"] = "not computable (not a finite number)"
    return out


def _missing(name: str, reason: str, **details) -> dict:
    return {"value": None, "unit": UNITS[name], "reason": reason, **details}


#: Frames the evaluator's memory-hungry checks (capsule distances, inverse dynamics with the
#: soles' Jacobians) take at a time; all frames at once took 9 GB on a 30-minute clip.
EVAL_BLOCK_FRAMES = 2048


def _self_collisions_blocked(robot, q: np.ndarray, depth: float):
    """:func:`check_capsule_collisions` over blocks of :data:`EVAL_BLOCK_FRAMES` frames, merged
    into one report (the same as one call: every figure is per frame or a max/sum/first)."""
    B = EVAL_BLOCK_FRAMES
    if len(q) <= B:
        return check_capsule_collisions(robot, q, depth)
    parts = [(a, check_capsule_collisions(robot, q[a:a + B], depth)) for a in range(0, len(q), B)]
    stats: dict = {}
    for a, r in parts:
        for hit in r.pairs:
            s = stats.get(hit.frames)
            if s is None:
                stats[hit.frames] = [hit.max_depth_m, hit.worst_frame + a, hit.n_frames,
                                     hit.first_frame + a]
                continue
            if hit.max_depth_m > s[0]:
                s[0], s[1] = hit.max_depth_m, hit.worst_frame + a
            s[2] += hit.n_frames
    pairs = sorted((PairHit(frames=k, max_depth_m=v[0], worst_frame=v[1], n_frames=v[2],
                            first_frame=v[3]) for k, v in stats.items()),
                   key=lambda p: -p.max_depth_m)
    return dataclasses.replace(
        parts[0][1], colliding=np.concatenate([r.colliding for _, r in parts]), pairs=pairs,
        max_depth_m=np.concatenate([r.max_depth_m for _, r in parts]))


def _reference_dynamics_blocked(robot, q, v, a, support):
    """:func:`reference_dynamics` over blocks of :data:`EVAL_BLOCK_FRAMES` frames (its figures
    are per frame; the velocities and accelerations are the whole motion's), merged."""
    B = EVAL_BLOCK_FRAMES
    if len(q) <= B:
        return reference_dynamics(robot, q, v, a, support)
    parts = [(s, reference_dynamics(robot, q[s:s + B], v[s:s + B], a[s:s + B],
                                    support[s:s + B])) for s in range(0, len(q), B)]
    start, best = parts[0]
    for s, r in parts[1:]:
        if r.torque_ratio > best.torque_ratio:
            start, best = s, r
    friction = np.concatenate([r.friction_ratios for _, r in parts])
    sup = support.any(axis=1)
    ft = int(np.argmax(np.where(sup, friction, -1.0))) if sup.any() else -1
    return dataclasses.replace(
        best, torque_frame=best.torque_frame + start,
        friction_ratio=float(friction[ft]) if ft >= 0 else float("nan"), friction_frame=ft,
        torque_ratios=np.concatenate([r.torque_ratios for _, r in parts]),
        friction_ratios=friction)


def evaluate_motion(robot, motion: RobotMotion, source=None, physics: bool = False, *,
                    adapted=None, seconds: Mapping[str, float] | None = None,
                    physics_config=None, support_config: SupportDetection | None = None,
                    plot: str | os.PathLike | None = None, resample: bool = False) -> dict:
    """Every DESIGN.md quality metric of a robot motion.

    Args:
        robot: an :class:`imesh.robot.Robot`.
        motion: its RobotMotion (imesh output or :func:`load_motion_file`).
        source: the human source: a motion file path or MarkerMotion (raw clip, or arranged
            markers), for ``close_pair_error`` and, without ``adapted``, ``marker_rms_mm``
            against the arranged source. None: both are null.
        physics: run the DART check (``physics_*``, ``tracking_rms_rad``,
            ``torque_ratio_max``); otherwise those are null.
        adapted: the adapted markers the robot fitted (MarkerMotion or an imesh marker .npz,
            ``imesh retarget --markers``) for ``marker_rms_mm``.
        seconds: wall time [s] per pipeline stage (e.g. ``RetargetResult.seconds``) for
            ``seconds_per_frame``; default ``motion.meta["seconds"]`` if present.
        physics_config: a :class:`imesh.physics.PhysicsConfig`.
        support_config: thresholds of the support detection.
        plot: write the DART run's figure here (physics only).
        resample: compare ``source``/``adapted`` markers whose frame rate or frame count differ
            from the motion's (resampled to its fps, first common frames); by default such a
            mismatch raises SourceMismatchError.

    Returns:
        dict: exactly the keys :data:`METRIC_NAMES`; each a dict with ``value``, ``unit`` and
        details (``reason`` when ``value`` is None).

    Raises:
        ImeshError: the motion is for another robot or has other joints; unreadable source.
        SourceMismatchError: source or adapted markers of another frame count or fps (unless
            ``resample``).
    """
    _check_motion(robot, motion)
    timing: dict[str, float] = {}
    q, fps, T = motion.q, motion.fps, motion.n_frames
    out: dict[str, dict] = {}

    # --- markers -----------------------------------------------------------------------------
    t0 = time.perf_counter()
    src = None
    if source is not None:
        src = arranged_source(source, robot)
    ref_markers, ref_kind = None, ""
    if adapted is None and motion.meta.get("adapted_markers") is not None:
        adapted = motion.meta["adapted_markers"]  # stored in the motion file by retarget
    if adapted is not None:
        ref_markers, ref_kind = _markers(adapted, "adapted markers"), "adapted markers"
    elif src is not None:
        ref_markers, ref_kind = src, "arranged source markers (no adapted markers given)"
    kp_all = keypoint_motion(robot, q, fps)
    if ref_markers is None:
        out["marker_rms_mm"] = _missing("marker_rms_mm", "needs the adapted markers (--adapted) "
                                        "or the source clip (--source)")
    else:
        aligned, note = _align(ref_markers, fps, T, ref_kind.split(" (")[0], resample)
        n = min(aligned.n_frames, T)
        common = [m for m in kp_all.names if m in aligned.names]
        value = marker_rms_mm(kp_all.frames(0, n).subset(common), aligned.frames(0, n))
        out["marker_rms_mm"] = _metric("marker_rms_mm", value, reference=ref_kind,
                                       markers=len(common), frames=n, note=note or None)
    if src is None:
        out["close_pair_error"] = _missing("close_pair_error", "needs the source clip "
                                           "(--source)")
    else:
        aligned, note = _align(src, fps, T, "source", resample)
        n = min(aligned.n_frames, T)
        names = [m for m in aligned.names if m in kp_all.names]
        sub = aligned.frames(0, n).subset(names)
        robot_pts = kp_all.frames(0, n).subset(names).replace(bones=sub.bones)
        value = close_pair_error(sub, robot_pts)
        out["close_pair_error"] = _metric("close_pair_error", value,
                                          compared="arranged source vs robot key points",
                                          markers=len(names), frames=n, note=note or None)
    timing["markers"] = time.perf_counter() - t0

    # --- collisions and ground ----------------------------------------------------------------
    t0 = time.perf_counter()
    selfc = _self_collisions_blocked(robot, q, SELF_COLLISION_DEPTH_M)
    out["self_collision_frames"] = _metric(
        "self_collision_frames", selfc.n_frames, frames_total=T,
        depth_threshold_mm=1e3 * selfc.depth_m, worst_pairs=selfc.summary()["worst_pairs"],
        deepest_mm=round(1e3 * float(selfc.max_depth_m.max(initial=0.0)), 2),
        proxies="capsules (Robot.capsule_model, robots/<name>/collision_pairs.toml)")
    soles = sole_tracks(robot, q, fps)
    contacts = detect_support(soles, support_config)
    ground = check_ground(robot, q, planted=planted_feet(soles, support_config))
    out["ground_penetration_mm"] = _metric("ground_penetration_mm", ground.penetration_mm,
                                           **{k: v for k, v in ground.summary().items()
                                              if k != "penetration_mm"})
    timing["collision"] = time.perf_counter() - t0

    # --- support, skid, limits, ZMP ------------------------------------------------------------
    t0 = time.perf_counter()
    support = contacts.support
    sup_frames = int(support.any(axis=1).sum())
    skid = foot_skid(soles, support)
    if skid.samples:
        out["foot_skid_mm_per_frame"] = _metric(
            "foot_skid_mm_per_frame", skid.mean_mm_per_frame,
            fraction_over_10mm=skid.fraction_over_10mm, max_mm_per_frame=skid.max_mm_per_frame,
            support_samples=skid.samples, threshold_mm=SKID_THRESHOLD_MM)
    else:
        out["foot_skid_mm_per_frame"] = _missing(
            "foot_skid_mm_per_frame", "no support frame detected (no sole within "
            f"{(support_config or SupportDetection()).height_m * 1e3:.0f} mm of the ground and "
            "slow)")
    dev = sole_deviation(soles, support)
    if dev.samples:
        out["sole_deviation_mm"] = _metric("sole_deviation_mm", dev.deviation_mm,
                                           footprint="median sole centre of the phase on z = 0",
                                           support_samples=dev.samples)
        out["sole_tilt_deg"] = _metric("sole_tilt_deg", dev.tilt_deg,
                                       support_samples=dev.samples)
    else:
        for name in ("sole_deviation_mm", "sole_tilt_deg"):
            out[name] = _missing(name, "no support frame detected")
    lim = limit_violations(robot, q, fps)
    out["limit_violation_frames"] = _metric(
        "limit_violation_frames", int(lim.any.sum()), position=int(lim.position.sum()),
        velocity=int(lim.velocity.sum()), acceleration=int(lim.acceleration.sum()),
        worst_position_excess_rad=lim.worst_position_rad,
        worst_velocity_ratio=lim.worst_velocity_ratio,
        worst_acceleration_ratio=lim.worst_acceleration_ratio,
        position_joints=lim.position_joints, velocity_joints=lim.velocity_joints,
        acceleration_joints=lim.acceleration_joints)
    v, a = motion_derivatives(q, fps)
    if sup_frames:
        dyn = _reference_dynamics_blocked(robot, q, v, a, support)
        out["torque_ratio_ref"] = _metric("torque_ratio_ref", dyn.torque_ratio,
                                          joint=dyn.torque_joint, frame=dyn.torque_frame,
                                          note="inverse dynamics, sole wrenches least-norm")
        out["friction_ratio_max"] = _metric("friction_ratio_max", dyn.friction_ratio,
                                            frame=dyn.friction_frame, mu=MU)
    else:
        for name in ("torque_ratio_ref", "friction_ratio_max"):
            out[name] = _missing(name, "no support frame detected")
    zmp = zmp_report(zmp_trajectory(robot, q, v, a), soles, support)
    phases = {"support_frames": sup_frames, "double_support_frames":
              int(support.all(axis=1).sum()), "flight_frames": int(T - sup_frames)}
    if sup_frames:
        out["zmp_inside_fraction"] = _metric("zmp_inside_fraction", zmp.inside_fraction,
                                             max_outside_mm=zmp.max_outside_mm, **phases)
        out["zmp_error_mm"] = _metric("zmp_error_mm", zmp.error_mm,
                                      desired="sole centre (single), hull centre (double)",
                                      **phases)
    else:
        reason = "no support frame detected: the soles never touch the ground"
        out["zmp_inside_fraction"] = _missing("zmp_inside_fraction", reason, **phases)
        out["zmp_error_mm"] = _missing("zmp_error_mm", reason, **phases)
    timing["kinematics"] = time.perf_counter() - t0

    # --- physics -------------------------------------------------------------------------------
    if physics:
        from ..physics import PhysicsConfig, simulate_motion

        t0 = time.perf_counter()
        res = simulate_motion(robot, motion, config=physics_config or PhysicsConfig())
        timing["physics"] = time.perf_counter() - t0
        summary = res.summary()
        m = res.metrics()
        details = {k: summary[k] for k in ("fall_reason", "real_time_factor", "base_drift_m",
                                           "base_height_drift_m", "zmp_contact_error_mm",
                                           "saturation_fraction", "controller")}
        out["physics_fell"] = _metric("physics_fell", m["physics_fell"], **details)
        out["physics_survived_s"] = _metric("physics_survived_s", m["physics_survived_s"],
                                            duration_s=summary["duration_s"])
        out["tracking_rms_rad"] = _metric("tracking_rms_rad", m["tracking_rms_rad"])
        out["torque_ratio_max"] = _metric("torque_ratio_max", m["torque_ratio_max"],
                                          note="demanded torque before clamping / limit")
        if plot is not None:
            res.plot(plot)
    else:
        for name in ("physics_fell", "physics_survived_s", "tracking_rms_rad",
                     "torque_ratio_max"):
            out[name] = _missing(name, "physics check not run (physics=True / --physics)")

    # --- timing -------------------------------------------------------------------------------
    seconds = seconds if seconds is not None else motion.meta.get("seconds")
    evaluation = {k: v / T for k, v in timing.items()}
    if seconds:
        stages = {k: float(v) / T for k, v in seconds.items() if k != "total"}
        total = float(seconds.get("total", sum(seconds.values()))) / T
        out["seconds_per_frame"] = _metric("seconds_per_frame", total, stages=stages,
                                           evaluation=evaluation)
    else:
        out["seconds_per_frame"] = _missing(
            "seconds_per_frame", "the pipeline's timing is not stored in a motion file (pass "
            "seconds= from RetargetResult.seconds)", evaluation=evaluation)
    return {name: _clean(out[name]) for name in METRIC_NAMES}


def metric_values(report: Mapping[str, dict]) -> dict:
    """``{name: value}`` of a report of :func:`evaluate_motion`."""
    return {name: report[name]["value"] for name in report}


def _fmt(value) -> str:
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if abs(value) >= 100:
        return f"{value:.0f}"
    if abs(value) >= 1:
        return f"{value:.2f}"
    return f"{value:.4f}" if value else "0"


def _note(name: str, entry: dict) -> str:
    if entry.get("value") is None:
        return entry.get("reason", "")
    if name == "self_collision_frames" and entry.get("worst_pairs"):
        p = entry["worst_pairs"][0]
        return f"worst {p['pair'][0]}-{p['pair'][1]} {p['max_depth_mm']} mm"
    if name == "ground_penetration_mm":
        text = f"worst link {entry.get('worst_link')}" if entry.get("worst_link") else ""
        if entry.get("floating_frames"):
            text += f"; floating {entry['floating_frames']} frames"
        return text.strip("; ")
    if name == "foot_skid_mm_per_frame":
        return f"{100 * entry['fraction_over_10mm']:.1f} % of support frames > 10 mm"
    if name == "limit_violation_frames":
        return f"position {entry['position']}, velocity {entry['velocity']}"
    if name == "marker_rms_mm":
        return f"vs {entry['reference']}"
    if name == "physics_fell":
        return entry.get("fall_reason") or f"real-time factor {entry['real_time_factor']:.2f}"
    if name == "seconds_per_frame":
        return ", ".join(f"{k} {v:.4f}" for k, v in entry.get("stages", {}).items())
    return ""


def format_table(report: Mapping[str, dict]) -> str:
    """A plain-text table of a report (metric, value, unit, note)."""
    rows = [(name, _fmt(e["value"]), e["unit"], _note(name, e)) for name, e in report.items()]
    w = [max(len(r[k]) for r in rows) for k in range(3)]
    return "\n".join(f"{a:<{w[0]}}  {b:>{w[1]}}  {c:<{w[2]}}  {d}".rstrip() for a, b, c, d in rows)


# ----------------------------------------------------------------------------------------------
# command line
