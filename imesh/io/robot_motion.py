"""Robot-motion files: :class:`~imesh.core.robot_motion.RobotMotion` as .npz or .csv.

Files always spell out the quaternion order and the joint names, so they can be read without
pinocchio. Formats written by :func:`save_robot_motion` (atomically) and read by
:func:`load_robot_motion`:

- ``.npz`` with the keys ``fps`` (float), ``robot`` (str), ``joint_names`` (n,) str,
  ``base_position`` (T, 3) [m], ``base_quat_xyzw`` (T, 4), ``joint_positions`` (T, n) [rad];
  optionally ``provenance`` (str: one JSON object, :class:`imesh.core.provenance.Provenance`),
  the adapted markers ``adapted_positions_m`` (T, M, 3) [m], ``adapted_marker_names`` (M,),
  and the planned contact modes ``contact_modes`` (T, 2) int8 [left, right] (0 swing,
  1 stance, 2 slide, 3 pivot: :attr:`~imesh.core.robot_motion.RobotMotion.contact_modes`).
- ``.csv``: a comment line ``# imesh robot motion: robot=<name> fps=<fps> ...``, optionally a
  comment line ``# imesh provenance: {...}`` (the same JSON), then a header row
  ``frame,time_s,base_x,base_y,base_z,base_qx,base_qy,base_qz,base_qw,<joint names...>`` and one
  row per frame (``pandas.read_csv(path, comment="#")`` reads it too). A .csv keeps neither
  the adapted markers nor the contact modes.

Files without provenance (written by imesh before it had one, or by other tools) load with
``motion.provenance`` None.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import re
from pathlib import Path
from typing import Any

import numpy as np

from ..core.provenance import Provenance
from ..core.robot_motion import CSV_BASE_COLUMNS, RobotLike, RobotMotion
from ..errors import (
    InvalidMotionError,
    MotionFileError,
    OptionError,
    UnsupportedFormatError,
    _listing,
)
from .atomic import atomic_path
from .npz import load_npz

log = logging.getLogger(__name__)

#: Keys of a robot-motion .npz file (exactly these).
NPZ_KEYS: tuple[str, ...] = (
    "fps", "robot", "joint_names", "base_position", "base_quat_xyzw", "joint_positions",
)


def save_robot_motion(path: str | os.PathLike, motion: RobotMotion, markers=None) -> None:
    """Write a robot motion as .npz or .csv (see the module docstring), atomically.

    Args:
        path: output file; the suffix (.npz or .csv) chooses the format.
        motion: the motion to write.
        markers: the adapted markers the motion was fitted to (a MarkerMotion with the same
            frames), stored in a .npz as ``adapted_positions_m`` (T, M, 3) [m] and
            ``adapted_marker_names`` (M,), so ``imesh evaluate`` measures ``marker_rms_mm``
            against them; not written to a .csv.

    Raises:
        OptionError: unknown suffix (lists the valid ones).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        extra: dict[str, Any] = {}
        if motion.provenance is not None:
            extra["provenance"] = np.array(motion.provenance.to_json(), dtype=np.str_)
        if motion.contact_modes is not None:
            extra["contact_modes"] = motion.contact_modes
        if markers is not None:
            if markers.n_frames != motion.n_frames:
                raise InvalidMotionError(f"{path}: {markers.n_frames} frames of adapted markers "
                                         f"for a motion of {motion.n_frames} frames")
            extra |= {"adapted_positions_m": markers.positions_m,
                     "adapted_marker_names": np.array(markers.names, dtype=np.str_)}
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(
                fh, fps=np.float64(motion.fps), robot=np.str_(motion.robot),
                joint_names=np.array(motion.joint_names, dtype=np.str_).reshape(-1),
                base_position=motion.base_position, base_quat_xyzw=motion.base_quat_xyzw,
                joint_positions=motion.joint_positions, **extra,
            )
    elif suffix == ".csv":
        bad = [n for n in motion.joint_names if not n or any(c in n for c in ',"\n\r')]
        if bad:
            raise OptionError("joint names for CSV", bad, "names without commas, quotes or "
                              "newlines (use .npz)")
        header = ["frame", "time_s", *CSV_BASE_COLUMNS, *motion.joint_names]
        t = np.arange(motion.n_frames)
        table = np.column_stack([t, t / motion.fps, motion.q])
        comment = (f"# imesh robot motion: robot={motion.robot} fps={motion.fps!r} "
                   "quaternion=xyzw units=m,rad")
        if motion.provenance is not None:
            comment += "\n" + _PROVENANCE_LINE + motion.provenance.to_json()
        with atomic_path(path) as tmp:
            np.savetxt(tmp, table, delimiter=",", header=comment + "\n" + ",".join(header),
                       comments="", fmt="%.17g")
    else:
        raise OptionError("robot motion file extension", suffix or path.name, [".npz", ".csv"])
    log.info("wrote %s: %d frames of %s at %g fps", path, motion.n_frames, motion.robot,
             motion.fps)


def load_robot_motion(path: str | os.PathLike, robot: RobotLike | str | None = None
                      ) -> RobotMotion:
    """Read a robot motion written by :func:`save_robot_motion` (.npz or .csv).

    Args:
        path: the file.
        robot: when given (a ``Robot`` or a robot name), the file must be a motion of this robot;
            with a ``Robot`` the joint columns are also checked against ``robot.joint_names`` and
            reordered into that order when the file lists the same joints in another order.

    Returns:
        The motion.

    Raises:
        UnsupportedFormatError: suffix not .npz/.csv.
        MotionFileError: unreadable or malformed file, missing keys/columns, wrong array shapes,
            non-finite values, a motion of another robot, joint names unknown to ``robot`` (the
            message lists the valid names) or joints of ``robot`` missing from the file.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if not path.is_file():
        raise MotionFileError(str(path), "no such file")
    if suffix == ".npz":
        fps, name, joints, base_pos, quat, q_joints, provenance, modes = _read_npz(path)
    elif suffix == ".csv":
        fps, name, joints, base_pos, quat, q_joints, provenance = _read_csv(path, robot)
        modes = None
    else:
        raise UnsupportedFormatError(str(path), f"unknown robot motion extension {suffix!r}; "
                                     "valid: .npz, .csv")
    _check_plausible(path, fps, base_pos, q_joints, joints)
    if robot is not None:
        expected_name = robot if isinstance(robot, str) else robot.name
        if name != expected_name:
            raise MotionFileError(str(path), f"this is a motion of robot {name!r}, not of "
                                  f"{expected_name!r}")
        if not isinstance(robot, str):
            q_joints, joints = _match_joints(path, q_joints, joints, tuple(robot.joint_names))
    try:
        motion = RobotMotion.from_parts(base_pos, quat, q_joints, fps=fps, robot=name,
                                        joint_names=joints)
        if modes is not None:
            motion = dataclasses.replace(motion, contact_modes=modes)
    except InvalidMotionError as exc:
        raise MotionFileError(str(path), str(exc)) from None
    if provenance is not None:
        motion = dataclasses.replace(motion, provenance=_provenance(path, provenance,
                                                                    motion.n_frames))
    return motion


def _provenance(path: Path, text: str, n_frames: int) -> Provenance:
    """The provenance stored in a motion file, checked against its frame count."""
    try:
        provenance = Provenance.from_json(text)
        provenance.clip_frames(n_frames)
    except InvalidMotionError as exc:
        raise MotionFileError(str(path), str(exc)) from None
    return provenance


def read_provenance(path: str | os.PathLike) -> Provenance | None:
    """The provenance a robot-motion file (.npz or .csv of :func:`save_robot_motion`) stores,
    without reading its frames; None for files without one (and for other files).

    Raises:
        MotionFileError: an unreadable file or a malformed provenance.
    """
    path = Path(path)
    text = None
    if path.suffix.lower() == ".npz" and path.is_file():
        arrays = load_npz(path, "robot motion")
        text = str(arrays["provenance"]) if "provenance" in arrays else None
    elif path.suffix.lower() == ".csv" and path.is_file():
        try:
            with open(path, encoding="utf-8") as fh:
                for line in fh:
                    if not line.startswith("#"):
                        break
                    if line.startswith(_PROVENANCE_LINE):
                        text = line[len(_PROVENANCE_LINE):].strip()
        except (OSError, UnicodeDecodeError) as exc:
            raise MotionFileError(str(path), f"cannot read ({exc})") from None
    if text is None:
        return None
    try:
        return Provenance.from_json(text)
    except InvalidMotionError as exc:
        raise MotionFileError(str(path), str(exc)) from None


#: Plausibility limits of a robot motion file: frame rate [1/s], |base coordinate| [m],
#: |joint position| [rad or m].
PLAUSIBLE_FPS = (1.0, 10000.0)
PLAUSIBLE_BASE_M = 1000.0
PLAUSIBLE_JOINT = 1000.0


def _check_plausible(path: Path, fps: float, base_pos: np.ndarray, q_joints: np.ndarray,
                     joints: tuple[str, ...]) -> None:
    """Frame rate and magnitudes a robot motion can have (shapes are checked by RobotMotion)."""
    lo, hi = PLAUSIBLE_FPS
    if not lo <= fps <= hi:
        raise MotionFileError(str(path), f"frame rate {fps:.6g} fps; valid: {lo:g} to {hi:g}")
    for what, arr, limit, names in (("base position", base_pos, PLAUSIBLE_BASE_M, "xyz"),
                                    ("joint position", q_joints, PLAUSIBLE_JOINT, joints)):
        if arr.ndim != 2 or arr.size == 0:
            continue
        with np.errstate(invalid="ignore"):
            far = np.abs(arr) > limit
        if far.any():
            t, c = (int(i[0]) for i in np.nonzero(far))
            col = names[c] if c < len(names) else str(c)
            raise MotionFileError(str(path), f"{what} {arr[t, c]:.4g} in column {col}; valid: "
                                  f"|value| <= {limit:g}", frame=t)


def _read_npz(path: Path):
    arrays = load_npz(path, "robot motion")
    missing = [k for k in NPZ_KEYS if k not in arrays]
    if missing:
        raise MotionFileError(str(path), f"missing keys {missing}; a robot motion .npz has "
                              f"{list(NPZ_KEYS)}, this file has {sorted(arrays)}")
    try:
        fps = float(arrays["fps"])
        name = str(arrays["robot"])
        joints = tuple(str(n) for n in np.asarray(arrays["joint_names"]).reshape(-1))
        base_pos = np.asarray(arrays["base_position"], dtype=np.float64)
        quat = np.asarray(arrays["base_quat_xyzw"], dtype=np.float64)
        q_joints = np.asarray(arrays["joint_positions"], dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise MotionFileError(str(path), f"wrong array types ({exc})") from None
    if q_joints.ndim == 2 and q_joints.shape[1] != len(joints):
        raise MotionFileError(str(path), f"joint_positions has {q_joints.shape[1]} columns but "
                              f"joint_names lists {len(joints)} joints")
    provenance = str(arrays["provenance"]) if "provenance" in arrays else None
    modes = np.asarray(arrays["contact_modes"]) if "contact_modes" in arrays else None
    return fps, name, joints, base_pos, quat, q_joints, provenance, modes


_COMMENT = re.compile(r"^#\s*imesh robot motion:(?P<fields>.*)$")
#: The start of the provenance comment line of a robot-motion .csv (JSON follows).
_PROVENANCE_LINE = "# imesh provenance: "


def _read_csv(path: Path, robot: RobotLike | str | None):
    try:
        with open(path, encoding="utf-8") as fh:
            lines = fh.read().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise MotionFileError(str(path), f"cannot read ({exc})") from None
    meta: dict[str, str] = {}
    provenance = None
    row = 0
    while row < len(lines) and lines[row].lstrip().startswith("#"):
        if lines[row].startswith(_PROVENANCE_LINE):
            provenance = lines[row][len(_PROVENANCE_LINE):]
        match = _COMMENT.match(lines[row].strip())
        if match:
            for kv in match["fields"].split():
                if "=" in kv:
                    key, value = kv.split("=", 1)
                    meta[key] = value
        row += 1
    if row >= len(lines):
        raise MotionFileError(str(path), "no header row", line=row + 1)
    header = [h.strip() for h in lines[row].split(",")]
    head = ["frame", "time_s", *CSV_BASE_COLUMNS]
    if header[:len(head)] != head:
        raise MotionFileError(str(path), f"header must start with {','.join(head)}, got "
                              f"{','.join(header[:len(head)])}", line=row + 1)
    joints = tuple(header[len(head):])
    body = [ln for ln in lines[row + 1:] if ln.strip()]
    if not body:
        raise MotionFileError(str(path), "no data rows", line=row + 2)
    values = np.empty((len(body), len(header)))
    for i, ln in enumerate(body):
        cells = ln.split(",")
        if len(cells) != len(header):
            raise MotionFileError(str(path), f"{len(cells)} values, header has {len(header)} "
                                  "columns", line=row + 2 + i)
        try:
            values[i] = [float(c) for c in cells]
        except ValueError as exc:
            raise MotionFileError(str(path), f"not a number ({exc})", line=row + 2 + i) from None
    bad = ~np.isfinite(values)
    if bad.any():
        i, c = np.argwhere(bad)[0]
        raise MotionFileError(str(path), f"non-finite value in column {header[c]}",
                              line=row + 2 + int(i), frame=int(i))
    name = meta.get("robot", "")
    if not name:
        if robot is None:
            raise MotionFileError(str(path), "the file does not say its robot (no "
                                  "'# imesh robot motion: robot=...' line): pass robot=")
        name = robot if isinstance(robot, str) else robot.name
    if "fps" in meta:
        try:
            fps = float(meta["fps"])
        except ValueError:
            raise MotionFileError(str(path), f"bad fps {meta['fps']!r}", line=1) from None
    elif len(body) >= 2 and values[1, 1] > values[0, 1]:
        fps = 1.0 / (values[1, 1] - values[0, 1])
    else:
        raise MotionFileError(str(path), "cannot tell fps: no 'fps=' comment and no time_s step")
    base = values[:, 2:9]
    return fps, name, joints, base[:, :3], base[:, 3:7], values[:, 9:], provenance


def _match_joints(path: Path, q_joints: np.ndarray, joints: tuple[str, ...],
                  valid: tuple[str, ...]) -> tuple[np.ndarray, tuple[str, ...]]:
    """Check file joints against the robot's and return columns in the robot's order."""
    unknown = [n for n in joints if n not in valid]
    if unknown:
        raise MotionFileError(str(path), f"unknown joint names {_listing(unknown)}; valid joints "
                              f"of this robot: {_listing(valid, limit=100)}")
    missing = [n for n in valid if n not in joints]
    if missing or len(joints) != len(valid):
        raise MotionFileError(str(path), f"{len(joints)} joint columns, the robot has "
                              f"{len(valid)} joints; missing {_listing(missing)}")
    if joints == valid:
        return q_joints, joints
    order = [joints.index(n) for n in valid]
    log.info("%s: reordered %d joint columns into the robot's joint order", path, len(order))
    return q_joints[:, order], valid
