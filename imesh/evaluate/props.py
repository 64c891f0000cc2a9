"""The scene's scoreboard: what a robot motion does to the props of its scene (docs/terrain.md).

:func:`evaluate_scene` adds, when a scene is given (``imesh evaluate OUT.npz`` finds
``OUT.scene.npz`` beside it; ``--scene`` names one), entries in the evaluator's format
(``{"value", "unit", ...details}``, a ``"reason"`` when the value is None):

- ``prop_penetration_mm``: deepest penetration of the robot's collision proxies into a prop.
- ``prop_penetration_frames``: frames with a prop penetrated deeper than 10 mm.
- ``prop_contacts_kept``: fraction of the human's prop contacts (toes, hands, knees within their
  thresholds of a prop, on the clip's frames) that the robot keeps: the link of the marker's key
  point within 20 mm of the same prop (needs the source clip: ``--source`` or the provenance).
- ``surface_skid_mm_per_frame``: ``foot_skid_mm_per_frame`` on every surface: the mean slide of
  a sole supporting on the floor or on a prop, per 1/30 s, with the support the flat figure
  takes (the motion's planned contact modes, slides apart; else the evaluator's detection
  measured from each surface); the largest slide, its 95th percentile and the share over 10 mm
  beside it.
- ``human_prop_contact_frames``: the human's contact frames per prop and effector (a table,
  no single value: its ``value`` is the total).
- ``cwc_inside_fraction``: fraction of frames whose gravito-inertial wrench is inside the
  contact wrench cone of the robot's own contacts (soles and hand / knee points within 10 mm
  of the floor or a prop's top; :mod:`imesh.metrics.cwc`).

The props are measured in the robot's world (the scene's scaled props); the human's contacts in
the human's world (the scene's unscaled props), with the thresholds of
:data:`imesh.metrics.props.HUMAN_CONTACT_M`.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from ..core.motion import MarkerMotion
from ..core.robot_motion import RobotMotion
from ..errors import ImeshError
from ..human.standard import to_standard
from ..io import load_motion
from ..io.clip import read_clip
from ..metrics.cwc import cwc_balance
from ..metrics.props import (
    CONTACT_KEPT_M,
    PENETRATION_COUNT_M,
    ProxyPoints,
    contact_preservation,
    human_contacts,
    prop_penetration,
    surface_skid,
)
from ..scene import Scene, find_scene, prop_planes, scene_from_files
from ..scene.morph_frame import scene_for_clip
from .motion_files import clip_frames_of

log = logging.getLogger(__name__)

__all__ = ["SCENE_METRICS", "evaluate_scene", "human_scene_contacts", "scene_for_motion",
           "format_scene_table"]

#: Scene metric -> unit.
SCENE_METRICS = {
    "prop_penetration_mm": "mm",
    "prop_penetration_frames": "frames",
    "prop_contacts_kept": "fraction",
    "surface_skid_mm_per_frame": "mm per 1/30 s",
    "human_prop_contact_frames": "frames",
    "cwc_inside_fraction": "fraction",
}


def _raw_source(source, motion: RobotMotion) -> MarkerMotion | None:
    """The human clip as loaded (a path read with the provenance's options; by default the
    provenance's clip when its file is still there)."""
    clip = motion.provenance.source if motion.provenance is not None else None
    if source is None and clip is not None:
        if not Path(clip.path).is_file():
            return None
        try:  # a clip the provenance names but that cannot be read again as recorded (a
            # window cut in Python, a file without its frame rate): no contact figures
            source = read_clip(clip.path, clip.load)
        except ImeshError as exc:
            log.warning("scene contacts: the provenance's clip cannot be read again (%s); pass "
                        "--source", exc)
            return None
        if source.n_frames != clip.frames:
            log.warning("scene contacts: the provenance's clip %s has %d frames, the motion was "
                        "made from %d; pass --source", clip.path, source.n_frames, clip.frames)
            return None
    elif isinstance(source, str | Path):
        source = read_clip(source, clip.load) if clip is not None else load_motion(source)
    return source


def _source_motion(source, motion: RobotMotion) -> MarkerMotion | None:
    """The human clip as standard markers."""
    raw = _raw_source(source, motion)
    return None if raw is None else to_standard(raw)


def scene_for_motion(robot, motion: RobotMotion, motion_path, files=(), *,
                     scale: float | None = None, source=None) -> Scene | None:
    """The scene to measure a motion against: ``files`` (a written ``.scene.npz``, or meshes /
    URDF in the clip's frame, mapped like the retarget with the source clip), else the
    ``.scene.npz`` beside ``motion_path``, else None.

    Raises:
        SceneFileError: unreadable scene files.
        ImeshError: meshes given without a source clip to scale them with.
    """
    if not files:
        return find_scene(motion_path)
    scene = scene_from_files(files)
    if scene.frame == "robot":
        return scene
    human = _raw_source(source, motion)
    if human is None:
        raise ImeshError(f"{motion_path}: mesh/URDF scene files are in the clip's frame and "
                         "need the clip to be scaled like the human; valid: --source CLIP (or a "
                         "motion whose provenance names its clip), or the .scene.npz that "
                         "'imesh retarget --scene' wrote")
    return scene_for_clip(files, human, robot, scale=scale, fps=motion.fps)


def human_scene_contacts(human: MarkerMotion, scene: Scene):
    """The human's prop contacts (:func:`imesh.metrics.props.human_contacts`) in the human
    world (the scene's ``human_props``, or its props for a human-world scene)."""
    props = scene.human_props or scene.props
    return human_contacts(human.positions_m, human.names, [prop_planes(p) for p in props],
                          [p.name for p in props])


def evaluate_scene(robot, motion: RobotMotion, scene: Scene, source=None) -> dict:
    """The scene metrics of a robot motion (:data:`SCENE_METRICS`, module docstring).

    Args:
        robot: the robot.
        motion: its motion.
        scene: a robot-world scene (:func:`imesh.scene.robot_scene` or a ``.scene.npz``).
        source: the human clip (path or MarkerMotion); None: the provenance's clip when it is
            still there, else the contact figures are null.
    """
    if scene.frame != "robot":
        log.warning("scene in the %s frame: measured as if it were the robot's world",
                    scene.frame)
    names = list(scene.names)
    planes = [prop_planes(p) for p in scene.props]
    points = ProxyPoints.of(robot)
    pen = prop_penetration(robot, motion.q, planes, names, points=points)
    summary = pen.summary()
    out: dict[str, dict] = {
        "prop_penetration_mm": {"value": summary["prop_penetration_mm"], "unit": "mm",
                                "props": summary["props"]},
        "prop_penetration_frames": {"value": summary["prop_penetration_frames"],
                                    "unit": "frames",
                                    "depth_mm": 1e3 * PENETRATION_COUNT_M},
    }
    cwc = cwc_balance(robot, motion.q, motion.fps, planes).summary()
    out["cwc_inside_fraction"] = {
        "value": cwc["cwc_inside_fraction"], "unit": "fraction",
        **{k: v for k, v in cwc.items() if k != "cwc_inside_fraction"}}
    skid = surface_skid(robot, motion.q, motion.fps, planes, names,
                        contact_modes=motion.contact_modes)
    out["surface_skid_mm_per_frame"] = {
        "value": None if not skid.samples else skid.mean_mm, "unit": "mm per 1/30 s",
        "max_mm": skid.max_mm, "p95": skid.p95_mm,
        "fraction_over_10mm": skid.fraction_over_10mm, "samples": skid.samples,
        "surfaces": skid.surfaces, "max_by_surface_mm": skid.max_by_surface_mm,
        "mean_by_surface_mm": skid.mean_by_surface_mm,
        "support": "planned" if skid.planned else "detected",
        "slide_mm_per_frame": None if np.isnan(skid.slide_mm) else skid.slide_mm,
        **({} if skid.samples else {"reason": "no sole touches a surface"})}
    human = _source_motion(source, motion)
    if human is None:
        reason = "needs the source clip (--source, or the provenance's clip file)"
        out["prop_contacts_kept"] = {"value": None, "unit": "fraction", "reason": reason}
        out["human_prop_contact_frames"] = {"value": None, "unit": "frames", "reason": reason}
        return out
    aligned, (start, stop), note = clip_frames_of(human, motion)
    contacts = human_scene_contacts(aligned, scene)
    per = contacts.frames()
    out["human_prop_contact_frames"] = {
        "value": int(contacts.contact.sum()), "unit": "frames", "props": per,
        "fps": aligned.fps, "note": note.strip("; ")}
    keypoints = robot.markers.keypoints
    frames = {e: keypoints[e].frame for e in contacts.effectors}
    kept = contact_preservation(robot, motion.q[:stop], contacts, frames, planes, start=start,
                                points=points)
    ks = kept.summary()
    out["prop_contacts_kept"] = {
        "value": None if not ks["prop_contact_samples"] else ks["prop_contacts_kept"],
        "unit": "fraction", "samples": ks["prop_contact_samples"], "props": ks["props"],
        "kept_mm": 1e3 * CONTACT_KEPT_M,
        **({} if ks["prop_contact_samples"] else {"reason": "the human touches no prop"})}
    return out


def format_scene_table(report: dict) -> str:
    """The scene metrics as rows of the evaluator's table, with per-prop notes."""
    from .table import _fmt

    rows = []
    for name, e in report.items():
        note = e.get("reason", "")
        if name == "prop_penetration_mm" and e.get("props"):
            note = "; ".join(f"{p} {v['deepest_mm']:.0f} mm ({v['worst_link'] or '-'})"
                             for p, v in e["props"].items())
        elif name == "human_prop_contact_frames" and e.get("props"):
            note = "; ".join(f"{p}: " + ", ".join(f"{k} {n}" for k, n in v.items())
                             for p, v in e["props"].items() if v)
        elif name == "cwc_inside_fraction":
            note = (f"{e['outside_frames']} of {e['frames']} frames outside "
                    f"({e['no_contact_frames']} without contact), worst face "
                    f"{e['worst_violation']:.2f} m/s^2")
        elif name == "surface_skid_mm_per_frame" and e.get("surfaces"):
            mean, worst = e.get("mean_by_surface_mm", {}), e.get("max_by_surface_mm", {})
            note = f"{e.get('support', 'detected')} support samples (mean / max mm) on "
            note += ", ".join(
                f"{k} {n}" + (f" ({mean[k]:.2f} / {worst[k]:.1f})" if k in worst else "")
                for k, n in e["surfaces"].items())
            if e.get("slide_mm_per_frame") is not None:
                note += f"; planned slides {e['slide_mm_per_frame']:.1f} mm apart"
        rows.append((name, _fmt(e["value"]), e["unit"], note))
    w = [max(len(r[k]) for r in rows) for k in range(3)]
    return "\n".join(f"{a:<{w[0]}}  {b:>{w[1]}}  {c:<{w[2]}}  {d}".rstrip() for a, b, c, d in rows)
