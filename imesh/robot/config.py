"""Robot configuration files: ``robots/<name>/robot.toml``.

This module only reads and validates the file (no pinocchio): what it says about the model source,
the joints to fix, the waist and foot frames, the soles, the nominal standing pose, the limits, the
collision proxies and the sagittal chain. Checks that need the model itself (frame and joint names
exist) happen in :func:`imesh.robot.load_robot`. The markers.toml beside it is read by
:mod:`imesh.robot.markers_config`.

Every problem raises :class:`~imesh.robot.errors.RobotConfigError` naming the file, the key and the
valid options.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np

from . import toml_fields as toml
from .errors import RobotConfigError

#: The robot folders shipped with imesh (each holds robot.toml, markers.toml): ``imesh/robots``
#: in an installed wheel (the build copies ``<repo>/robots`` there, setup.py), else
#: ``<repo>/robots`` of a checkout (editable install).
ROBOTS_DIR: Path = next((d for d in (Path(__file__).resolve().parents[1] / "robots",
                                     Path(__file__).resolve().parents[2] / "robots")
                         if d.is_dir()), Path(__file__).resolve().parents[2] / "robots")

#: Default acceleration limit [rad/s^2] when robot.toml gives none (see docs/robots.md).
DEFAULT_ACCELERATION = 20.0

#: The two sides, in the order of every per-side table (feet, soles, arms).
SIDES: tuple[str, str] = ("left", "right")


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
        in_solve: the whole-body solve keeps the self-collision capsules apart
            (``WholeBodyConfig.collision.enabled``, docs/collision.md); false for a robot whose
            capsules are not yet validated against its geometry.
    """

    use_visual: tuple[str, ...] = ()
    skip: tuple[str, ...] = ()
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


_TOP_KEYS = ("name", "licence", "description", "dof", "model", "joints", "frames", "soles",
             "nominal", "limits", "collision", "sagittal")
_MODEL_KEYS = ("source", "package", "distribution", "urdf", "install", "url")
_SOURCES = ("package", "user")
_FRAME_KEYS = ("waist", "left_foot", "right_foot")
_SOLE_KEYS = ("frame", "center", "half_extents", "normal")
_LIMIT_KEYS = ("acceleration_default", "acceleration", "velocity", "effort", "position", "source")
_COLLISION_KEYS = ("use_visual", "skip", "in_solve")


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
    data = toml.read_toml(path)
    toml.check_keys(path, data, "", _TOP_KEYS)
    name = toml.string(path, data, "name", "")
    licence = toml.string(path, data, "licence", "")
    description = toml.string(path, data, "description", "", required=False)
    dof = data.get("dof")
    if dof is not None and (isinstance(dof, bool) or not isinstance(dof, int) or dof <= 0):
        raise RobotConfigError(f"must be a positive integer, got {dof!r}", path=path, key="dof")

    m = toml.table(path, data, "model", required=True)
    toml.check_keys(path, m, "model", _MODEL_KEYS)
    source = toml.string(path, m, "source", "model")
    if source not in _SOURCES:
        raise RobotConfigError(f"unknown model source {source!r}", path=path, key="model.source",
                               valid=_SOURCES)
    package = toml.string(path, m, "package", "model", required=False)
    distribution = toml.string(path, m, "distribution", "model", required=False)
    urdf = toml.string(path, m, "urdf", "model")
    if source == "package" and not (package or distribution):
        raise RobotConfigError("source = \"package\" needs package (import name) or "
                               "distribution (pip name)", path=path, key="model.package")
    model = ModelSource(source=source, package=package, distribution=distribution, urdf=urdf,
                        install=toml.string(path, m, "install", "model", required=False),
                        url=toml.string(path, m, "url", "model", required=False))

    joints = toml.table(path, data, "joints")
    toml.check_keys(path, joints, "joints", ("fixed",))
    fixed = toml.name_list(path, joints.get("fixed", []), "joints.fixed")

    frames = toml.table(path, data, "frames", required=True)
    toml.check_keys(path, frames, "frames", _FRAME_KEYS)
    waist = toml.string(path, frames, "waist", "frames")
    feet = {side: toml.string(path, frames, f"{side}_foot", "frames") for side in SIDES}

    soles: dict[str, SoleRectangle] = {}
    sole_tables = toml.table(path, data, "soles")
    toml.check_keys(path, sole_tables, "soles", SIDES)
    for side, tab in sole_tables.items():
        key = f"soles.{side}"
        if not isinstance(tab, dict):
            raise RobotConfigError("must be a table", path=path, key=key)
        toml.check_keys(path, tab, key, _SOLE_KEYS)
        half = toml.vector(path, tab.get("half_extents"), f"{key}.half_extents", 2)
        if np.any(half <= 0):
            raise RobotConfigError("half extents must be positive", path=path,
                                   key=f"{key}.half_extents")
        normal = toml.vector(path, tab.get("normal", [0.0, 0.0, 1.0]), f"{key}.normal", 3)
        if np.linalg.norm(normal) < 1e-9:
            raise RobotConfigError("normal must be non-zero", path=path, key=f"{key}.normal")
        soles[side] = SoleRectangle(
            frame=toml.string(path, tab, "frame", key, required=False, default=feet[side]),
            center=toml.vector(path, tab.get("center"), f"{key}.center", 3),
            half_extents=half, normal=normal / np.linalg.norm(normal))

    nominal = toml.joint_numbers(path, toml.table(path, data, "nominal"), "nominal")

    lim = toml.table(path, data, "limits")
    toml.check_keys(path, lim, "limits", _LIMIT_KEYS)
    position: dict[str, tuple[float, float]] = {}
    for j, pair in dict(lim.get("position", {})).items():
        lo, hi = toml.vector(path, pair, f"limits.position.{j}", 2)
        if not lo < hi:
            raise RobotConfigError(f"lower {lo} must be below upper {hi}", path=path,
                                   key=f"limits.position.{j}")
        position[j] = (float(lo), float(hi))
    limits = LimitsConfig(
        acceleration_default=toml.number(
            path, lim.get("acceleration_default", DEFAULT_ACCELERATION),
            "limits.acceleration_default", positive=True),
        acceleration=MappingProxyType(toml.joint_numbers(path, lim.get("acceleration", {}),
                                                          "limits.acceleration", positive=True)),
        velocity=MappingProxyType(toml.joint_numbers(path, lim.get("velocity", {}),
                                                      "limits.velocity", positive=True)),
        effort=MappingProxyType(toml.joint_numbers(path, lim.get("effort", {}), "limits.effort",
                                                    positive=True)),
        position=MappingProxyType(position),
        source=toml.string(path, lim, "source", "limits", required=False),
    )

    col = toml.table(path, data, "collision")
    toml.check_keys(path, col, "collision", _COLLISION_KEYS)
    collision = CollisionConfig(
        use_visual=toml.name_list(path, col.get("use_visual", []), "collision.use_visual"),
        skip=toml.name_list(path, col.get("skip", []), "collision.skip"),
        in_solve=toml.flag(path, col.get("in_solve", True), "collision.in_solve"),
    )

    # the motion reduction's sagittal chain (imesh.reduction): six pitch joints or none
    sagittal = toml.table(path, data, "sagittal")
    toml.check_keys(path, sagittal, "sagittal", ("joints",))
    sagittal_joints = toml.name_list(path, sagittal.get("joints", []), "sagittal.joints")
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
