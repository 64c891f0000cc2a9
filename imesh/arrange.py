"""Marker-model arrangement for a robot (Nakaoka & Komura 2012, sec. IV-A).

A robot has fewer joints and DOF than a human marker model. Before the morph, the standard human
markers are arranged per the robot's ``markers.toml``:

1. extra markers are removed (e.g. the spine marker for a robot without a spine joint); their
   children are re-attached to their parent so the skeleton stays a tree;
2. bones are added that make segments rigid (pelvis triangle, shoulders to waist);
3. markers and bones are added that restrict a joint's DOF or carry a joint offset (a collar
   marker); each added marker starts on the human as an affine combination of human markers.

Target lengths of every length-constrained pair come from the robot's nominal pose: the distance
between the two markers' robot key points. The human is first scaled (about the floor point under
its pelvis) so that its size matches the robot's; the morph then takes every pair from the
scaled human length to the robot length.
"""

from __future__ import annotations

import logging
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import ImeshError, OptionError
from .mesh.bones import bone_lengths
from .motion import MarkerMotion

log = logging.getLogger(__name__)


class MarkerModelError(ImeshError):
    """A markers.toml is invalid: unknown marker or frame, missing key point, bad weights."""


@dataclass(frozen=True)
class Keypoint:
    """A human marker's place on the robot: a point fixed in a robot frame.

    Attributes:
        marker: human marker name.
        frame: robot frame name.
        offset: (3,) point in the frame [m].
        weight: weight of its position error in the joint fitting.
    """

    marker: str
    frame: str
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    weight: float = 1.0


@dataclass(frozen=True)
class Direction:
    """An orientation key vector: ``axis`` of robot ``frame`` should point from ``from_marker``
    to ``to_marker`` (the orientation errors of paper eq. 8)."""

    frame: str
    axis: tuple[float, float, float]
    from_marker: str
    to_marker: str
    weight: float = 1.0


@dataclass(frozen=True)
class AddedMarker:
    """A marker added by the arrangement.

    Attributes:
        name: new marker name.
        keypoint: its place on the robot.
        human: human marker -> weight (sum 1): where it starts on the human.
        bones: length-constrained pairs it takes part in.
    """

    name: str
    keypoint: Keypoint
    human: tuple[tuple[str, float], ...]
    bones: tuple[tuple[str, str], ...]


@dataclass(frozen=True)
class MarkerModel:
    """A robot's markers.toml: key points, key directions and arrangement operations."""

    keypoints: tuple[Keypoint, ...]
    directions: tuple[Direction, ...] = ()
    remove: tuple[str, ...] = ()
    rigid: tuple[tuple[str, str], ...] = ()
    added: tuple[AddedMarker, ...] = ()
    path: str = ""

    def keypoint(self, marker: str) -> Keypoint:
        for k in self.keypoints:
            if k.marker == marker:
                return k
        for a in self.added:
            if a.name == marker:
                return a.keypoint
        raise MarkerModelError(
            f"{self.path}: no key point for marker {marker!r}; key points: "
            f"{', '.join(k.marker for k in self.keypoints)}")


def _vec3(path: str, where: str, value) -> tuple[float, float, float]:
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise MarkerModelError(f"{path}: {where} must be 3 finite numbers, got {value!r}")
    return tuple(float(v) for v in arr)


def _pair(path: str, where: str, value) -> tuple[str, str]:
    if not (isinstance(value, list) and len(value) == 2 and all(isinstance(v, str)
                                                                for v in value)):
        raise MarkerModelError(f"{path}: {where} must be a pair of marker names, got {value!r}")
    return (value[0], value[1])


def _keypoint(path: str, marker: str, spec: dict) -> Keypoint:
    if "frame" not in spec:
        raise MarkerModelError(f"{path}: key point {marker!r} needs a 'frame'")
    weight = float(spec.get("weight", 1.0))
    if not (np.isfinite(weight) and weight >= 0):
        raise MarkerModelError(f"{path}: key point {marker!r} weight must be >= 0")
    return Keypoint(marker=marker, frame=str(spec["frame"]),
                    offset=_vec3(path, f"key point {marker!r} offset", spec.get("offset",
                                                                              [0, 0, 0])),
                    weight=weight)


def parse_marker_model(text: str, path: str = "markers.toml") -> MarkerModel:
    """Parse and validate the text of a markers.toml (schema in docs/robots.md)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise MarkerModelError(f"{path}: not valid TOML ({exc})") from None
    keypoints = tuple(_keypoint(path, m, spec) for m, spec in data.get("keypoints", {}).items())
    directions = []
    for k, spec in enumerate(data.get("directions", [])):
        missing = [key for key in ("frame", "axis", "from", "to") if key not in spec]
        if missing:
            raise MarkerModelError(f"{path}: directions[{k}] lacks {', '.join(missing)}")
        axis = np.asarray(_vec3(path, f"directions[{k}] axis", spec["axis"]))
        if np.linalg.norm(axis) < 1e-9:
            raise MarkerModelError(f"{path}: directions[{k}] axis is zero")
        directions.append(Direction(frame=str(spec["frame"]),
                                    axis=tuple(float(v) for v in axis / np.linalg.norm(axis)),
                                    from_marker=str(spec["from"]), to_marker=str(spec["to"]),
                                    weight=float(spec.get("weight", 1.0))))
    arr = data.get("arrangement", {})
    remove = tuple(str(m) for m in arr.get("remove", []))
    rigid = tuple(_pair(path, f"arrangement.rigid[{k}]", p)
                  for k, p in enumerate(arr.get("rigid", [])))
    added = []
    for k, spec in enumerate(arr.get("add", [])):
        if "name" not in spec or "human" not in spec:
            raise MarkerModelError(f"{path}: arrangement.add[{k}] needs 'name' and 'human'")
        human = tuple((str(m), float(w)) for m, w in dict(spec["human"]).items())
        if abs(sum(w for _, w in human) - 1.0) > 1e-6:
            raise MarkerModelError(f"{path}: arrangement.add[{k}] human weights must sum to 1")
        added.append(AddedMarker(
            name=str(spec["name"]), keypoint=_keypoint(path, str(spec["name"]), spec),
            human=human,
            bones=tuple(_pair(path, f"arrangement.add[{k}].bones", b)
                        for b in spec.get("bones", []))))
    return MarkerModel(keypoints=keypoints, directions=tuple(directions), remove=remove,
                       rigid=rigid, added=tuple(added), path=path)


def load_marker_model(path: str | os.PathLike) -> MarkerModel:
    """Read a markers.toml file."""
    p = Path(path)
    if not p.is_file():
        raise MarkerModelError(f"{p}: no such markers.toml")
    return parse_marker_model(p.read_text(), str(p))


@dataclass(frozen=True, eq=False)
class Arrangement:
    """The human marker model arranged for a robot, with its morph targets.

    Attributes:
        motion: (T, M', 3) arranged human markers (scaled to the robot's size, floor at z = 0),
            bones = the re-attached tree.
        pairs: (P, 2) length-constrained pairs: tree bones, rigid bones, bones of added markers.
        target_lengths_m: (P,) lengths of those pairs on the robot in its nominal pose [m].
        keypoints: key point of every arranged marker, in ``motion.names`` order.
        directions: key directions whose markers survived the arrangement.
        scale: factor applied to the human before the morph.
    """

    motion: MarkerMotion
    pairs: np.ndarray
    target_lengths_m: np.ndarray
    keypoints: tuple[Keypoint, ...]
    directions: tuple[Direction, ...]
    scale: float
    meta: dict = field(default_factory=dict)


def _reattach(names: tuple[str, ...], bones: np.ndarray, remove: set[str]
              ) -> list[tuple[str, str]]:
    """Tree bones among kept markers: children of removed markers go to the nearest kept
    ancestor."""
    parent = {names[b]: names[a] for a, b in bones}
    out = []
    for child in names:
        if child in remove or child not in parent:
            continue
        p = parent[child]
        while p in remove:
            p = parent.get(p)
            if p is None:
                break
        if p is not None:
            out.append((p, child))
    return out


def arrange_for_robot(motion: MarkerMotion, robot, model: MarkerModel) -> Arrangement:
    """Arrange a standard human motion for ``robot`` per ``model`` (paper sec. IV-A).

    Args:
        motion: complete standard-marker motion (``adapt.prepare_markers``).
        robot: an :class:`imesh.robot.Robot` (key point positions in its nominal pose).
        model: the robot's MarkerModel.

    Returns:
        The Arrangement: scaled, arranged markers and the robot target lengths.

    Raises:
        MarkerModelError: a marker named by the model is not in the motion, a kept marker has no
            key point, or a frame does not exist on the robot (listing valid frames).
    """
    names = motion.names
    unknown = sorted({m for m in model.remove if m not in names}
                     | {m for a in model.added for m, _ in a.human if m not in names})
    if unknown:
        raise MarkerModelError(f"{model.path}: markers {unknown} are not in the motion; "
                               f"available: {', '.join(names)}")
    remove = set(model.remove)
    kept = [n for n in names if n not in remove]
    tree = _reattach(names, motion.bones, remove)
    added_names = [a.name for a in model.added]
    all_names = kept + added_names
    all_set = set(all_names)
    for a, b in list(model.rigid) + [p for a_ in model.added for p in a_.bones]:
        if a not in all_set or b not in all_set:
            raise MarkerModelError(f"{model.path}: pair ({a}, {b}) names a marker that is not "
                                   f"in the arranged model ({', '.join(all_names)})")
    keypoints = tuple(model.keypoint(n) for n in all_names)

    # positions: kept markers, then added markers as affine combinations (all frames at once)
    idx = motion.indices(kept)
    pos = motion.positions_m[:, idx]
    if model.added:
        w = np.zeros((len(model.added), motion.n_markers))
        lookup = {n: i for i, n in enumerate(names)}
        for k, a in enumerate(model.added):
            for m, wt in a.human:
                w[k, lookup[m]] += wt
        pos = np.concatenate([pos, np.einsum("km,tmc->tkc", w, motion.positions_m)], axis=1)
    index = {n: i for i, n in enumerate(all_names)}
    tree_idx = np.array([[index[a], index[b]] for a, b in tree], dtype=np.int64).reshape(-1, 2)
    extra = list(model.rigid) + [p for a in model.added for p in a.bones]
    pair_names = list(tree) + [p for p in extra if p not in tree and p[::-1] not in tree]
    pairs = np.array([[index[a], index[b]] for a, b in pair_names], dtype=np.int64)

    # robot lengths in the nominal pose
    frames = [robot.frame_id(k.frame) for k in keypoints]
    offsets = np.array([k.offset for k in keypoints])
    robot_pts = robot.frame_positions(robot.q_nominal, frames, offsets)
    target = np.linalg.norm(robot_pts[pairs[:, 0]] - robot_pts[pairs[:, 1]], axis=1)
    if (target < 1e-4).any():
        k = int(np.argmin(target))
        a, b = pair_names[k]
        raise MarkerModelError(f"{model.path}: markers {a} and {b} sit on the same robot point "
                               f"(length {target[k]:.2g} m): a bone needs two distinct points")

    # scale the human to the robot's size about the floor point under its pelvis at frame 0
    human = bone_lengths(pos, tree_idx)
    robot_tree = np.linalg.norm(robot_pts[tree_idx[:, 0]] - robot_pts[tree_idx[:, 1]], axis=1)
    scale = float(robot_tree.sum() / np.median(human, axis=0).sum())
    if not (np.isfinite(scale) and scale > 0):
        raise OptionError("human-to-robot scale", scale, "a positive number")
    centre = pos[0].mean(axis=0) * [1.0, 1.0, 0.0]
    pos = centre + (pos - centre) * scale
    arranged = MarkerMotion(positions_m=pos, fps=motion.fps, names=tuple(all_names),
                            valid=np.ones(pos.shape[:2], dtype=bool), bones=tree_idx,
                            source=motion.source, meta={**motion.meta, "robot": robot.name,
                                                        "human_scale": scale})
    directions = tuple(d for d in model.directions
                       if d.from_marker in all_set and d.to_marker in all_set)
    log.info("arranged %d -> %d markers for %s (removed %s, added %s, %d length pairs, "
             "human scaled by %.3f)", motion.n_markers, len(all_names), robot.name,
             sorted(remove) or "none", added_names or "none", len(pairs), scale)
    return Arrangement(motion=arranged, pairs=pairs, target_lengths_m=target,
                       keypoints=keypoints, directions=directions, scale=scale,
                       meta={"pair_names": pair_names, "robot_points_m": robot_pts})
