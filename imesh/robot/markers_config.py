"""Marker configuration files: ``robots/<name>/markers.toml``, beside robot.toml.

How the standard human markers map onto the robot (key points and key directions), how the marker
model is arranged for it (removed, rigid and added markers, Nakaoka & Komura 2012 sec. IV-A) and
the hand points of the arm imitation (docs/arms.md). Read and validated like robot.toml
(:mod:`imesh.robot.config`): no pinocchio here, frame names are checked by
:func:`imesh.robot.load_robot`, and each problem is a :class:`~imesh.robot.errors.RobotConfigError`
naming the key and listing the valid markers.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from ..human.markerset import STANDARD_MARKERS
from . import toml_fields as toml
from .config import SIDES
from .errors import RobotConfigError, closest_first


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
    arms = toml.table(path, data, "arms")
    toml.check_keys(path, arms, "arms", SIDES)
    out = {}
    for side, tab in arms.items():
        key = f"arms.{side}"
        if not isinstance(tab, dict):
            raise RobotConfigError("must be a table {frame, wrist, hand, thumb, joints}",
                                   path=path, key=key)
        toml.check_keys(path, tab, key, _ARM_KEYS)
        points = {k: toml.vector(path, tab.get(k), f"{key}.{k}", 3)
                  for k in ("wrist", "hand", "thumb")}
        out[side] = ArmHand(frame=toml.string(path, tab, "frame", key), **points,
                            joints=toml.name_list(path, tab.get("joints", []),
                                                  f"{key}.joints"))
    return out


def _keypoint(path: Path, tab: Any, key: str) -> Keypoint:
    """The key point table ``tab`` ({frame, offset, weight}) at dotted key ``key``."""
    if not isinstance(tab, dict):
        raise RobotConfigError("must be a table {frame, offset, weight}", path=path, key=key)
    toml.check_keys(path, tab, key, _KEYPOINT_KEYS)
    return Keypoint(frame=toml.string(path, tab, "frame", key),
                    offset=toml.vector(path, tab.get("offset", [0.0, 0.0, 0.0]), f"{key}.offset",
                                       3),
                    weight=toml.number(path, tab.get("weight", 1.0), f"{key}.weight"))


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
    data = toml.read_toml(path)
    toml.check_keys(path, data, "", ("keypoints", "directions", "arrangement", "arms"))
    arr = toml.table(path, data, "arrangement")
    toml.check_keys(path, arr, "arrangement", _ARRANGEMENT_KEYS)
    remove = toml.name_list(path, arr.get("remove", []), "arrangement.remove")
    for n in remove:
        if n not in STANDARD_MARKERS:
            raise RobotConfigError(f"{n!r} is not a standard marker", path=path,
                                   key="arrangement.remove",
                                   valid=closest_first(n, STANDARD_MARKERS))
    surviving = [m for m in STANDARD_MARKERS if m not in remove]

    raw = toml.table(path, data, "keypoints", required=True)
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
    for key, tab in toml.table_array(path, arr.get("add", []), "arrangement.add", _ADD_KEYS):
        name = toml.string(path, tab, "name", key)
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
            weights[m] = toml.number(path, w, f"{key}.human.{m}")
        if abs(sum(weights.values()) - 1.0) > 1e-6:
            raise RobotConfigError(f"weights sum to {sum(weights.values()):.6g}, not 1", path=path,
                                   key=f"{key}.human")
        keypoints[name] = kp
        adds.append(AddedMarker(name=name, keypoint=kp, human=MappingProxyType(weights),
                                bones=toml.name_pairs(path, tab.get("bones", []), f"{key}.bones")))
    known = list(keypoints)

    def check_pairs(pairs: tuple[tuple[str, str], ...], key: str) -> None:
        for j, pair in enumerate(pairs):
            for n in pair:
                if n not in known:
                    raise RobotConfigError(f"unknown or removed marker {n!r}", path=path,
                                           key=f"{key}[{j}]", valid=closest_first(n, known))

    for i, a in enumerate(adds):
        check_pairs(a.bones, f"arrangement.add[{i}].bones")
    rigid = toml.name_pairs(path, arr.get("rigid", []), "arrangement.rigid")
    check_pairs(rigid, "arrangement.rigid")

    directions = []
    for key, tab in toml.table_array(path, data.get("directions", []), "directions",
                                      _DIRECTION_KEYS):
        axis = toml.vector(path, tab.get("axis"), f"{key}.axis", 3)
        if np.linalg.norm(axis) < 1e-9:
            raise RobotConfigError("axis must be non-zero", path=path, key=f"{key}.axis")
        ends = []
        for k in ("from", "to"):
            n = toml.string(path, tab, k, key)
            if n not in known:
                raise RobotConfigError(f"unknown or removed marker {n!r}", path=path,
                                       key=f"{key}.{k}", valid=closest_first(n, known))
            ends.append(n)
        directions.append(Direction(frame=toml.string(path, tab, "frame", key),
                                    axis=axis / np.linalg.norm(axis), from_marker=ends[0],
                                    to_marker=ends[1],
                                    weight=toml.number(path, tab.get("weight", 1.0),
                                                       f"{key}.weight")))
    return MarkerConfig(path=path, keypoints=MappingProxyType(keypoints),
                        directions=tuple(directions), remove=remove, rigid=rigid, add=tuple(adds),
                        arms=MappingProxyType(_arms(path, data)))
