"""RobotMotion: a robot's joint-space trajectory (pinocchio free-flyer configurations).

``q[t] = [x, y, z, qx, qy, qz, qw, joints...]``: base (waist/root link) position [m] and
orientation quaternion (x, y, z, w order, world frame Z up), then one angle [rad] (or position [m]
for prismatic joints) per actuated joint in ``joint_names`` order. The files are written and read
by :mod:`imesh.io.robot_motion`.

"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..errors import InvalidMotionError, OptionError
from .motion import MarkerMotion
from .provenance import Provenance

log = logging.getLogger(__name__)

#: The base columns of a robot-motion .csv file (after ``frame`` and ``time_s``).
CSV_BASE_COLUMNS: tuple[str, ...] = (
    "base_x", "base_y", "base_z", "base_qx", "base_qy", "base_qz", "base_qw",
)
_QUAT_TOL = 1e-3


#: Number of contact modes of :attr:`RobotMotion.contact_modes` (swing, stance, slide, pivot).
N_CONTACT_MODES = 4


def _checked_modes(modes, n_frames: int, where: str) -> np.ndarray:
    """``contact_modes`` as a read-only (T, 2) int8 array, or InvalidMotionError."""
    arr = np.asarray(modes)
    if arr.shape != (n_frames, 2):
        raise InvalidMotionError(f"{where}: contact_modes must have shape ({n_frames}, 2) "
                                 f"[left, right] per frame, got {arr.shape}")
    if arr.size and (not np.issubdtype(arr.dtype, np.integer)
                     or arr.min() < 0 or arr.max() >= N_CONTACT_MODES):
        raise InvalidMotionError(f"{where}: contact_modes must be integers 0 (swing), "
                                 "1 (stance), 2 (slide) or 3 (pivot)")
    out = arr.astype(np.int8)
    out.setflags(write=False)
    return out


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
        adapted: the adapted human markers the motion was fitted to (T frames), when known:
            an imesh .npz stores them and the evaluator's ``marker_rms_mm`` measures against
            them; None otherwise.
        provenance: where the motion came from (the clip and its hash, the lead-in/out
            frames, the robot configuration, the imesh version; :mod:`imesh.core.provenance`),
            when known: imesh's retarget sets it and its files store it; None otherwise.
        contact_modes: (T, 2) int8 [left, right] the contact mode the motion was planned
            with, per foot and frame: 0 swing, 1 stance, 2 slide, 3 pivot
            (:data:`imesh.contacts.phases.MODE_NAMES`; ``Contacts.from_modes`` reads it back),
            when known: the whole-body solve plans it, imesh's .npz files store it, and the
            evaluator and the physics check then judge the soles against the planned support
            instead of detecting it; None otherwise. Read-only.
    """

    q: np.ndarray
    fps: float
    robot: str
    joint_names: tuple[str, ...]
    adapted: MarkerMotion | None = None
    provenance: Provenance | None = None
    contact_modes: np.ndarray | None = None

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
        if self.contact_modes is not None:
            object.__setattr__(self, "contact_modes", _checked_modes(self.contact_modes,
                                                                     len(q), where))
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
        """Frames ``start:stop`` (Python slice semantics), without the provenance (its
        lead-in/out frames are those of the whole motion)."""
        q = self.q[slice(start, stop)]
        if q.shape[0] == 0:
            raise OptionError("frame range", (start, stop),
                              f"a non-empty range within 0..{self.n_frames}")
        adapted = None if self.adapted is None else self.adapted.frames(start, stop)
        modes = None if self.contact_modes is None else self.contact_modes[slice(start, stop)]
        return dataclasses.replace(self, q=q, adapted=adapted, provenance=None,
                                   contact_modes=modes)

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
