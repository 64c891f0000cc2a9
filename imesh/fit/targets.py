"""What the robot fits: key points (human marker -> robot frame + offset) and directions (a robot
frame axis -> the direction between two human markers).

By default both come from the robot's ``robots/<name>/markers.toml`` (``[keypoints]``, the
keypoints of ``[[arrangement.add]]`` markers, and ``[[directions]]``), which
:mod:`imesh.robot.markers_config` reads and validates and ``Robot.markers`` holds. Explicit lists
are accepted in plain tuple form, so the arrangement code can pass its own:

- key points: ``(marker, frame, offset_m, weight)`` (offset and weight optional), or
  ``{marker: imesh.robot.Keypoint}``;
- directions: ``(frame, axis, from_marker, to_marker, weight)`` (weight optional), or objects
  with those attributes (``imesh.robot.Direction``).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..errors import MissingMarkerError
from ..robot.errors import closest_first
from ..robot.markers_config import MarkerConfig, load_markers_config
from .errors import FitError, UnknownFrameError

log = logging.getLogger(__name__)


class KeypointTarget(NamedTuple):
    """A robot point that should coincide with a human marker.

    Attributes:
        marker: human marker name (in the fitted MarkerMotion).
        frame: robot frame name.
        offset: (3,) point in the frame [m].
        weight: residual weight (multiplies the position error; the energy scales with
            weight^2).
    """

    marker: str
    frame: str
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    weight: float = 1.0


class DirectionTarget(NamedTuple):
    """A robot frame axis that should point along the human marker direction ``to - from``.

    Attributes:
        frame: robot frame name.
        axis: (3,) axis in the frame (normalized when used).
        from_marker: human marker at the tail of the direction.
        to_marker: human marker at the head of the direction.
        weight: residual weight (multiplies the unit-vector error, ~ the angle [rad]).
    """

    frame: str
    axis: tuple[float, float, float]
    from_marker: str
    to_marker: str
    weight: float = 1.0


def _vec3(value, what: str, where: str) -> tuple[float, float, float]:
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        arr = np.zeros(0)
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise FitError(f"{where}: {what} must be 3 finite numbers, got {value!r}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def _weight(value, where: str) -> float:
    try:
        w = float(value)
    except (TypeError, ValueError):
        w = float("nan")
    if not (np.isfinite(w) and w >= 0):
        raise FitError(f"{where}: weight must be a finite number >= 0, got {value!r}")
    return w


def as_keypoints(entries: Iterable | Mapping) -> list[KeypointTarget]:
    """Normalize key points given as tuples, KeypointTargets or ``{marker: Keypoint}``.

    Raises:
        FitError: malformed entry (named in the message).
    """
    if isinstance(entries, Mapping):
        entries = [(m, k.frame, k.offset, k.weight) for m, k in entries.items()]
    out = []
    for k, entry in enumerate(entries):
        where = f"key point #{k + 1} {entry!r}"
        items = tuple(entry)
        if len(items) == 2 and hasattr(items[1], "frame"):  # (marker, imesh.robot.Keypoint)
            kp = items[1]
            items = (items[0], kp.frame, kp.offset, getattr(kp, "weight", 1.0))
        if not 2 <= len(items) <= 4:
            raise FitError(f"{where}: expected (marker, frame, offset, weight)")
        offset = _vec3(items[2], "offset", where) if len(items) > 2 else (0.0, 0.0, 0.0)
        weight = _weight(items[3], where) if len(items) > 3 else 1.0
        out.append(KeypointTarget(str(items[0]), str(items[1]), offset, weight))
    return out


def as_directions(entries: Iterable) -> list[DirectionTarget]:
    """Normalize directions given as tuples, DirectionTargets or ``imesh.robot.Direction``.

    Raises:
        FitError: malformed entry or zero axis.
    """
    out = []
    for k, entry in enumerate(entries):
        where = f"direction #{k + 1} {entry!r}"
        if hasattr(entry, "from_marker") and not isinstance(entry, tuple):
            items = (entry.frame, entry.axis, entry.from_marker, entry.to_marker,
                     getattr(entry, "weight", 1.0))
        else:
            items = tuple(entry)
        if not 4 <= len(items) <= 5:
            raise FitError(f"{where}: expected (frame, axis, from marker, to marker, weight)")
        axis = _vec3(items[1], "axis", where)
        if np.linalg.norm(axis) < 1e-9:
            raise FitError(f"{where}: axis must be non-zero")
        weight = _weight(items[4], where) if len(items) > 4 else 1.0
        out.append(DirectionTarget(str(items[0]), axis, str(items[2]), str(items[3]), weight))
    return out


def robot_targets(robot, markers_toml: str | os.PathLike | None = None
                  ) -> tuple[list[KeypointTarget], list[DirectionTarget]]:
    """Key points and directions of a robot's markers.toml.

    Args:
        robot: the robot (``robot.markers`` is used).
        markers_toml: another markers.toml to read instead (validated by
            ``imesh.robot.load_markers_config``).

    Returns:
        (key points, directions); key points of the surviving standard markers, then of the
        markers the arrangement adds.

    Raises:
        FitError: the robot has no markers.toml and none was given.
        RobotConfigError: the file is invalid (from imesh.robot).
    """
    config: MarkerConfig | None
    if markers_toml is not None:
        config = load_markers_config(markers_toml)
    else:
        config = getattr(robot, "markers", None)
        if config is None:
            raise FitError(f"robot {robot.name!r} has no markers.toml: pass keypoints= and "
                           "directions= explicitly")
    return as_keypoints(config.keypoints), as_directions(config.directions)


@dataclass(frozen=True, eq=False)
class CompiledTargets:
    """Key points and directions resolved against one robot and one marker motion.

    Attributes:
        keypoints: (K) resolved key points.
        directions: (D) resolved directions.
        kp_frame_ids: (K,) robot frame indices.
        kp_offsets: (K, 3) offsets in the frames [m].
        kp_weights: (K,) weights.
        kp_markers: (K,) marker indices in the motion.
        dir_frame_ids: (D,) robot frame indices.
        dir_axes: (D, 3) unit axes in the frames.
        dir_weights: (D,) weights.
        dir_from: (D,) marker indices of the tails.
        dir_to: (D,) marker indices of the heads.
    """

    keypoints: tuple[KeypointTarget, ...]
    directions: tuple[DirectionTarget, ...]
    kp_frame_ids: tuple[int, ...]
    kp_offsets: np.ndarray
    kp_weights: np.ndarray
    kp_markers: np.ndarray
    dir_frame_ids: tuple[int, ...]
    dir_axes: np.ndarray
    dir_weights: np.ndarray
    dir_from: np.ndarray
    dir_to: np.ndarray


def _frame_ids(robot, frames: Sequence[str]) -> list[int]:
    """Frame indices; UnknownFrameError listing all unknown names and the valid ones."""
    ids, missing = [], []
    for frame in frames:
        try:
            ids.append(int(robot.frame_id(frame)))
        except Exception:  # any lookup failure means the frame is unknown
            missing.append(frame)
    if missing:
        valid = closest_first(missing[0], list(getattr(robot, "frame_names", []) or []))
        raise UnknownFrameError(f"key points / directions name frames robot {robot.name!r} "
                                "does not have", list(dict.fromkeys(missing)), valid)
    return ids


def compile_targets(robot, names: Sequence[str], keypoints, directions, *,
                    source: str = "motion") -> CompiledTargets:
    """Validate key points and directions against the robot's frames and the motion's markers.

    Args:
        robot: the robot.
        names: marker names of the motion.
        keypoints: key points (see the module docstring), or None for the robot's markers.toml.
        directions: directions, or None for the robot's markers.toml (``[]`` for none).
        source: motion name for messages.

    Raises:
        MissingMarkerError: an entry names a marker the motion lacks (lists the available ones).
        UnknownFrameError: an entry names a frame the robot lacks (lists the valid ones).
        FitError: malformed entries, no key points, or no markers.toml when needed.
    """
    if keypoints is None or directions is None:
        default_kps, default_dirs = robot_targets(robot)
        keypoints = default_kps if keypoints is None else keypoints
        directions = default_dirs if directions is None else directions
    kps = as_keypoints(keypoints)
    dirs = as_directions(directions)
    if not kps:
        raise FitError(f"nothing to fit for robot {robot.name!r}: no key points")
    wanted = [k.marker for k in kps] + [m for d in dirs for m in (d.from_marker, d.to_marker)]
    missing = [m for m in dict.fromkeys(wanted) if m not in names]
    if missing:
        raise MissingMarkerError(f"{source}: key points / directions for robot {robot.name!r} "
                                 "name markers the motion does not have", missing, names)
    ids = _frame_ids(robot, [k.frame for k in kps] + [d.frame for d in dirs])
    lookup = {n: i for i, n in enumerate(names)}
    axes = np.array([d.axis for d in dirs], dtype=np.float64).reshape(-1, 3)
    axes /= np.maximum(np.linalg.norm(axes, axis=1, keepdims=True), 1e-300)
    return CompiledTargets(
        keypoints=tuple(kps), directions=tuple(dirs),
        kp_frame_ids=tuple(ids[:len(kps)]),
        kp_offsets=np.array([k.offset for k in kps], dtype=np.float64).reshape(-1, 3),
        kp_weights=np.array([k.weight for k in kps], dtype=np.float64),
        kp_markers=np.array([lookup[k.marker] for k in kps], dtype=np.int64),
        dir_frame_ids=tuple(ids[len(kps):]),
        dir_axes=axes,
        dir_weights=np.array([d.weight for d in dirs], dtype=np.float64),
        dir_from=np.array([lookup[d.from_marker] for d in dirs], dtype=np.int64),
        dir_to=np.array([lookup[d.to_marker] for d in dirs], dtype=np.int64),
    )
