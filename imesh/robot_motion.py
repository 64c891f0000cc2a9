"""RobotMotion: a robot's joint-space trajectory (pinocchio free-flyer configurations).

``q[t] = [x, y, z, qx, qy, qz, qw, joints...]``: base (waist/root link) position [m] and
orientation quaternion (x, y, z, w order, world frame Z up), then one angle [rad] (or position [m]
for prismatic joints) per actuated joint in ``joint_names`` order. Files always spell out the
quaternion order and the joint names, so they can be read without pinocchio.

File formats written by :func:`save_robot_motion` (atomically) and read by
:func:`load_robot_motion`:

- ``.npz`` with exactly the keys ``fps`` (float), ``robot`` (str), ``joint_names`` (n,) str,
  ``base_position`` (T, 3) [m], ``base_quat_xyzw`` (T, 4), ``joint_positions`` (T, n) [rad].
- ``.csv``: a comment line ``# imesh robot motion: robot=<name> fps=<fps> ...``, then a header row
  ``frame,time_s,base_x,base_y,base_z,base_qx,base_qy,base_qz,base_qw,<joint names...>`` and one
  row per frame (``pandas.read_csv(path, comment="#")`` reads it too).
"""

from __future__ import annotations

import dataclasses
import logging
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from .errors import InvalidMotionError, MotionFileError, OptionError, _listing
from .export import atomic_path

log = logging.getLogger(__name__)

#: Keys of a robot-motion .npz file (exactly these).
NPZ_KEYS: tuple[str, ...] = (
    "fps", "robot", "joint_names", "base_position", "base_quat_xyzw", "joint_positions",
)
#: The base columns of a robot-motion .csv file (after ``frame`` and ``time_s``).
CSV_BASE_COLUMNS: tuple[str, ...] = (
    "base_x", "base_y", "base_z", "base_qx", "base_qy", "base_qz", "base_qw",
)
_QUAT_TOL = 1e-3


class RobotLike(Protocol):
    """What :func:`load_robot_motion` needs of a robot (``imesh.robot.Robot`` has it)."""

    name: str
    joint_names: Sequence[str]


@dataclass(frozen=True, eq=False)
class RobotMotion:
    """Joint-space motion of one robot.

    Attributes:
        q: (T, nq) float64 pinocchio configurations ``[x, y, z, qx, qy, qz, qw, joints...]``,
            base position [m], unit base quaternion (x, y, z, w), joint positions [rad].
            Read-only; quaternions are normalized on construction.
        fps: frames per second [1/s].
        robot: robot name (``Robot.name``, e.g. ``"jvrc1"``).
        joint_names: (nq - 7,) joint names in the order of ``q[:, 7:]``.
        meta: free-form provenance (source clip, fitting settings), not saved to files.
    """

    q: np.ndarray
    fps: float
    robot: str
    joint_names: tuple[str, ...]
    meta: dict = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        where = f"robot motion ({self.robot or 'unnamed robot'})"
        q = np.array(self.q, dtype=np.float64)
        names = tuple(str(n) for n in self.joint_names)
        if q.ndim != 2 or q.shape[0] < 1:
            raise InvalidMotionError(f"{where}: q must have shape (T >= 1, nq), got {q.shape}")
        if q.shape[1] != 7 + len(names):
            raise InvalidMotionError(
                f"{where}: q has {q.shape[1]} columns but 7 base columns + {len(names)} joint "
                f"names need {7 + len(names)}"
            )
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise InvalidMotionError(f"{where}: duplicate joint names {dup}")
        if not str(self.robot):
            raise InvalidMotionError("robot motion: robot name must be a non-empty string")
        if not (np.isfinite(self.fps) and self.fps > 0):
            raise InvalidMotionError(f"{where}: fps must be > 0, got {self.fps}")
        bad = ~np.isfinite(q)
        if bad.any():
            t, c = np.argwhere(bad)[0]
            column = (CSV_BASE_COLUMNS + names)[c]
            raise InvalidMotionError(
                f"{where}: non-finite value {q[t, c]} at frame {t}, column {column} "
                f"({int(bad.any(axis=1).sum())} frames affected)"
            )
        norm = np.linalg.norm(q[:, 3:7], axis=1)
        off = np.abs(norm - 1.0) > _QUAT_TOL
        if off.any():
            t = int(np.flatnonzero(off)[0])
            raise InvalidMotionError(
                f"{where}: base quaternion (x, y, z, w) at frame {t} has norm {norm[t]:.6g}, "
                f"not 1 (tolerance {_QUAT_TOL:g}); {int(off.sum())} frames affected"
            )
        q[:, 3:7] /= norm[:, None]
        q.setflags(write=False)
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "fps", float(self.fps))
        object.__setattr__(self, "robot", str(self.robot))
        object.__setattr__(self, "joint_names", names)

    # ------------------------------------------------------------------ sizes
    @property
    def n_frames(self) -> int:
        return self.q.shape[0]

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    @property
    def dt(self) -> float:
        """Frame period [s]."""
        return 1.0 / self.fps

    @property
    def duration_s(self) -> float:
        return (self.n_frames - 1) / self.fps

    # ------------------------------------------------------------------ views
    @property
    def base_position(self) -> np.ndarray:
        """(T, 3) base (root link) position in the world [m]."""
        return self.q[:, 0:3]

    @property
    def base_quat_xyzw(self) -> np.ndarray:
        """(T, 4) unit base orientation quaternion, order (x, y, z, w)."""
        return self.q[:, 3:7]

    @property
    def joint_positions(self) -> np.ndarray:
        """(T, n) joint positions [rad] in ``joint_names`` order."""
        return self.q[:, 7:]

    def joint_index(self, name: str) -> int:
        """Column of joint ``name`` in :attr:`joint_positions`; OptionError listing valid names."""
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise OptionError("joint name", name, self.joint_names) from None

    def joint_velocities(self) -> np.ndarray:
        """(T, n) backward-difference joint velocities [rad/s]; row 0 is zero."""
        v = np.zeros_like(self.joint_positions)
        v[1:] = np.diff(self.joint_positions, axis=0) * self.fps
        return v

    def joint_accelerations(self) -> np.ndarray:
        """(T, n) backward-difference joint accelerations [rad/s^2]; rows 0 and 1 are zero."""
        a = np.zeros_like(self.joint_positions)
        a[2:] = np.diff(self.joint_positions, n=2, axis=0) * self.fps**2
        return a

    def frames(self, start: int, stop: int | None = None) -> RobotMotion:
        """Frames ``start:stop`` (Python slice semantics)."""
        q = self.q[slice(start, stop)]
        if q.shape[0] == 0:
            raise OptionError("frame range", (start, stop),
                              f"a non-empty range within 0..{self.n_frames}")
        return dataclasses.replace(self, q=q)

    @classmethod
    def from_parts(cls, base_position: np.ndarray, base_quat_xyzw: np.ndarray,
                   joint_positions: np.ndarray, *, fps: float, robot: str,
                   joint_names: Sequence[str]) -> RobotMotion:
        """Assemble from base position (T, 3) [m], quaternion (T, 4) xyzw, joints (T, n) [rad]."""
        base_position = np.asarray(base_position, dtype=np.float64)
        base_quat_xyzw = np.asarray(base_quat_xyzw, dtype=np.float64)
        joint_positions = np.asarray(joint_positions, dtype=np.float64)
        n_frames = base_position.shape[0] if base_position.ndim == 2 else -1
        if joint_positions.ndim == 1 and len(joint_names) == 0:
            joint_positions = joint_positions.reshape(-1, 0)
        shapes = {"base_position": (base_position.shape, 3),
                  "base_quat_xyzw": (base_quat_xyzw.shape, 4),
                  "joint_positions": (joint_positions.shape, len(joint_names))}
        for key, (shape, width) in shapes.items():
            if len(shape) != 2 or shape[0] != n_frames or shape[1] != width:
                raise InvalidMotionError(
                    f"robot motion ({robot}): {key} must have shape (T, {width}) with the same T "
                    f"as base_position {base_position.shape}, got {shape}"
                )
        q = np.concatenate([base_position, base_quat_xyzw, joint_positions], axis=1)
        return cls(q=q, fps=fps, robot=robot, joint_names=tuple(joint_names))


# ---------------------------------------------------------------------------------------- files
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
        extra = {}
        if markers is not None:
            if markers.n_frames != motion.n_frames:
                raise InvalidMotionError(f"{path}: {markers.n_frames} frames of adapted markers "
                                         f"for a motion of {motion.n_frames} frames")
            extra = {"adapted_positions_m": markers.positions_m,
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
    from .errors import UnsupportedFormatError

    path = Path(path)
    suffix = path.suffix.lower()
    if not path.is_file():
        raise MotionFileError(str(path), "no such file")
    if suffix == ".npz":
        fps, name, joints, base_pos, quat, q_joints = _read_npz(path)
    elif suffix == ".csv":
        fps, name, joints, base_pos, quat, q_joints = _read_csv(path, robot)
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
        return RobotMotion.from_parts(base_pos, quat, q_joints, fps=fps, robot=name,
                                      joint_names=joints)
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
    from .export import load_npz

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
    return fps, name, joints, base_pos, quat, q_joints


_COMMENT = re.compile(r"^#\s*imesh robot motion:(?P<fields>.*)$")


def _read_csv(path: Path, robot: RobotLike | str | None):
    try:
        with open(path, encoding="utf-8") as fh:
            lines = fh.read().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise MotionFileError(str(path), f"cannot read ({exc})") from None
    meta: dict[str, str] = {}
    row = 0
    while row < len(lines) and lines[row].lstrip().startswith("#"):
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
    return fps, name, joints, base[:, :3], base[:, 3:7], values[:, 9:]


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
