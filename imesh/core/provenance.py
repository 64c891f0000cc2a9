"""Provenance of a robot motion: which clip it was made from, how it was read, which frames are
the clip's, which robot configuration and imesh version made it.

A retarget attaches a :class:`Provenance` to its :class:`~imesh.core.robot_motion.RobotMotion`;
the motion files store it (:mod:`imesh.io.robot_motion`: the ``.npz`` key ``provenance``, a JSON
string; a ``# imesh provenance: {...}`` line of the ``.csv``), so the commands that read a motion
file know its robot, and ``imesh evaluate --source CLIP`` compares the clip with the motion's own
frames of it (the standing lead-in and lead-out are not the clip's) and refuses another clip by
its SHA-256. Files without provenance (older imesh, other tools) still load: ``provenance`` is
then None.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

from ..errors import InvalidMotionError

#: Version of the JSON layout written by :meth:`Provenance.to_json`.
PROVENANCE_FORMAT = 1

#: Options of :func:`imesh.io.load_motion` and of the command line's clip reading that change
#: the markers a retarget sees (``imesh retarget --units --up-axis --source-fps --asf --rig
#: --fps --body-model``), recorded so that the clip can be read again the same way.
LOAD_OPTION_KEYS = ("units", "up_axis", "source_fps", "asf", "rig", "fps", "body_model",
                    "joints")


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


@dataclass(frozen=True)
class SourceClip:
    """The human clip a motion was made from.

    Attributes:
        path: the clip's file as it was given (absolute).
        sha256: SHA-256 of the file's bytes (hex).
        fps: frame rate of the clip as the pipeline received it [1/s] (after ``load``'s
            ``fps`` resampling, if any).
        frames: frame count of the clip as the pipeline received it.
        load: the reading options (keys of :data:`LOAD_OPTION_KEYS`, values str or float)
            that were not left at their defaults.
    """

    path: str
    sha256: str
    fps: float
    frames: int
    load: Mapping[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        unknown = sorted(set(self.load) - set(LOAD_OPTION_KEYS))
        if unknown:
            raise InvalidMotionError(f"source clip {self.path}: unknown load options {unknown}; "
                                     f"valid: {', '.join(LOAD_OPTION_KEYS)}")
        object.__setattr__(self, "load", MappingProxyType(
            {k: v for k, v in self.load.items() if v is not None}))


@dataclass(frozen=True)
class Provenance:
    """Where a robot motion came from.

    Attributes:
        lead_in: standing frames the retarget added before the clip's first frame.
        lead_out: standing frames added after the clip's last frame.
        robot: the robot's name.
        robot_sha256: SHA-256 (hex) of the robot's configuration: its robot.toml, markers.toml
            and URDF bytes (:func:`robot_sha256`).
        robot_toml: the robot.toml used (absolute path; to find a generated or user robot
            again).
        urdf: the URDF used (absolute path).
        imesh_version: the version of imesh that made the motion.
        source: the clip, or None when the motion was made from markers that are no file.
    """

    lead_in: int
    lead_out: int
    robot: str
    robot_sha256: str
    robot_toml: str
    urdf: str
    imesh_version: str
    source: SourceClip | None = None

    def __post_init__(self) -> None:
        if min(self.lead_in, self.lead_out) < 0:
            raise InvalidMotionError(f"provenance: lead-in/out frames ({self.lead_in}, "
                                     f"{self.lead_out}) must be >= 0")

    def clip_frames(self, n_frames: int) -> tuple[int, int]:
        """The [start, stop) frames of a motion of ``n_frames`` frames that are the clip's.

        Raises:
            InvalidMotionError: the lead-in and lead-out leave no frame of the clip.
        """
        stop = n_frames - self.lead_out
        if stop <= self.lead_in:
            raise InvalidMotionError(f"provenance: lead-in {self.lead_in} and lead-out "
                                     f"{self.lead_out} frames leave no clip frame of "
                                     f"{n_frames}")
        return self.lead_in, stop

    def to_json(self) -> str:
        """One line of JSON (the layout of :meth:`from_json`)."""
        data: dict[str, object] = {
            "format": PROVENANCE_FORMAT, "imesh_version": self.imesh_version,
            "lead_frames": [self.lead_in, self.lead_out],
            "robot": {"name": self.robot, "sha256": self.robot_sha256,
                      "robot_toml": self.robot_toml, "urdf": self.urdf},
            "source": None,
        }
        if self.source is not None:
            s = self.source
            data["source"] = {"path": s.path, "sha256": s.sha256, "fps": s.fps,
                              "frames": s.frames, "load": dict(s.load)}
        return json.dumps(data, sort_keys=True)

    @classmethod
    def from_json(cls, text: str) -> Provenance:
        """Read :meth:`to_json`'s layout.

        Raises:
            InvalidMotionError: not JSON, a newer format, missing or mistyped fields (named).
        """
        try:
            data = json.loads(text)
        except ValueError as exc:
            raise InvalidMotionError(f"provenance is not JSON ({exc})") from None
        if not isinstance(data, dict):
            raise InvalidMotionError("provenance must be a JSON object")
        fmt = data.get("format")
        if fmt != PROVENANCE_FORMAT:
            raise InvalidMotionError(f"provenance format {fmt!r}; valid: {PROVENANCE_FORMAT} "
                                     "(a newer imesh wrote this file?)")
        try:
            lead_in, lead_out = (int(n) for n in data["lead_frames"])
            robot = data["robot"]
            src = data["source"]
            source = None if src is None else SourceClip(
                path=str(src["path"]), sha256=str(src["sha256"]), fps=float(src["fps"]),
                frames=int(src["frames"]), load=dict(src.get("load", {})))
            return cls(lead_in=lead_in, lead_out=lead_out, robot=str(robot["name"]),
                       robot_sha256=str(robot["sha256"]), robot_toml=str(robot["robot_toml"]),
                       urdf=str(robot["urdf"]), imesh_version=str(data["imesh_version"]),
                       source=source)
        except (KeyError, TypeError, ValueError) as exc:
            raise InvalidMotionError(f"provenance: missing or mistyped field ({exc!r})"
                                     ) from None


def robot_files(robot) -> tuple[Path, ...]:
    """The files that configure ``robot`` (an :class:`imesh.robot.Robot`): robot.toml,
    markers.toml (when there is one) and the URDF."""
    files = [Path(robot.config.path), Path(robot.urdf)]
    if robot.config.markers_path is not None:
        files.insert(1, Path(robot.config.markers_path))
    return tuple(files)


def robot_sha256(robot) -> str:
    """SHA-256 (hex) of a robot's configuration: the bytes of :func:`robot_files`, each
    preceded by its role, so that a change to any of them changes the hash."""
    h = hashlib.sha256()
    for path in robot_files(robot):
        h.update(path.suffix.encode() + b"\0" + bytes.fromhex(file_sha256(path)))
    return h.hexdigest()


def source_clip(motion) -> SourceClip | None:
    """The :class:`SourceClip` of a loaded human motion (a MarkerMotion), or None when it
    was not read from a file that still exists (generated or combined markers).

    The reading options come from ``motion.meta["load_options"]`` (set by the command line's
    clip reader, :func:`imesh.cli.loading.load_clip`).
    """
    path = Path(motion.source) if motion.source else None
    if path is None or not path.is_file():
        return None
    load = dict(motion.meta.get("load_options", {}))
    return SourceClip(path=str(path.resolve()), sha256=file_sha256(path), fps=motion.fps,
                      frames=motion.n_frames, load=load)


def make_provenance(motion, robot, lead_frames: tuple[int, int], imesh_version: str
                    ) -> Provenance:
    """The provenance of a retarget of ``motion`` (MarkerMotion) to ``robot`` (Robot) with
    ``lead_frames`` (lead-in, lead-out) standing frames, by imesh ``imesh_version``."""
    return Provenance(lead_in=int(lead_frames[0]), lead_out=int(lead_frames[1]),
                      robot=robot.name, robot_sha256=robot_sha256(robot),
                      robot_toml=str(Path(robot.config.path).resolve()),
                      urdf=str(Path(robot.urdf).resolve()), imesh_version=imesh_version,
                      source=source_clip(motion))
