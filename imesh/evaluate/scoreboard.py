"""The quality scoreboard of a robot motion: every metric of DESIGN.md, for imesh outputs and for
other retargeters' outputs alike.

:func:`evaluate_motion` returns a dict whose keys are exactly :data:`METRIC_NAMES`; each value
is a JSON-ready dict ``{"value": number | bool | None, "unit": str, ...details}``, with a
``"reason"`` when the value is None (not computable: no source markers given, physics not run,
no support frame...). :func:`metric_values` flattens it to ``{name: value}``. It is composed of
one function per group of metrics: markers, collisions and ground, support and kinematics
(skid, soles, limits, reference dynamics, ZMP), physics, timing.

Support phases come from the robot motion itself (soles within 1 cm of the ground and slower
than 0.5 m/s, with hysteresis), so plain arrays from other tools are scored on the same terms.

Motion files are read by :mod:`imesh.evaluate.motion_files`, the report printed as a table by
:mod:`imesh.evaluate.table`; the command line is ``imesh evaluate`` (:mod:`imesh.cli.evaluate`).
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from collections.abc import Mapping

import numpy as np

from ..contacts.phases import Contacts
from ..core.robot_motion import RobotMotion
from ..errors import ImeshError, _listing
from ..metrics.collision import (
    SELF_COLLISION_DEPTH_M,
    SelfCollisions,
    check_ground,
    check_self_collisions,
)
from ..metrics.derivatives import motion_derivatives
from ..metrics.dynamics import MU, ground_wrench, reference_dynamics, worst_frame
from ..metrics.flight import skid_apart_from_slides
from ..metrics.limits import limit_violations
from ..metrics.markers import (
    close_pair_error,
    keypoint_motion,
    marker_rms_by_name_mm,
    marker_rms_mm,
    marker_rms_worst_window,
)
from ..metrics.skid import SKID_THRESHOLD_MM, sole_deviation
from ..metrics.soles import SoleTracks, sole_tracks
from ..metrics.support import EVALUATOR_SUPPORT, SupportDetection, motion_support, planted_feet
from ..metrics.zmp import multibody_zmp, zmp_jitter_mm, zmp_report
from ..physics import PhysicsConfig, simulate_motion
from ..viz.physics import plot_physics
from .motion_files import align_markers, arranged_source, clip_frames_of, read_markers

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


def _check_motion(robot, motion: RobotMotion) -> None:
    """Refuse a motion of another robot or with other joints (ImeshError)."""
    if motion.robot != robot.name:
        raise ImeshError(f"the motion is for robot {motion.robot!r}, not {robot.name!r}")
    if tuple(motion.joint_names) != tuple(robot.joint_names):
        raise ImeshError(f"the motion's joints differ from robot {robot.name!r}'s: "
                         f"{_listing(motion.joint_names)} vs {_listing(robot.joint_names)}")


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


#: Length [s] of the window ``marker_rms_mm`` names as the motion's worst (``worst_window``):
#: half a second, a step or a gesture, so a refusal says when as well as where.
WORST_WINDOW_S = 0.5

#: Frames the evaluator's memory-hungry checks (capsule distances, inverse dynamics with the
#: soles' Jacobians) take at a time; all frames at once took 9 GB on a 30-minute clip.
EVAL_BLOCK_FRAMES = 2048


def _reference_dynamics_blocked(robot, q, v, a, wrench, support):
    """:func:`reference_dynamics` over blocks of :data:`EVAL_BLOCK_FRAMES` frames (its figures
    are per frame; the velocities, accelerations and the ground's wrench (T, 6) are the whole
    motion's), merged."""
    B = EVAL_BLOCK_FRAMES
    if len(q) <= B:
        return reference_dynamics(robot, q, v, a, support, wrench)
    parts = [(s, reference_dynamics(robot, q[s:s + B], v[s:s + B], a[s:s + B],
                                    support[s:s + B], wrench[s:s + B]))
             for s in range(0, len(q), B)]
    start, best = parts[0]
    for s, r in parts[1:]:
        if r.torque_ratio > best.torque_ratio:
            start, best = s, r
    friction = np.concatenate([r.friction_ratios for _, r in parts])
    yaw = np.concatenate([r.yaw_ratios for _, r in parts])
    ft, fv = worst_frame(friction, support.any(axis=1))
    yt, yv = worst_frame(yaw, support.sum(axis=1) == 1)
    return dataclasses.replace(
        best, torque_frame=best.torque_frame + start, friction_ratio=fv, friction_frame=ft,
        torque_ratios=np.concatenate([r.torque_ratios for _, r in parts]),
        friction_ratios=friction, yaw_ratio=yv, yaw_frame=yt, yaw_ratios=yaw)


def evaluate_motion(robot, motion: RobotMotion, source=None, physics: bool = False, *,
                    adapted=None, seconds: Mapping[str, float] | None = None,
                    physics_config=None, support_config: SupportDetection | None = None,
                    plot: str | os.PathLike | None = None, resample: bool = False,
                    physics_result=None, collisions: SelfCollisions | None = None,
                    scene=None) -> dict:
    """Every DESIGN.md quality metric of a robot motion.

    Args:
        robot: an :class:`imesh.robot.Robot`.
        motion: its RobotMotion (imesh output or
            :func:`~imesh.evaluate.motion_files.load_motion_file`).
        source: the human source: a motion file path or MarkerMotion (raw clip, or arranged
            markers), for ``close_pair_error`` and, without ``adapted``, ``marker_rms_mm``
            against the arranged source. None: both are null.
        physics: run the DART check (``physics_*``, ``tracking_rms_rad``,
            ``torque_ratio_max``); otherwise those are null.
        adapted: the adapted markers the robot fitted (MarkerMotion or an imesh marker .npz,
            ``imesh retarget --markers``) for ``marker_rms_mm``.
        seconds: wall time [s] per pipeline stage (e.g. ``RetargetResult.seconds``) for
            ``seconds_per_frame``; None: that metric is null.
        physics_config: a :class:`imesh.physics.PhysicsConfig`.
        support_config: thresholds of the support detection (motions without the plan's
            ``contact_modes``; with them the soles are judged by the planned support).
        plot: write the DART run's figure here (physics only).
        resample: compare ``source``/``adapted`` markers whose frame rate or frame count differ
            from the motion's (resampled to its fps, first common frames); by default such a
            mismatch raises SourceMismatchError.
        physics_result: a :class:`imesh.physics.PhysicsResult` of this motion already
            computed (``simulate_motion``): its figures are reported (:func:`physics_entries`)
            without running the check again, whatever ``physics`` says.
        collisions: the :func:`~imesh.metrics.collision.check_self_collisions` result of this
            motion already computed (e.g. for the viewer's scene): reported, not computed again.
        scene: the motion's props in the robot's world (:class:`imesh.scene.Scene`), put in
            the DART check's world (physics only; the scene's own metrics are
            :func:`imesh.evaluate.props.evaluate_scene`'s).

    Returns:
        dict: exactly the keys :data:`METRIC_NAMES`; each a dict with ``value``, ``unit`` and
        details (``reason`` when ``value`` is None).

    Raises:
        ImeshError: the motion is for another robot or has other joints; unreadable source.
        SourceMismatchError: source or adapted markers of another frame count or fps (unless
            ``resample``).
    """
    _check_motion(robot, motion)
    q, fps, T = motion.q, motion.fps, motion.n_frames
    timing: dict[str, float] = {}  # the evaluator's own seconds per group

    t0 = time.perf_counter()
    out = _marker_metrics(robot, motion, source, adapted, resample)
    timing["markers"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    soles = sole_tracks(robot, q, fps)
    support_config = support_config or EVALUATOR_SUPPORT  # flat sliding soles carry the body
    contacts = motion_support(soles, motion.contact_modes, support_config)
    out.update(_collision_metrics(robot, q, soles, support_config, collisions))
    timing["collision"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    out.update(_kinematics_metrics(robot, q, fps, soles, contacts, support_config,
                                   planned=motion.contact_modes is not None))
    timing["kinematics"] = time.perf_counter() - t0

    if physics_result is not None:
        out.update(physics_entries(physics_result))
        if plot is not None:
            plot_physics(physics_result, plot)
    elif physics:
        physics_metrics, timing["physics"] = _physics_metrics(robot, motion, physics_config,
                                                              plot, scene)
        out.update(physics_metrics)
    else:
        for name in ("physics_fell", "physics_survived_s", "tracking_rms_rad",
                     "torque_ratio_max"):
            out[name] = _missing(name, "physics check not run (physics=True / --physics)")

    out["seconds_per_frame"] = _seconds_metric(
        seconds, timing, T)
    return {name: _clean(out[name]) for name in METRIC_NAMES}


def _marker_metrics(robot, motion: RobotMotion, source, adapted, resample: bool
                    ) -> dict[str, dict]:
    """``marker_rms_mm`` (against the adapted markers: given, stored in the motion file, or the
    arranged source without them) and ``close_pair_error`` (against the arranged source)."""
    src = arranged_source(source, robot, motion.provenance) if source is not None else None
    ref_markers, ref_kind = None, ""
    if adapted is None and motion.adapted is not None:
        adapted = motion.adapted  # stored in the motion file by retarget
    kp_all = keypoint_motion(robot, motion.q, motion.fps)
    kp_src, kp_ref, src_note = kp_all, kp_all, ""
    if src is not None:  # the clip's own frames of the motion (its provenance says which)
        src, (start, stop), src_note = clip_frames_of(src, motion)
        kp_src = kp_all.frames(start, stop)
    if adapted is not None:
        ref_markers, ref_kind = read_markers(adapted), "adapted markers"
    elif src is not None:
        ref_markers, ref_kind = src, "arranged source markers (no adapted markers given)"
        kp_ref = kp_src
    out: dict[str, dict] = {}
    if ref_markers is None:
        out["marker_rms_mm"] = _missing("marker_rms_mm", "needs the adapted markers (--adapted) "
                                        "or the source clip (--source)")
    else:
        aligned, note = align_markers(ref_markers, kp_ref.fps, kp_ref.n_frames,
                                      ref_kind.split(" (")[0], resample)
        note = (src_note if kp_ref is kp_src else "") + note
        n = min(aligned.n_frames, kp_ref.n_frames)
        common = [m for m in kp_ref.names if m in aligned.names]
        kp_n, markers_n = kp_ref.frames(0, n).subset(common), aligned.frames(0, n)
        value = marker_rms_mm(kp_n, markers_n)
        by_name = marker_rms_by_name_mm(kp_n, markers_n)
        # when: the half second of the motion farthest from its markers
        a_w, b_w, rms_w = marker_rms_worst_window(kp_n, markers_n,
                                                  round(WORST_WINDOW_S * kp_n.fps))
        worst_window = {"frames": [a_w, b_w], "seconds": [round(a_w / kp_n.fps, 2),
                                                          round(b_w / kp_n.fps, 2)],
                        "rms_mm": round(rms_w, 1)}
        split = {}
        if kp_ref is kp_all and motion.provenance is not None and n == motion.n_frames:
            # the clip's own frames and the lead-in/out apart: the lead's targets are the
            # clip's first and last frames held still, not the performer's
            a, b = motion.provenance.clip_frames(n)
            # the worst window on the clip's own clock too
            worst_window["clip_seconds"] = [round((a_w - a) / kp_n.fps, 2),
                                            round((b_w - a) / kp_n.fps, 2)]
            lead = np.r_[0:a, b:n]
            split = {"clip_frames_mm": round(marker_rms_mm(kp_n.frames(a, b),
                                                           markers_n.frames(a, b)), 1)}
            if len(lead):
                split["lead_frames_mm"] = round(marker_rms_mm(
                    kp_n.with_positions(kp_n.positions_m[lead]),
                    markers_n.with_positions(markers_n.positions_m[lead])), 1)
        out["marker_rms_mm"] = _metric("marker_rms_mm", value, reference=ref_kind,
                                       markers=len(common), frames=n, **split,
                                       by_marker_mm={k: round(v, 1) for k, v in by_name.items()},
                                       worst_window=worst_window,
                                       note=note.rstrip("; ") or None)
    if src is None:
        out["close_pair_error"] = _missing("close_pair_error", "needs the source clip "
                                           "(--source)")
    else:
        aligned, note = align_markers(src, kp_src.fps, kp_src.n_frames, "source", resample)
        n = min(aligned.n_frames, kp_src.n_frames)
        names = [m for m in aligned.names if m in kp_src.names]
        sub = aligned.frames(0, n).subset(names)
        robot_pts = kp_src.frames(0, n).subset(names).replace(bones=sub.bones)
        value = close_pair_error(sub, robot_pts)
        out["close_pair_error"] = _metric("close_pair_error", value,
                                          compared="arranged source vs robot key points",
                                          markers=len(names), frames=n,
                                          note=(src_note + note).rstrip("; ") or None)
    return out


def _collision_metrics(robot, q: np.ndarray, soles: SoleTracks,
                       support_config: SupportDetection | None,
                       selfc: SelfCollisions | None = None) -> dict[str, dict]:
    """``self_collision_frames`` (the URDF's own geometry, with the capsules' figure beside it)
    and ``ground_penetration_mm``; ``selfc``: the self-collision check, if already made."""
    if selfc is None:
        selfc = check_self_collisions(robot, q, SELF_COLLISION_DEPTH_M,
                                      block_frames=EVAL_BLOCK_FRAMES)
    mesh, caps = selfc.mesh, selfc.capsules
    ground = check_ground(robot, q, planted=planted_feet(soles, support_config))
    return {
        "self_collision_frames": _metric(
            "self_collision_frames", mesh.n_frames, frames_total=len(q),
            depth_threshold_mm=1e3 * mesh.depth_m, worst_pairs=mesh.summary()["worst_pairs"],
            deepest_mm=round(mesh.deepest_mm, 2),
            geometry=f"URDF {mesh.geometry} geometry (coal), the capsules' body pairs and "
                     "ignore list (robots/<name>/collision_pairs.toml)",
            capsule_frames=caps.n_frames, capsule_deepest_mm=round(caps.deepest_mm, 2),
            capsule_worst_pairs=caps.summary()["worst_pairs"]),
        "ground_penetration_mm": _metric("ground_penetration_mm", ground.penetration_mm,
                                         **{k: v for k, v in ground.summary().items()
                                            if k != "penetration_mm"}),
    }


def _kinematics_metrics(robot, q: np.ndarray, fps: float, soles: SoleTracks,
                        contacts: Contacts, support_config: SupportDetection | None, *,
                        planned: bool) -> dict[str, dict]:
    """The soles during support (skid, deviation, tilt), the joint limits, the reference
    dynamics (torques, friction) and the ZMP; ``contacts``: the support phases (``planned``:
    the motion's own, else detected)."""
    support = contacts.support
    out = _sole_metrics(soles, contacts, support_config, planned=planned)
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
    com, dh, _ = robot.centroidal_trajectory(q, v, fps)  # one pinocchio pass for both
    out.update(_dynamics_metrics(robot, q, v, a, ground_wrench(q, com, dh, robot.mass),
                                 support))
    out.update(_zmp_metrics(robot, com, dh, soles, support))
    return out


def _sole_metrics(soles: SoleTracks, contacts: Contacts,
                  support_config: SupportDetection | None, *, planned: bool) -> dict[str, dict]:
    """``foot_skid_mm_per_frame``, ``sole_deviation_mm`` and ``sole_tilt_deg`` over the
    support frames; a planned slide or pivot (and the frames next to it) counts apart from
    skid (``slide_mm_per_frame``) and is no footprint."""
    out: dict[str, dict] = {}
    support, moving = np.asarray(contacts.support), contacts.moving
    origin = ("planned (the motion's contact modes)" if planned else
              "detected from the soles")
    none = "no support frame planned" if planned else "no support frame detected"
    skid, slide = skid_apart_from_slides(soles, support, moving)
    if skid.samples:
        out["foot_skid_mm_per_frame"] = _metric(
            "foot_skid_mm_per_frame", skid.mean_mm_per_frame,
            fraction_over_10mm=skid.fraction_over_10mm, max_mm_per_frame=skid.max_mm_per_frame,
            support_samples=skid.samples, threshold_mm=SKID_THRESHOLD_MM, support=origin,
            slide_samples=slide.samples,
            slide_mm_per_frame=slide.mean_mm_per_frame if slide.samples else None)
    else:
        out["foot_skid_mm_per_frame"] = _missing(
            "foot_skid_mm_per_frame", none if planned else
            f"{none} (no sole within "
            f"{(support_config or SupportDetection()).height_m * 1e3:.0f} mm of the ground and "
            "slow)")
    dev = sole_deviation(soles, support & ~moving)
    if dev.samples:
        out["sole_deviation_mm"] = _metric("sole_deviation_mm", dev.deviation_mm,
                                           footprint="median sole centre of the phase on z = 0",
                                           support_samples=dev.samples, support=origin)
        out["sole_tilt_deg"] = _metric("sole_tilt_deg", dev.tilt_deg,
                                       support_samples=dev.samples)
    else:
        for name in ("sole_deviation_mm", "sole_tilt_deg"):
            out[name] = _missing(name, none)
    return out


def _dynamics_metrics(robot, q: np.ndarray, v: np.ndarray, a: np.ndarray, wrench: np.ndarray,
                      support: np.ndarray) -> dict[str, dict]:
    """``torque_ratio_ref`` and ``friction_ratio_max`` of the motion's inverse dynamics."""
    if not support.any():
        return {name: _missing(name, "no support frame detected")
                for name in ("torque_ratio_ref", "friction_ratio_max")}
    dyn = _reference_dynamics_blocked(robot, q, v, a, wrench, support)
    return {
        "torque_ratio_ref": _metric("torque_ratio_ref", dyn.torque_ratio,
                                    joint=dyn.torque_joint, frame=dyn.torque_frame,
                                    note="inverse dynamics, sole wrenches least-norm"),
        "friction_ratio_max": _metric("friction_ratio_max", dyn.friction_ratio,
                                      frame=dyn.friction_frame, mu=MU,
                                      yaw_ratio=_clean(dyn.yaw_ratio), yaw_frame=dyn.yaw_frame),
    }


def _zmp_metrics(robot, com: np.ndarray, dh: np.ndarray, soles: SoleTracks,
                 support: np.ndarray) -> dict[str, dict]:
    """``zmp_inside_fraction`` and ``zmp_error_mm`` of the multibody ZMP, with the frame counts
    of the support phases and the ZMP's frame-to-frame swing the central differences do not
    see (``zmp_jitter_mm``, :func:`imesh.metrics.zmp.zmp_jitter_mm`)."""
    zmp = zmp_report(multibody_zmp(com, dh, robot.mass), soles, support)
    sup_frames = int(support.any(axis=1).sum())
    jitter = _clean(zmp_jitter_mm(com, soles.fps, np.asarray(support.any(axis=1))))
    phases = {"support_frames": sup_frames, "double_support_frames":
              int(support.all(axis=1).sum()), "flight_frames": int(len(com) - sup_frames)}
    if not sup_frames:
        reason = "no support frame detected: the soles never touch the ground"
        return {"zmp_inside_fraction": _missing("zmp_inside_fraction", reason, **phases),
                "zmp_error_mm": _missing("zmp_error_mm", reason, **phases)}
    return {
        "zmp_inside_fraction": _metric("zmp_inside_fraction", zmp.inside_fraction,
                                       max_outside_mm=zmp.max_outside_mm,
                                       zmp_jitter_mm=jitter, **phases),
        "zmp_error_mm": _metric("zmp_error_mm", zmp.error_mm,
                                desired="sole centre (single), hull centre (double)", **phases),
    }


def _physics_metrics(robot, motion: RobotMotion, config, plot: str | os.PathLike | None,
                     scene=None) -> tuple[dict[str, dict], float]:
    """The DART check's metrics (``physics_*``, ``tracking_rms_rad``, ``torque_ratio_max``) and
    the seconds the simulation took, with ``scene``'s props in its world; writes its figure
    to ``plot`` when given."""
    t0 = time.perf_counter()
    res = simulate_motion(robot, motion, config=config or PhysicsConfig(), scene=scene)
    seconds = time.perf_counter() - t0
    out = physics_entries(res)
    if plot is not None:
        plot_physics(res, plot)
    return out, seconds


def physics_entries(res) -> dict[str, dict]:
    """The report entries of a DART check (``physics_fell``, ``physics_survived_s``,
    ``tracking_rms_rad``, ``torque_ratio_max``, JSON-ready) from its
    :class:`imesh.physics.PhysicsResult`; ``physics_fell`` carries the other figures as details
    (fall reason, base drift [m], key-point error RMS and max [mm], controller...)."""
    summary = res.summary()
    m = res.metrics()
    details = {k: summary[k] for k in ("fall_reason", "real_time_factor", "base_drift_m",
                                       "base_height_drift_m", "keypoint_rms_mm",
                                       "keypoint_max_mm", "keypoint_worst", "keypoint_worst_s",
                                       "slip_mm", "slip_side", "slip_s",
                                       "zmp_contact_error_mm", "saturation_fraction",
                                       "controller", "props", "link_contact_force_max_n")}
    out = {
        "physics_fell": _metric("physics_fell", m["physics_fell"], **details),
        "physics_survived_s": _metric("physics_survived_s", m["physics_survived_s"],
                                      duration_s=summary["duration_s"]),
        "tracking_rms_rad": _metric("tracking_rms_rad", m["tracking_rms_rad"]),
        "torque_ratio_max": _metric("torque_ratio_max", m["torque_ratio_max"],
                                    note="demanded torque before clamping / limit"),
    }
    return {name: _clean(entry) for name, entry in out.items()}


def _seconds_metric(seconds: Mapping[str, float] | None, timing: Mapping[str, float],
                    n_frames: int) -> dict:
    """``seconds_per_frame`` from the pipeline's stage times (None: not computable), with the
    evaluator's own ``timing`` per frame as a detail."""
    evaluation = {k: v / n_frames for k, v in timing.items()}
    if not seconds:
        return _missing(
            "seconds_per_frame", "the pipeline's timing is not stored in a motion file (pass "
            "seconds= from RetargetResult.seconds)", evaluation=evaluation)
    stages = {k: float(v) / n_frames for k, v in seconds.items() if k != "total"}
    total = float(seconds.get("total", sum(seconds.values()))) / n_frames
    return _metric("seconds_per_frame", total, stages=stages, evaluation=evaluation)


def metric_values(report: Mapping[str, dict]) -> dict:
    """``{name: value}`` of a report of :func:`evaluate_motion`."""
    return {name: report[name]["value"] for name in report}
