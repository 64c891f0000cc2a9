"""What the robot fits: key points (marker -> frame + offset) and directions (frame axis -> marker
pair), read from ``robots/<name>/markers.toml`` or given explicitly.

``markers.toml``::

    [keypoints]
    knee_l = { frame = "L_KNEE_P_LINK", offset = [0.0, 0.0, 0.0], weight = 1.0 }

    [[directions]]
    frame = "L_ANKLE_P_LINK"   # robot frame
    axis = [1.0, 0.0, 0.0]     # unit axis in that frame
    from = "ankle_l"           # human marker
    to = "toe_l"               # human marker: the axis should point along to - from
    weight = 0.5

Offsets are in metres in the frame; ``offset`` defaults to zero and ``weight`` to 1.
"""

from __future__ import annotations

import logging
import os
import tomllib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..errors import MissingMarkerError
from .errors import FitError, UnknownFrameError

log = logging.getLogger(__name__)

#: Where the project keeps per-robot tables (``robots/<name>/markers.toml``).
ROBOTS_DIR = Path(__file__).resolve().parents[2] / "robots"


class Keypoint(NamedTuple):
    """A robot point that should coincide with a human marker.

    Attributes:
        marker: human marker name (in the fitted MarkerMotion).
        frame: robot frame name.
        offset: (3,) point in the frame [m].
        weight: residual weight (multiplies the position error, so the energy scales with
            weight^2).
    """

    marker: str
    frame: str
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    weight: float = 1.0


class Direction(NamedTuple):
    """A robot frame axis that should point along a human marker direction ``to - from``.

    Attributes:
        frame: robot frame name.
        axis: (3,) axis in the frame (normalized when used).
        from_marker: human marker at the tail of the direction.
        to_marker: human marker at the head of the direction.
        weight: residual weight (multiplies the unit-vector error [rad for small errors]).
    """

    frame: str
    axis: tuple[float, float, float]
    from_marker: str
    to_marker: str
    weight: float = 1.0


@dataclass(frozen=True)
class MarkerTable:
    """The ``[keypoints]`` and ``[[directions]]`` of a markers.toml file."""

    keypoints: tuple[Keypoint, ...]
    directions: tuple[Direction, ...]
    path: str = ""


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


def marker_table_path(robot_name: str) -> Path:
    """``robots/<robot_name>/markers.toml`` of the project."""
    return ROBOTS_DIR / robot_name / "markers.toml"


def load_marker_table(source: str | os.PathLike) -> MarkerTable:
    """Read key points and directions from a markers.toml file, or by robot name.

    Args:
        source: a path to a .toml file, or a robot name (``robots/<name>/markers.toml``).

    Returns:
        The table (other tables of the file, e.g. arrangement operations, are ignored).

    Raises:
        FitError: no such file, invalid TOML, or malformed entries (named in the message).
    """
    text_source = str(source)
    if isinstance(source, os.PathLike) or text_source.endswith(".toml"):
        path = Path(source)
    else:
        path = marker_table_path(text_source)
    if not path.is_file():
        known = sorted(p.parent.name for p in ROBOTS_DIR.glob("*/markers.toml"))
        raise FitError(f"no marker table {path}; robots with a markers.toml: "
                       f"{', '.join(known) or '(none)'}")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise FitError(f"{path}: invalid TOML ({exc})") from None
    keypoints = []
    for marker, spec in dict(data.get("keypoints", {})).items():
        where = f"{path} [keypoints] {marker}"
        if not isinstance(spec, dict) or "frame" not in spec:
            raise FitError(f"{where}: expected {{ frame = ..., offset = [x, y, z], weight = w }}")
        keypoints.append(Keypoint(str(marker), str(spec["frame"]),
                                  _vec3(spec.get("offset", (0.0, 0.0, 0.0)), "offset", where),
                                  _weight(spec.get("weight", 1.0), where)))
    directions = []
    for k, spec in enumerate(data.get("directions", [])):
        where = f"{path} [[directions]] #{k + 1}"
        need = [key for key in ("frame", "axis", "from", "to") if key not in spec]
        if need:
            raise FitError(f"{where}: missing {', '.join(need)} (needs frame, axis, from, to, "
                           "weight)")
        directions.append(Direction(str(spec["frame"]), _vec3(spec["axis"], "axis", where),
                                    str(spec["from"]), str(spec["to"]),
                                    _weight(spec.get("weight", 1.0), where)))
    log.debug("%s: %d key points, %d directions", path, len(keypoints), len(directions))
    return MarkerTable(tuple(keypoints), tuple(directions), str(path))


@dataclass(frozen=True, eq=False)
class CompiledTargets:
    """Key points and directions resolved against one robot and one marker motion.

    Attributes:
        kp_frames: (K,) robot frame names of the key points.
        kp_offsets: (K, 3) offsets in the frames [m].
        kp_weights: (K,) weights.
        kp_markers: (K,) marker indices in the motion.
        dir_frames: (D,) robot frame names of the directions.
        dir_axes: (D, 3) unit axes in the frames.
        dir_weights: (D,) weights.
        dir_from: (D,) marker indices of the tails.
        dir_to: (D,) marker indices of the heads.
        keypoints, directions: the resolved entries (normalized NamedTuples).
    """

    kp_frames: tuple[str, ...]
    kp_offsets: np.ndarray
    kp_weights: np.ndarray
    kp_markers: np.ndarray
    dir_frames: tuple[str, ...]
    dir_axes: np.ndarray
    dir_weights: np.ndarray
    dir_from: np.ndarray
    dir_to: np.ndarray
    keypoints: tuple[Keypoint, ...]
    directions: tuple[Direction, ...]


def _as_keypoints(entries: Iterable) -> list[Keypoint]:
    out = []
    for k, entry in enumerate(entries):
        where = f"key point #{k + 1} {entry!r}"
        items = tuple(entry)
        if not 2 <= len(items) <= 4:
            raise FitError(f"{where}: expected (marker, frame, offset, weight)")
        marker, frame = str(items[0]), str(items[1])
        offset = _vec3(items[2], "offset", where) if len(items) > 2 else (0.0, 0.0, 0.0)
        weight = _weight(items[3], where) if len(items) > 3 else 1.0
        out.append(Keypoint(marker, frame, offset, weight))
    return out


def _as_directions(entries: Iterable) -> list[Direction]:
    out = []
    for k, entry in enumerate(entries):
        where = f"direction #{k + 1} {entry!r}"
        items = tuple(entry)
        if not 4 <= len(items) <= 5:
            raise FitError(f"{where}: expected (frame, axis, from marker, to marker, weight)")
        axis = _vec3(items[1], "axis", where)
        if np.linalg.norm(axis) < 1e-9:
            raise FitError(f"{where}: axis must be non-zero")
        weight = _weight(items[4], where) if len(items) > 4 else 1.0
        out.append(Direction(str(items[0]), axis, str(items[2]), str(items[3]), weight))
    return out


def _robot_frame_names(robot) -> list[str]:
    for attr in ("frame_names", "frames"):
        names = getattr(robot, attr, None)
        if names is not None and not callable(names):
            return [str(n) for n in names]
        if callable(names):
            try:
                return [str(n) for n in names()]
            except Exception:  # noqa: BLE001 - listing is best effort for the message
                return []
    return []


def check_frames(robot, frames: Iterable[str], what: str) -> None:
    """Raise UnknownFrameError when ``robot`` lacks any of ``frames``."""
    missing = []
    for frame in dict.fromkeys(frames):
        try:
            robot.frame_id(frame)
        except Exception:  # noqa: BLE001 - any lookup failure means the frame is unknown
            missing.append(frame)
    if missing:
        raise UnknownFrameError(f"{what} name frames robot {robot.name!r} does not have",
                                missing, _robot_frame_names(robot))


def compile_targets(robot, names: Sequence[str], keypoints: Iterable | None,
                    directions: Iterable | None, *, source: str = "motion") -> CompiledTargets:
    """Validate key points and directions against the robot frames and the motion's markers.

    Args:
        robot: the robot (``frame_id`` must accept every frame name).
        names: marker names of the motion.
        keypoints: (marker, frame, offset, weight) entries, or None for the robot's markers.toml.
        directions: (frame, axis, from, to, weight) entries, or None for the robot's markers.toml.
        source: motion name for messages.

    Raises:
        MissingMarkerError: an entry names a marker the motion lacks (lists the available ones).
        UnknownFrameError: an entry names a frame the robot lacks (lists the valid ones).
        FitError: malformed entries, or nothing to fit.
    """
    if keypoints is None or directions is None:
        table = load_marker_table(robot.name)
        keypoints = table.keypoints if keypoints is None else keypoints
        directions = table.directions if directions is None else directions
    kps = _as_keypoints(keypoints)
    dirs = _as_directions(directions)
    if not kps:
        raise FitError(f"nothing to fit for robot {robot.name!r}: no key points")
    wanted = [k.marker for k in kps] + [m for d in dirs for m in (d.from_marker, d.to_marker)]
    missing = [m for m in dict.fromkeys(wanted) if m not in names]
    if missing:
        raise MissingMarkerError(f"{source}: key points / directions for robot {robot.name!r} "
                                 "name markers the motion does not have", missing, names)
    check_frames(robot, [k.frame for k in kps] + [d.frame for d in dirs],
                 "key points / directions")
    lookup = {n: i for i, n in enumerate(names)}
    axes = np.array([d.axis for d in dirs], dtype=np.float64).reshape(-1, 3)
    axes /= np.maximum(np.linalg.norm(axes, axis=1, keepdims=True), 1e-300)
    return CompiledTargets(
        kp_frames=tuple(k.frame for k in kps),
        kp_offsets=np.array([k.offset for k in kps], dtype=np.float64).reshape(-1, 3),
        kp_weights=np.array([k.weight for k in kps], dtype=np.float64),
        kp_markers=np.array([lookup[k.marker] for k in kps], dtype=np.int64),
        dir_frames=tuple(d.frame for d in dirs),
        dir_axes=axes,
        dir_weights=np.array([d.weight for d in dirs], dtype=np.float64),
        dir_from=np.array([lookup[d.from_marker] for d in dirs], dtype=np.int64),
        dir_to=np.array([lookup[d.to_marker] for d in dirs], dtype=np.int64),
        keypoints=tuple(kps), directions=tuple(dirs),
    )
