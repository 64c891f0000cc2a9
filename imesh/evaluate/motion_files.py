"""Motions and markers as written, read for the evaluator (:mod:`imesh.evaluate.scoreboard`).

Motion files (:func:`load_motion_file`):

- imesh robot motions (``.npz``/``.csv`` written by
  :func:`imesh.io.robot_motion.save_robot_motion`), including files of other tools written in that
  layout; the adapted markers an imesh ``.npz`` carries go to ``motion.adapted``;
- GMR's motion pickle (``.pkl``: ``fps``, ``root_pos``, ``root_rot`` xyzw, ``dof_pos`` in the
  joint order of GMR's model, mapped by name; :mod:`imesh.io.gmr`);
- plain ``.npz`` arrays: ``joint_names`` (n,) str, ``joint_positions`` (T, n) [rad],
  ``base_position`` (T, 3) [m] (world, Z up, ground z = 0), the base orientation as
  ``base_quat_xyzw`` or ``base_quat_wxyz`` (T, 4) (the key names the order), ``fps`` (or pass
  fps=), optionally ``robot`` (must match). The base is the URDF root link.

The markers a motion is compared with: :func:`arranged_source` (the human clip arranged for the
robot), :func:`read_markers` (adapted markers) and :func:`align_markers` (the motion's frame rate
and frame count).
"""

from __future__ import annotations

import dataclasses
import logging
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..core.motion import MarkerMotion
from ..core.provenance import Provenance, file_sha256
from ..core.robot_motion import RobotMotion
from ..errors import (
    ImeshError,
    InvalidMotionError,
    MotionFileError,
    SourceMismatchError,
    _listing,
)
from ..human.arrange import arrange_for_robot
from ..io import load_motion
from ..io.clip import read_clip
from ..io.gmr import is_gmr, read_gmr
from ..io.npz import load_marker_motion, load_npz
from ..io.robot_motion import NPZ_KEYS, load_robot_motion
from ..morph.adapt import prepare_markers

log = logging.getLogger(__name__)

_QUAT_KEYS = {"base_quat_xyzw": (0, 1, 2, 3), "base_quat_wxyz": (1, 2, 3, 0)}


def load_motion_file(path: str | os.PathLike, robot, fps: float | None = None) -> RobotMotion:
    """Read a robot motion to evaluate: an imesh robot motion or plain arrays (module docstring).

    Args:
        path: ``.npz``, ``.csv`` or GMR ``.pkl`` file.
        robot: the :class:`imesh.robot.Robot` the motion is for (names and joints are checked;
            columns are reordered into ``robot.joint_names`` order).
        fps: frame rate for files that store none [1/s].

    Raises:
        MotionFileError: unreadable file, wrong shapes or joint count, unknown or missing joint
            names (listing the valid ones), non-finite values, a motion of another robot.
        GMRJointError: a GMR pickle lacking joints of the robot (named).
    """
    path = Path(path)
    if is_gmr(path):
        return read_gmr(path, robot, fps)
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
        motion = dataclasses.replace(motion, adapted=adapted)
    if fps is not None and abs(fps - motion.fps) > 1e-6 * motion.fps:
        log.warning("%s: the file says %g fps; using %g fps as asked", path, motion.fps, fps)
        motion = RobotMotion(q=motion.q, fps=fps, robot=motion.robot,
                             joint_names=motion.joint_names, adapted=motion.adapted,
                             contact_modes=motion.contact_modes)
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
    """A motion of plain ``.npz`` arrays (module docstring), joints in ``robot``'s order."""
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


def arranged_source(source, robot, provenance: Provenance | None = None) -> MarkerMotion:
    """The human source motion arranged for the robot (the pipeline's first stages:
    standard markers, gaps filled, arrangement per markers.toml, scaled to the robot).

    Args:
        source: a motion file path, a loaded MarkerMotion (raw, standard or already arranged:
            a motion whose markers all are key points of the robot is used as is) or an
            :class:`imesh.human.arrange.Arrangement`.
        robot: the robot.
        provenance: the provenance of the motion the source is compared with, when it has one:
            a file must be the clip it names (same SHA-256) and is read with the options the
            retarget read it with (``--units``, ``--fps``, ``--rig`` ...); a loaded clip must
            have its frame count and frame rate.

    Raises:
        SourceMismatchError: another clip than the provenance's (``what`` is ``"sha256"``,
            ``"frames"`` or ``"fps"``).
    """
    clip = provenance.source if provenance is not None else None
    if isinstance(source, str | os.PathLike):
        if clip is not None:
            found = file_sha256(source) if Path(source).is_file() else "no such file"
            if found != clip.sha256:
                raise SourceMismatchError(
                    f"{source} is not the clip the motion was made from: its SHA-256 is "
                    f"{found[:16]}..., the motion's provenance names {clip.path} with SHA-256 "
                    f"{clip.sha256[:16]}...; valid: that clip (or a copy of it)",
                    what="sha256", expected=clip.sha256, found=found)
            source = read_clip(source, clip.load)
        else:
            source = load_motion(source)
    elif not isinstance(source, MarkerMotion) and isinstance(getattr(source, "motion", None),
                                                             MarkerMotion):
        source = source.motion  # an imesh.human.arrange.Arrangement
    if clip is not None:
        fps_differs = abs(source.fps - clip.fps) > 1e-6 * clip.fps
        if fps_differs or source.n_frames != clip.frames:
            raise SourceMismatchError(
                f"source {source.source or ''} has {source.n_frames} frames at "
                f"{source.fps:g} fps, the clip the motion was made from ({clip.path}) "
                f"{clip.frames} frames at {clip.fps:g} fps; valid: that clip, read as it was "
                f"(options {dict(clip.load) or 'none'})",
                what="fps" if fps_differs else "frames",
                expected=clip.fps if fps_differs else clip.frames,
                found=source.fps if fps_differs else source.n_frames)
    keypoints = robot.keypoint_arrays()[0]
    if all(n in keypoints for n in source.names):
        return source
    return arrange_for_robot(prepare_markers(source), robot).motion


def clip_frames_of(source: MarkerMotion, motion: RobotMotion
                   ) -> tuple[MarkerMotion, tuple[int, int], str]:
    """The source markers and the frames of ``motion`` to compare them with.

    A motion with a provenance holds the clip on its frames ``[lead_in, T - lead_out)`` at its
    own frame rate: the source is resampled to that rate as the retarget did, and those frames
    are compared. A motion without one: the source as it is and every frame.

    Returns:
        (source markers, (start, stop) frames of ``motion``, a note of what was done).
    """
    if motion.provenance is None:
        return source, (0, motion.n_frames), ""
    start, stop = motion.provenance.clip_frames(motion.n_frames)
    note = ""
    if abs(source.fps - motion.fps) > 1e-6 * motion.fps:
        note = f"source resampled from {source.fps:g} fps as the retarget did; "
        source = source.resample(motion.fps)
    if (start, stop) != (0, motion.n_frames):
        note += f"the clip's frames {start}..{stop - 1} (lead-in/out excluded); "
    return source, (start, stop), note


def read_markers(markers: MarkerMotion | str | os.PathLike) -> MarkerMotion:
    """Markers given as a MarkerMotion or an imesh marker file (``imesh retarget --markers``).

    Raises:
        MotionFileError: an unreadable marker file.
    """
    if isinstance(markers, str | os.PathLike):
        return load_marker_motion(markers)
    return markers


def align_markers(markers: MarkerMotion, fps: float, n_frames: int, what: str,
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
