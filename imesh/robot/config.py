"""Robot configuration files: ``robots/<name>/robot.toml`` and ``markers.toml``.

This module only reads and validates the TOML files (no pinocchio): what the file says about the
model source, the joints to fix, the waist and foot frames, the soles, the nominal standing pose and
the limits (``robot.toml``), and how the standard human markers map onto the robot and how the
marker model is arranged for it (``markers.toml``, Nakaoka & Komura 2012 sec. IV-A). Checks that
need the model itself (frame and joint names exist) happen in :func:`imesh.robot.load_robot`.

Every problem raises :class:`RobotConfigError` naming the file, the key and the valid options.
"""

from __future__ import annotations

import difflib
import math
import os
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from ..errors import ImeshError, _listing
from ..human.markerset import STANDARD_MARKERS

#: The robot folders shipped with imesh (``<repo>/robots``; each holds robot.toml, markers.toml).
ROBOTS_DIR: Path = Path(__file__).resolve().parents[2] / "robots"

#: Default acceleration limit [rad/s^2] when robot.toml gives none (see docs/robots.md).
DEFAULT_ACCELERATION = 20.0

SIDES: tuple[str, str] = ("left", "right")


class RobotConfigError(ImeshError):
    """A robot configuration, robot model file or robot name is invalid.

    The message says which file and key (or argument) was wrong and lists the valid options.

    Attributes:
        path: the file concerned, or None.
        key: the TOML key (dotted) or argument concerned, or None.
        valid: the valid options listed in the message (possibly shortened), or None.
    """

    def __init__(self, message: str, *, path: str | os.PathLike | None = None,
                 key: str | None = None, valid: Iterable[str] | None = None):
        self.path = None if path is None else str(path)
        self.key = key
        self.valid = None if valid is None else list(valid)
        where = ""
        if self.path is not None:
            where = self.path
        if key is not None:
            where = f"{where} [{key}]" if where else f"[{key}]"
        text = f"{where}: {message}" if where else message
        if self.valid is not None:
            text += f"; valid: {_listing(self.valid)}"
        super().__init__(text)


def closest_first(name: str, options: Iterable[str]) -> list[str]:
    """``options`` with the ones closest to ``name`` first (difflib ratio), the rest in order."""
    opts = list(dict.fromkeys(options))
    close = difflib.get_close_matches(name, opts, n=5, cutoff=0.5)
    lowered = [o for o in opts if name.lower() in o.lower() and o not in close]
    head = close + lowered
    return head + [o for o in opts if o not in head]


# ----------------------------------------------------------------------------------------------
# robot.toml


@dataclass(frozen=True)
class ModelSource:
    """Where the URDF comes from.

    Attributes:
        source: ``"package"`` (an installed Python package or distribution) or ``"user"``
            (the user passes the file).
        package: import name of the package (``source="package"``), or "".
        distribution: pip distribution name whose installed files hold the URDF when the package
            has no importable module (data-only wheels such as example-robot-data), or "".
        urdf: for ``package``: an attribute of the package holding the path, or a path relative to
            the package folder, or a path suffix of a file of the distribution; for ``user``: the
            file name expected.
        install: the command that installs the package (shown when it is missing).
        url: where the model comes from (upstream), for documentation.
    """

    source: str
    package: str = ""
    distribution: str = ""
    urdf: str = ""
    install: str = ""
    url: str = ""


@dataclass(frozen=True, eq=False)
class SoleRectangle:
    """A flat rectangular sole on a foot frame.

    Attributes:
        frame: the frame the rectangle is expressed in (the foot link).
        center: (3,) float [m] centre of the rectangle in ``frame``.
        half_extents: (2,) float [m] half sizes along the frame's x and y axes.
        normal: (3,) float unit outward normal of the ground side in ``frame`` (pointing up,
            away from the ground; (0, 0, 1) for a foot frame whose z axis is vertical).
    """

    frame: str
    center: np.ndarray
    half_extents: np.ndarray
    normal: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))

    def corners(self) -> np.ndarray:
        """(4, 3) float [m] corners in ``frame`` (front-left, front-right, back-right, back-left).

        Assumes the normal is the frame's z axis (the rectangle spans x and y).
        """
        hx, hy = self.half_extents
        c = self.center
        return np.array([c + [hx, hy, 0], c + [hx, -hy, 0], c + [-hx, -hy, 0], c + [-hx, hy, 0]])


@dataclass(frozen=True)
class LimitsConfig:
    """Limits added to or overriding the URDF.

    Attributes:
        acceleration_default: [rad/s^2] acceleration limit of every joint not listed.
        acceleration: joint -> [rad/s^2].
        velocity: joint -> [rad/s] overriding the URDF.
        effort: joint -> [Nm] overriding the URDF.
        position: joint -> (lower, upper) [rad] overriding the URDF.
        source: where the numbers come from (free text, documented in the robot README).
    """

    acceleration_default: float = DEFAULT_ACCELERATION
    acceleration: Mapping[str, float] = field(default_factory=dict)
    velocity: Mapping[str, float] = field(default_factory=dict)
    effort: Mapping[str, float] = field(default_factory=dict)
    position: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    source: str = ""


@dataclass(frozen=True)
class CollisionConfig:
    """How collision proxies are built.

    Attributes:
        use_visual: links whose proxy is fitted to the visual mesh instead of the URDF collision
            geometry (e.g. feet whose collision geometry is only contact points).
        skip: links that get no proxy.
        ignore: extra link pairs never checked against each other.
        touch_margin: [m] pairs closer than this in the nominal pose are ignored.
        in_solve: the whole-body solve keeps the self-collision capsules apart
            (``WholeBodyConfig.self_collision``, docs/collision.md); false for a robot whose
            capsules are not yet validated against its geometry.
    """

    use_visual: tuple[str, ...] = ()
    skip: tuple[str, ...] = ()
    ignore: tuple[tuple[str, str], ...] = ()
    touch_margin: float = 0.002
    in_solve: bool = True


@dataclass(frozen=True)
class RobotConfig:
    """The validated content of one ``robot.toml``.

    Attributes:
        name: robot name (the folder name for the shipped robots).
        licence: SPDX licence of the model.
        description: one line.
        path: the robot.toml file.
        dof: number of actuated joints after reduction, or None when not declared.
        model: where the URDF comes from.
        fixed_joints: joints fixed at their nominal value (fingers, face, mimic joints).
        waist_frame: the root/waist link.
        foot_frames: ``"left"``/``"right"`` -> foot link.
        soles: given sole rectangles by side (the others are derived from the foot geometry).
        nominal: joint -> angle [rad] of the standing pose (others 0).
        limits: limits added to or overriding the URDF.
        collision: proxy options.
        markers_path: the markers.toml beside robot.toml, or None when there is none.
        sagittal_joints: ``[sagittal] joints``, the hip, knee and ankle pitch joints of the left
            then the right leg (the motion reduction's 7-link chain, :mod:`imesh.reduction`);
            empty when not given.
    """

    name: str
    licence: str
    description: str
    path: Path
    dof: int | None
    model: ModelSource
    fixed_joints: tuple[str, ...]
    waist_frame: str
    foot_frames: Mapping[str, str]
    soles: Mapping[str, SoleRectangle]
    nominal: Mapping[str, float]
    limits: LimitsConfig
    collision: CollisionConfig
    markers_path: Path | None
    sagittal_joints: tuple[str, ...] = ()

    @property
    def directory(self) -> Path:
        """The folder holding robot.toml."""
        return self.path.parent

    def frame_references(self) -> list[tuple[str, str]]:
        """(key, frame name) for every frame this file names (checked against the model)."""
        refs = [("frames.waist", self.waist_frame)]
        refs += [(f"frames.{side}_foot", self.foot_frames[side]) for side in SIDES]
        refs += [(f"soles.{side}.frame", s.frame) for side, s in self.soles.items()]
        return refs


def _read_toml(path: Path) -> dict[str, Any]:
    if not path.is_file():
        raise RobotConfigError("file not found", path=path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise RobotConfigError(f"not valid TOML: {exc}", path=path) from None
    except UnicodeDecodeError as exc:
        raise RobotConfigError(f"not UTF-8 text: {exc}", path=path) from None


def _table_array(path, value, key: str, allowed) -> list[tuple[str, dict]]:
    """Validated ``[[key]]`` array of tables: [(``key[i]``, table), ...]."""
    if not isinstance(value, list):
        raise RobotConfigError(f"must be an array of tables [[{key}]]", path=path, key=key)
    out = []
    for i, tab in enumerate(value):
        where = f"{key}[{i}]"
        if not isinstance(tab, dict):
            raise RobotConfigError("must be a table", path=path, key=where)
        _check_keys(path, tab, where, allowed)
        out.append((where, tab))
    return out


def _check_keys(path: Path, table: Mapping[str, Any], where: str, valid: Iterable[str]) -> None:
    valid = list(valid)
    for key in table:
        if key not in valid:
            k = f"{where}.{key}" if where else key
            raise RobotConfigError(f"unknown key {key!r}", path=path, key=k,
                                   valid=closest_first(key, valid))


def _table(path: Path, data: Mapping[str, Any], key: str, required: bool = False) -> dict:
    value = data.get(key)
    if value is None:
        if required:
            raise RobotConfigError("missing table", path=path, key=key)
        return {}
    if not isinstance(value, dict):
        raise RobotConfigError(f"must be a table, got {type(value).__name__}", path=path, key=key)
    return value


def _string(path: Path, data: Mapping[str, Any], key: str, where: str,
            required: bool = True, default: str = "") -> str:
    value = data.get(key)
    full = f"{where}.{key}" if where else key
    if value is None:
        if required:
            raise RobotConfigError("missing key (a string)", path=path, key=full)
        return default
    if not isinstance(value, str) or (required and not value):
        raise RobotConfigError(f"must be a non-empty string, got {value!r}", path=path, key=full)
    return value


def _number(path: Path, value: Any, key: str, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise RobotConfigError(f"must be a number, got {value!r}", path=path, key=key)
    x = float(value)
    if not math.isfinite(x) or (positive and x <= 0):
        raise RobotConfigError(f"must be a finite{' positive' if positive else ''} number, "
                               f"got {value!r}", path=path, key=key)
    return x


def _vector(path: Path, value: Any, key: str, n: int) -> np.ndarray:
    if not isinstance(value, list) or len(value) != n:
        raise RobotConfigError(f"must be a list of {n} numbers, got {value!r}", path=path, key=key)
    return np.array([_number(path, v, f"{key}[{i}]") for i, v in enumerate(value)], dtype=float)


def _names(path: Path, value: Any, key: str) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise RobotConfigError(f"must be a list of names, got {value!r}", path=path, key=key)
    return tuple(value)


def _pairs(path: Path, value: Any, key: str) -> tuple[tuple[str, str], ...]:
    if not isinstance(value, list):
        raise RobotConfigError(f"must be a list of [name, name] pairs, got {value!r}",
                               path=path, key=key)
    out = []
    for i, pair in enumerate(value):
        if (not isinstance(pair, list) or len(pair) != 2
                or not all(isinstance(v, str) and v for v in pair) or pair[0] == pair[1]):
            raise RobotConfigError(f"must be a pair of two different names, got {pair!r}",
                                   path=path, key=f"{key}[{i}]")
        out.append((pair[0], pair[1]))
    return tuple(out)


def _joint_numbers(path: Path, table: Mapping[str, Any], key: str,
                   positive: bool = False) -> dict[str, float]:
    if not isinstance(table, dict):
        raise RobotConfigError("must be a table joint = number", path=path, key=key)
    return {j: _number(path, v, f"{key}.{j}", positive=positive) for j, v in table.items()}


_TOP_KEYS = ("name", "licence", "description", "dof", "model", "joints", "frames", "soles",
             "nominal", "limits", "collision", "sagittal")
_MODEL_KEYS = ("source", "package", "distribution", "urdf", "install", "url")
_SOURCES = ("package", "user")
_FRAME_KEYS = ("waist", "left_foot", "right_foot")
_SOLE_KEYS = ("frame", "center", "half_extents", "normal")
_LIMIT_KEYS = ("acceleration_default", "acceleration", "velocity", "effort", "position", "source")
def _flag(path: Path, value, key: str) -> bool:
    if not isinstance(value, bool):
        raise RobotConfigError(f"{key} must be true or false, got {value!r}", path=path, key=key)
    return value


_COLLISION_KEYS = ("use_visual", "skip", "ignore", "touch_margin", "in_solve")


def load_robot_config(path: str | os.PathLike) -> RobotConfig:
    """Read and validate one robot.toml.

    Args:
        path: the robot.toml file.

    Returns:
        The validated configuration (frame and joint names are checked later against the model).

    Raises:
        RobotConfigError: unreadable file, unknown or missing key, wrong type, invalid value.
    """
    path = Path(path)
    data = _read_toml(path)
    _check_keys(path, data, "", _TOP_KEYS)
    name = _string(path, data, "name", "")
    licence = _string(path, data, "licence", "")
    description = _string(path, data, "description", "", required=False)
    dof = data.get("dof")
    if dof is not None and (isinstance(dof, bool) or not isinstance(dof, int) or dof <= 0):
        raise RobotConfigError(f"must be a positive integer, got {dof!r}", path=path, key="dof")

    m = _table(path, data, "model", required=True)
    _check_keys(path, m, "model", _MODEL_KEYS)
    source = _string(path, m, "source", "model")
    if source not in _SOURCES:
        raise RobotConfigError(f"unknown model source {source!r}", path=path, key="model.source",
                               valid=_SOURCES)
    package = _string(path, m, "package", "model", required=False)
    distribution = _string(path, m, "distribution", "model", required=False)
    urdf = _string(path, m, "urdf", "model")
    if source == "package" and not (package or distribution):
        raise RobotConfigError("source = \"package\" needs package (import name) or "
                               "distribution (pip name)", path=path, key="model.package")
    model = ModelSource(source=source, package=package, distribution=distribution, urdf=urdf,
                        install=_string(path, m, "install", "model", required=False),
                        url=_string(path, m, "url", "model", required=False))

    joints = _table(path, data, "joints")
    _check_keys(path, joints, "joints", ("fixed",))
    fixed = _names(path, joints.get("fixed", []), "joints.fixed")

    frames = _table(path, data, "frames", required=True)
    _check_keys(path, frames, "frames", _FRAME_KEYS)
    waist = _string(path, frames, "waist", "frames")
    feet = {side: _string(path, frames, f"{side}_foot", "frames") for side in SIDES}

    soles: dict[str, SoleRectangle] = {}
    sole_tables = _table(path, data, "soles")
    _check_keys(path, sole_tables, "soles", SIDES)
    for side, tab in sole_tables.items():
        key = f"soles.{side}"
        if not isinstance(tab, dict):
            raise RobotConfigError("must be a table", path=path, key=key)
        _check_keys(path, tab, key, _SOLE_KEYS)
        half = _vector(path, tab.get("half_extents"), f"{key}.half_extents", 2)
        if np.any(half <= 0):
            raise RobotConfigError("half extents must be positive", path=path,
                                   key=f"{key}.half_extents")
        normal = _vector(path, tab.get("normal", [0.0, 0.0, 1.0]), f"{key}.normal", 3)
        if np.linalg.norm(normal) < 1e-9:
            raise RobotConfigError("normal must be non-zero", path=path, key=f"{key}.normal")
        soles[side] = SoleRectangle(
            frame=_string(path, tab, "frame", key, required=False, default=feet[side]),
            center=_vector(path, tab.get("center"), f"{key}.center", 3),
            half_extents=half, normal=normal / np.linalg.norm(normal))

    nominal = _joint_numbers(path, _table(path, data, "nominal"), "nominal")

    lim = _table(path, data, "limits")
    _check_keys(path, lim, "limits", _LIMIT_KEYS)
    position: dict[str, tuple[float, float]] = {}
    for j, pair in dict(lim.get("position", {})).items():
        lo, hi = _vector(path, pair, f"limits.position.{j}", 2)
        if not lo < hi:
            raise RobotConfigError(f"lower {lo} must be below upper {hi}", path=path,
                                   key=f"limits.position.{j}")
        position[j] = (float(lo), float(hi))
    limits = LimitsConfig(
        acceleration_default=_number(path, lim.get("acceleration_default", DEFAULT_ACCELERATION),
                                     "limits.acceleration_default", positive=True),
        acceleration=MappingProxyType(_joint_numbers(path, lim.get("acceleration", {}),
                                                     "limits.acceleration", positive=True)),
        velocity=MappingProxyType(_joint_numbers(path, lim.get("velocity", {}), "limits.velocity",
                                                 positive=True)),
        effort=MappingProxyType(_joint_numbers(path, lim.get("effort", {}), "limits.effort",
                                               positive=True)),
        position=MappingProxyType(position),
        source=_string(path, lim, "source", "limits", required=False),
    )

    col = _table(path, data, "collision")
    _check_keys(path, col, "collision", _COLLISION_KEYS)
    collision = CollisionConfig(
        use_visual=_names(path, col.get("use_visual", []), "collision.use_visual"),
        skip=_names(path, col.get("skip", []), "collision.skip"),
        ignore=_pairs(path, col.get("ignore", []), "collision.ignore"),
        touch_margin=_number(path, col.get("touch_margin", 0.002), "collision.touch_margin"),
        in_solve=_flag(path, col.get("in_solve", True), "collision.in_solve"),
    )

    # the motion reduction's sagittal chain (imesh.reduction): six pitch joints or none
    sagittal = _table(path, data, "sagittal")
    _check_keys(path, sagittal, "sagittal", ("joints",))
    sagittal_joints = _names(path, sagittal.get("joints", []), "sagittal.joints")
    if len(sagittal_joints) not in (0, 6):
        raise RobotConfigError("must name six joints: hip, knee, ankle pitch of the left then "
                               "the right leg", path=path, key="sagittal.joints")

    markers = path.parent / "markers.toml"
    return RobotConfig(
        name=name, licence=licence, description=description, path=path, dof=dof, model=model,
        fixed_joints=fixed, waist_frame=waist, foot_frames=MappingProxyType(feet),
        soles=MappingProxyType(soles), nominal=MappingProxyType(nominal), limits=limits,
        collision=collision, markers_path=markers if markers.is_file() else None,
        sagittal_joints=sagittal_joints,
    )


# ----------------------------------------------------------------------------------------------
# markers.toml


@dataclass(frozen=True, eq=False)
class Keypoint:
    """A robot point that a (human) marker is fitted to.

    Attributes:
        frame: robot frame (link) name.
        offset: (3,) float [m] position of the point in ``frame``.
        weight: fitting weight (relative; 1 = a normal joint-centre marker).
    """

    frame: str
    offset: np.ndarray
    weight: float = 1.0


@dataclass(frozen=True, eq=False)
class Direction:
    """An orientation key vector (Nakaoka eq. 8): a local axis of a robot frame should point
    along the direction from one marker to another.

    Attributes:
        frame: robot frame name.
        axis: (3,) float unit vector in ``frame``.
        from_marker: marker at the tail of the direction.
        to_marker: marker at the head of the direction.
        weight: fitting weight.
    """

    frame: str
    axis: np.ndarray
    from_marker: str
    to_marker: str
    weight: float = 1.0


@dataclass(frozen=True, eq=False)
class AddedMarker:
    """A marker added by the arrangement (offset or DOF-restricting marker, Nakaoka IV-A 3/4).

    Attributes:
        name: new marker name (not a standard marker).
        keypoint: where it sits on the robot.
        human: standard marker -> weight (weights sum to 1): its initial place on the human as an
            affine combination of (surviving) human markers.
        bones: new bones (pairs of marker names) whose lengths are constrained.
    """

    name: str
    keypoint: Keypoint
    human: Mapping[str, float]
    bones: tuple[tuple[str, str], ...]


@dataclass(frozen=True, eq=False)
class ArmHand:
    """The hand points of one arm for the arm imitation of Kim, Kim & Oh 2005 (``[arms.<side>]``
    of markers.toml; see docs/arms.md).

    Attributes:
        frame: the hand link all three points are fixed on.
        wrist: (3,) float [m] the wrist point in ``frame``.
        hand: (3,) float [m] the knuckles point in ``frame``.
        thumb: (3,) float [m] the derived third ("thumb") point in ``frame``.
        joints: the arm joints from shoulder to hand; empty = derived from the model.
    """

    frame: str
    wrist: np.ndarray
    hand: np.ndarray
    thumb: np.ndarray
    joints: tuple[str, ...] = ()


@dataclass(frozen=True)
class MarkerConfig:
    """The validated content of one ``markers.toml``.

    Attributes:
        path: the file.
        keypoints: every marker that survives the arrangement (standard markers not removed, then
            added markers) -> its robot keypoint, in that order.
        directions: orientation key vectors.
        remove: standard markers dropped for this robot.
        rigid: extra bones (pairs of surviving markers) that make segments rigid.
        add: added markers.
        arms: ``"left"``/``"right"`` -> hand points of the arm imitation (may be empty).
    """

    path: Path
    keypoints: Mapping[str, Keypoint]
    directions: tuple[Direction, ...]
    remove: tuple[str, ...]
    rigid: tuple[tuple[str, str], ...]
    add: tuple[AddedMarker, ...]
    arms: Mapping[str, ArmHand] = field(default_factory=dict)

    @property
    def markers(self) -> tuple[str, ...]:
        """Names of the markers after the arrangement (surviving standard ones, then added)."""
        return tuple(self.keypoints)

    def frame_references(self) -> list[tuple[str, str]]:
        """(key, frame name) for every frame this file names (checked against the model)."""
        refs = [(f"keypoints.{n}.frame", k.frame) for n, k in self.keypoints.items()]
        refs += [(f"directions[{i}].frame", d.frame) for i, d in enumerate(self.directions)]
        refs += [(f"arms.{side}.frame", a.frame) for side, a in self.arms.items()]
        return refs


_KEYPOINT_KEYS = ("frame", "offset", "weight")
_DIRECTION_KEYS = ("frame", "axis", "from", "to", "weight")
_ARRANGEMENT_KEYS = ("remove", "rigid", "add")
_ADD_KEYS = ("name", "frame", "offset", "weight", "human", "bones")
_ARM_KEYS = ("frame", "wrist", "hand", "thumb", "joints")


def _arms(path: Path, data: Mapping[str, Any]) -> dict[str, ArmHand]:
    """The optional ``[arms.left]`` / ``[arms.right]`` tables (hand points of imesh.arms)."""
    arms = _table(path, data, "arms")
    _check_keys(path, arms, "arms", SIDES)
    out = {}
    for side, tab in arms.items():
        key = f"arms.{side}"
        if not isinstance(tab, dict):
            raise RobotConfigError("must be a table {frame, wrist, hand, thumb, joints}",
                                   path=path, key=key)
        _check_keys(path, tab, key, _ARM_KEYS)
        points = {k: _vector(path, tab.get(k), f"{key}.{k}", 3)
                  for k in ("wrist", "hand", "thumb")}
        out[side] = ArmHand(frame=_string(path, tab, "frame", key), **points,
                            joints=_names(path, tab.get("joints", []), f"{key}.joints"))
    return out


def _keypoint(path: Path, tab: Any, key: str) -> Keypoint:
    if not isinstance(tab, dict):
        raise RobotConfigError("must be a table {frame, offset, weight}", path=path, key=key)
    _check_keys(path, tab, key, _KEYPOINT_KEYS)
    return Keypoint(frame=_string(path, tab, "frame", key),
                    offset=_vector(path, tab.get("offset", [0.0, 0.0, 0.0]), f"{key}.offset", 3),
                    weight=_number(path, tab.get("weight", 1.0), f"{key}.weight"))


def load_markers_config(path: str | os.PathLike) -> MarkerConfig:
    """Read and validate one markers.toml.

    Checks: keys and types; removed markers are standard markers; every surviving standard marker
    has a keypoint; added markers have new names, human weights summing to 1 over surviving
    standard markers, and bones between known markers; rigid bones and directions name surviving
    markers. Frame names are checked later against the model.

    Raises:
        RobotConfigError: naming the key and listing the valid names.
    """
    path = Path(path)
    data = _read_toml(path)
    _check_keys(path, data, "", ("keypoints", "directions", "arrangement", "arms"))
    arr = _table(path, data, "arrangement")
    _check_keys(path, arr, "arrangement", _ARRANGEMENT_KEYS)
    remove = _names(path, arr.get("remove", []), "arrangement.remove")
    for n in remove:
        if n not in STANDARD_MARKERS:
            raise RobotConfigError(f"{n!r} is not a standard marker", path=path,
                                   key="arrangement.remove",
                                   valid=closest_first(n, STANDARD_MARKERS))
    surviving = [m for m in STANDARD_MARKERS if m not in remove]

    raw = _table(path, data, "keypoints", required=True)
    for n in raw:
        if n not in STANDARD_MARKERS:
            raise RobotConfigError(f"{n!r} is not a standard marker (added markers go in "
                                   "[[arrangement.add]])", path=path, key=f"keypoints.{n}",
                                   valid=closest_first(n, STANDARD_MARKERS))
    missing = [m for m in surviving if m not in raw]
    if missing:
        raise RobotConfigError(f"no keypoint for marker(s) {', '.join(missing)} (give one or list "
                               "them in arrangement.remove)", path=path, key="keypoints",
                               valid=surviving)
    keypoints = {m: _keypoint(path, raw[m], f"keypoints.{m}") for m in surviving}

    adds: list[AddedMarker] = []
    for key, tab in _table_array(path, arr.get("add", []), "arrangement.add", _ADD_KEYS):
        name = _string(path, tab, "name", key)
        if name in STANDARD_MARKERS or name in keypoints:
            raise RobotConfigError(f"added marker name {name!r} is already a marker", path=path,
                                   key=f"{key}.name")
        kp = _keypoint(path, {k: tab[k] for k in _KEYPOINT_KEYS if k in tab}, key)
        human = tab.get("human")
        if not isinstance(human, dict) or not human:
            raise RobotConfigError("must be a table marker = weight (weights summing to 1)",
                                   path=path, key=f"{key}.human")
        weights = {}
        for m, w in human.items():
            if m not in surviving:
                raise RobotConfigError(f"{m!r} is not a surviving standard marker", path=path,
                                       key=f"{key}.human", valid=closest_first(m, surviving))
            weights[m] = _number(path, w, f"{key}.human.{m}")
        if abs(sum(weights.values()) - 1.0) > 1e-6:
            raise RobotConfigError(f"weights sum to {sum(weights.values()):.6g}, not 1", path=path,
                                   key=f"{key}.human")
        keypoints[name] = kp
        adds.append(AddedMarker(name=name, keypoint=kp, human=MappingProxyType(weights),
                                bones=_pairs(path, tab.get("bones", []), f"{key}.bones")))
    known = list(keypoints)

    def check_pairs(pairs: tuple[tuple[str, str], ...], key: str) -> None:
        for j, pair in enumerate(pairs):
            for n in pair:
                if n not in known:
                    raise RobotConfigError(f"unknown or removed marker {n!r}", path=path,
                                           key=f"{key}[{j}]", valid=closest_first(n, known))

    for i, a in enumerate(adds):
        check_pairs(a.bones, f"arrangement.add[{i}].bones")
    rigid = _pairs(path, arr.get("rigid", []), "arrangement.rigid")
    check_pairs(rigid, "arrangement.rigid")

    directions = []
    for key, tab in _table_array(path, data.get("directions", []), "directions",
                                 _DIRECTION_KEYS):
        axis = _vector(path, tab.get("axis"), f"{key}.axis", 3)
        if np.linalg.norm(axis) < 1e-9:
            raise RobotConfigError("axis must be non-zero", path=path, key=f"{key}.axis")
        ends = []
        for k in ("from", "to"):
            n = _string(path, tab, k, key)
            if n not in known:
                raise RobotConfigError(f"unknown or removed marker {n!r}", path=path,
                                       key=f"{key}.{k}", valid=closest_first(n, known))
            ends.append(n)
        directions.append(Direction(frame=_string(path, tab, "frame", key),
                                    axis=axis / np.linalg.norm(axis), from_marker=ends[0],
                                    to_marker=ends[1],
                                    weight=_number(path, tab.get("weight", 1.0), f"{key}.weight")))
    return MarkerConfig(path=path, keypoints=MappingProxyType(keypoints),
                        directions=tuple(directions), remove=remove, rigid=rigid, add=tuple(adds),
                        arms=MappingProxyType(_arms(path, data)))
