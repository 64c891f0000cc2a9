"""Where benchmarks find the shared data and the robots (IMESH_DATA, default ../shared/data)."""

from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def data_root() -> Path:
    return Path(os.environ.get("IMESH_DATA", ROOT.parent / "shared" / "data")).resolve()


def load(name: str):
    """A robot by name (HRP-4C from the shared URDF, as a user-supplied model)."""
    from imesh.robot import load_robot

    urdf = data_root().parent / "robots" / "hrp4c" / "HRP4Cmain_reduced.urdf"
    return load_robot(name, urdf=urdf if name == "hrp4c" else None)


def write_and_read(out: Path, stem: str, result, robot):
    """Write a retarget result as ``imesh retarget`` does (``OUT/STEM.npz`` and the adapted
    markers ``OUT/STEM_markers.npz``) and read the motion back, so benchmarks score the written
    file. Returns (the motion read back, the markers' path)."""
    from imesh.io.npz import save_marker_motion
    from imesh.io.robot_motion import load_robot_motion, save_robot_motion

    path, markers = out / f"{stem}.npz", out / f"{stem}_markers.npz"
    save_robot_motion(path, result.motion)
    save_marker_motion(markers, result.adapted)
    return load_robot_motion(path, robot), markers


def score_written(robot, result, source, out: Path, stem: str, physics: bool = False):
    """Write a retarget result, read it back and score it as ``imesh evaluate`` does; the
    close-pair error against the source clip on the clip's own frames (the whole-body solve's
    lead-in and lead-out are not the clip's). Returns (the motion read back, metric values,
    ``slide_mm_per_frame``, the planned slides' motion the evaluator reports apart from skid, and
    ``yaw_ratio``, the friction ratio's single-support yaw detail)."""
    from imesh.evaluate.scoreboard import evaluate_motion, metric_values

    written, markers = write_and_read(out, stem, result, robot)
    report = evaluate_motion(robot, written, adapted=str(markers), physics=physics)
    m = metric_values(report)
    # the planned slides' motion, which the evaluator reports apart from the skid
    m["slide_mm_per_frame"] = report["foot_skid_mm_per_frame"].get("slide_mm_per_frame")
    # the single-support soles' yaw friction share, a detail of the friction ratio
    m["yaw_ratio"] = report["friction_ratio_max"].get("yaw_ratio")
    if physics:  # why the DART check lost it, a detail of physics_fell
        m["physics_fall_reason"] = report["physics_fell"].get("fall_reason", "")
    a, b = result.lead_frames
    m["close_pair_error"] = metric_values(evaluate_motion(
        robot, written.frames(a, written.n_frames - b), source=source,
        resample=True))["close_pair_error"]
    return written, m


def cell(m: dict, key: str, fmt: str) -> str:
    """A table cell: the metric formatted, or n/a when it was not measured."""
    v = m.get(key)
    return format(v, fmt) if isinstance(v, (int, float)) else "n/a"


def cells(m: dict, *columns: tuple[str, str]) -> str:
    """Table cells of the metrics ``(key, format)`` separated by one space (:func:`cell`)."""
    return " ".join(cell(m, key, fmt) for key, fmt in columns)


#: The gated figures of a written motion as table columns ``(metric, format)``: marker RMS,
#: limit-violation and self-collision frames, ground penetration, ZMP inside.
GATED_COLUMNS = (("marker_rms_mm", "7.1f"), ("limit_violation_frames", "4d"),
                 ("self_collision_frames", "4d"), ("ground_penetration_mm", "6.1f"),
                 ("zmp_inside_fraction", "6.3f"))


def gates_failed(m: dict) -> dict:
    """The retarget's gates a written motion's metric values fail (``imesh retarget`` would
    not write it): metric -> (value, gate)."""
    from imesh.evaluate.verify import failed_gates

    return failed_gates({k: {"value": v} for k, v in m.items()})
