"""Marker-model arrangement for a robot (Nakaoka & Komura 2012, sec. IV-A).

A robot has fewer joints and DOF than a human marker model. Before the morph, the standard human
markers are arranged per the robot's ``markers.toml``:

1. extra markers are removed (e.g. the spine marker for a robot without a spine joint); their
   children are re-attached to their parent so the skeleton stays a tree;
2. bones are added that make segments rigid (pelvis triangle, shoulders to waist);
3. markers and bones are added that restrict a joint's DOF or carry a joint offset (a collar
   marker); each added marker starts on the human as an affine combination of human markers;
4. the pelvis marker is turned about the hip axis to sit where the robot's does: mocap
   skeletons put their root 15-25 degrees behind the vertical through the hip joints (CMU: 19),
   robots put their waist key point above or in front of it (G1: 15 degrees in front); left as
   is, the rigid pelvis triangle would pitch the robot's base by the difference and its waist
   joint would have to bend the torso back by as much (the offset problem of sec. IV-A, which
   the paper solves for the collar with an added marker);
5. markers the robot carries rigidly on its trunk besides the trunk's own markers (the neck key
   point on every robot; the head where it is the neck joints' centre or the head is fixed; added
   markers such as a collar) are listed (``Arrangement.carried``) and, after the morph, put
   where the robot has them on the trunk (:func:`carry_on_trunk`): the morph keeps only their
   bone lengths, so their direction from the trunk drifts with the deformation (the G1 wave's
   neck marker 46 mm behind the trunk point; HRP-4C's neck 169 mm from its key point in the
   initial fit before the key points moved to the body points of the markers). Placing them
   on the trunk before the morph as well changed the initial fit by at most 2 mm on the walk
   and wave, and made the CMU pirouettes' fit worse (G1 key points 146 -> 174 mm RMS).

Target lengths of every length-constrained pair come from the robot's nominal pose: the distance
between the two markers' robot key points. The human is first scaled (about the floor point under
its pelvis) so that its size matches the robot's; the morph then takes every pair from the
scaled human length to the robot length.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..core.motion import MarkerMotion
from ..errors import ImeshError, OptionError
from ..mesh.bones import bone_lengths

log = logging.getLogger(__name__)


#: Children of the leg bones (thigh, shank): their lengths set the human-to-robot scale.
LEG_MARKERS = ("knee_l", "ankle_l", "knee_r", "ankle_r")
#: The markers whose robot key points define the trunk's orientation (step 5 of the module);
#: the chest's key-point frame is the robot's trunk.
TRUNK_MARKERS = ("pelvis", "chest", "shoulder_l", "shoulder_r")
#: Largest motion [m] of a key point relative to the trunk over random joint configurations for
#: it to count as carried by the trunk.
CARRIED_TOLERANCE_M = 0.005


class ArrangementError(ImeshError):
    """The marker model cannot be arranged: a marker named by markers.toml is not in the
    motion, or two markers of a bone sit on the same robot point."""


@dataclass(frozen=True, eq=False)
class Arrangement:
    """The human marker model arranged for a robot, with its morph targets.

    Attributes:
        motion: (T, M', 3) arranged human markers (scaled to the robot's size, floor at z = 0),
            bones = the re-attached tree.
        pairs: (P, 2) length-constrained pairs: tree bones, rigid bones, bones of added markers.
        target_lengths_m: (P,) lengths of those pairs on the robot in its nominal pose [m].
        keypoints: marker -> robot key point (``imesh.robot.markers_config.Keypoint``), in
            ``motion.names`` order.
        directions: key directions (``imesh.robot.markers_config.Direction``) whose markers
            survived.
        scale: factor applied to the human before the morph.
        robot: name of the robot the markers are arranged for.
        pair_names: (P,) the marker names of each pair in ``pairs``.
        robot_points_m: (M', 3) each marker's robot key point in the robot's nominal pose,
            soles at z = 0 [m] (where the morph's targets and the foot geometry come from).
        carried: markers put on the trunk at the robot's geometry (step 5 of the module).
    """

    motion: MarkerMotion
    pairs: np.ndarray
    target_lengths_m: np.ndarray
    keypoints: Mapping
    directions: tuple
    scale: float
    robot: str
    pair_names: tuple[tuple[str, str], ...]
    robot_points_m: np.ndarray
    carried: tuple[str, ...] = ()


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


def _pelvis_angle(points: np.ndarray, pelvis: int, hip_l: int, hip_r: int
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signed angle [rad] of (pelvis - hip midpoint) from the vertical about the hip axis.

    Args:
        points: (..., M, 3) positions.

    Returns:
        (angle (...,), unit hip axis (..., 3), pelvis - hip midpoint (..., 3)).
    """
    axis = points[..., hip_l, :] - points[..., hip_r, :]
    axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    v = points[..., pelvis, :] - 0.5 * (points[..., hip_l, :] + points[..., hip_r, :])
    up = np.array([0.0, 0.0, 1.0]) - axis[..., 2:3] * axis
    vp = v - np.sum(v * axis, axis=-1, keepdims=True) * axis
    angle = np.arctan2(np.sum(np.cross(up, vp) * axis, axis=-1), np.sum(up * vp, axis=-1))
    return angle, axis, v


def _align_pelvis(pos: np.ndarray, robot_pts: np.ndarray, pelvis: int, hip_l: int, hip_r: int
                  ) -> tuple[np.ndarray, float]:
    """Turn the pelvis marker about the hip axis (every frame by the same angle) so its median
    angle from the vertical matches the robot's in the nominal pose (step 4 of the module)."""
    human, axis, v = _pelvis_angle(pos, pelvis, hip_l, hip_r)
    robot_angle = float(_pelvis_angle(robot_pts, pelvis, hip_l, hip_r)[0])
    turn = robot_angle - float(np.median(human))
    c, s = np.cos(turn), np.sin(turn)
    # Rodrigues: v' = v cos + (a x v) sin + a (a . v)(1 - cos)
    v_new = (v * c + np.cross(axis, v) * s
             + axis * np.sum(axis * v, axis=-1, keepdims=True) * (1.0 - c))
    out = pos.copy()
    out[:, pelvis] = 0.5 * (pos[:, hip_l] + pos[:, hip_r]) + v_new
    return out, turn


def _kabsch_rotations(model_pts: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotations R_t minimizing sum_k |R_t (m_k - mean m) - (p_tk - mean p_t)|^2.

    Args:
        model_pts: (K, 3) the model points.
        pts: (T, K, 3) the same points per frame.
    """
    a = model_pts - model_pts.mean(axis=0)
    b = pts - pts.mean(axis=1, keepdims=True)
    u, _, vt = np.linalg.svd(np.einsum("ki,tkj->tij", a, b))
    d = np.sign(np.linalg.det(np.einsum("tij,tjk->tik", u, vt)))
    u[:, :, 2] *= d[:, None]
    return np.einsum("tij,tjk->tki", u, vt)


def carried_by_trunk(robot, keypoints: Mapping, trunk: str = "chest",
                     tolerance_m: float = CARRIED_TOLERANCE_M, samples: int = 8) -> tuple[str, ...]:
    """Markers whose key points the robot carries rigidly with the frame of ``trunk``'s key
    point: their position in that frame moves by less than ``tolerance_m`` over random joint
    configurations (a point on its joints' axes, as a neck key point at the neck joints' centre,
    counts as carried).

    Args:
        robot: the Robot.
        keypoints: marker -> Keypoint.
        trunk: the marker whose key point's frame is the trunk.
        tolerance_m: largest motion in the trunk frame [m].
        samples: random configurations tried (a fixed seed: the answer is the same every call).

    Returns:
        The carried markers (``trunk`` excluded), in ``keypoints`` order.
    """
    if trunk not in keypoints:
        return ()
    names = [n for n in keypoints if n != trunk]
    frames = [robot.frame_id(keypoints[n].frame) for n in names]
    offsets = np.array([keypoints[n].offset for n in names], dtype=float).reshape(-1, 3)
    trunk_frame = robot.frame_id(keypoints[trunk].frame)

    def local(q):
        pose = robot.frame_placements(q, [trunk_frame])[0]
        return (robot.frame_positions(q, frames, offsets) - pose[:3, 3]) @ pose[:3, :3]

    ref = local(robot.q_nominal)
    rng = np.random.default_rng(0)
    moved = np.zeros(len(names))
    for _ in range(samples):
        moved = np.maximum(moved, np.linalg.norm(
            local(robot.random_configuration(rng, scale=0.5)) - ref, axis=1))
    return tuple(n for n, m in zip(names, moved, strict=True) if m < tolerance_m)


def carry_on_trunk(positions_m: np.ndarray, arrangement: Arrangement) -> np.ndarray:
    """The carried markers of an arrangement put back on the trunk after the morph.

    The morph (Laplacian deformation with bone lengths, paper eq. 5-6) keeps only the carried
    markers' bone lengths: their direction from the trunk drifts with the deformation (the G1
    wave's neck marker 46 mm behind the trunk point it was arranged on). The trunk markers
    (:data:`TRUNK_MARKERS`) are rigid in the marker model with the robot's lengths, so the
    rotation that maps the robot's trunk in its nominal pose onto them (Kabsch) puts each
    carried marker where the robot has it; a tree descendant that is not carried moves with
    its carried ancestor.

    Args:
        positions_m: (T, M, 3) markers in ``arrangement.motion.names`` order (the morph's
            output) [m].
        arrangement: the Arrangement.

    Returns:
        (T, M, 3) the markers, the carried ones on the trunk [m].
    """
    if not arrangement.carried:
        return positions_m
    names = list(arrangement.motion.names)
    index = {n: i for i, n in enumerate(names)}
    trunk = [index[n] for n in TRUNK_MARKERS]
    robot_pts = arrangement.robot_points_m
    rot = _kabsch_rotations(robot_pts[trunk], positions_m[:, trunk])
    centre = positions_m[:, trunk].mean(axis=1)
    robot_centre = robot_pts[trunk].mean(axis=0)
    bones = arrangement.motion.bones
    tree = [(names[a], names[b]) for a, b in bones]
    children: dict[str, list[str]] = {}
    for p, c in tree:
        children.setdefault(p, []).append(c)
    out = positions_m.copy()
    for name in arrangement.carried:
        i = index[name]
        new = centre + np.einsum("tij,j->ti", rot, robot_pts[i] - robot_centre)
        shift = new - positions_m[:, i]
        out[:, i] = new
        stack = [c for c in children.get(name, []) if c not in arrangement.carried]
        while stack:
            c = stack.pop()
            out[:, index[c]] = positions_m[:, index[c]] + shift
            stack.extend(k for k in children.get(c, []) if k not in arrangement.carried)
    return out


def arrange_for_robot(motion: MarkerMotion, robot, *, scale: float | None = None,
                      centre_m: np.ndarray | None = None) -> Arrangement:
    """Arrange a standard human motion for ``robot`` per its markers.toml (paper sec. IV-A).

    Args:
        motion: complete standard-marker motion (``adapt.prepare_markers``).
        robot: an :class:`imesh.robot.Robot` with a markers.toml (``robot.markers``).
        scale: the human-to-robot factor (None: the robot's legs over the human's, below).
            Two partners in one world share one (:mod:`imesh.partners`).
        centre_m: (3,) the fixed point of the scaling [m] (None: the floor point under the
            markers' centroid at frame 0). Two partners share one, so both stay in one world.

    Returns:
        The Arrangement: scaled, arranged markers and the robot target lengths.

    Raises:
        ArrangementError: a marker named by markers.toml is not in the motion, or a bone joins
            two markers on the same robot point.
    """
    model = robot.markers
    names = motion.names
    unknown = sorted({m for m in model.remove if m not in names}
                     | {m for a in model.add for m in a.human if m not in names}
                     | {m for m in model.keypoints if m not in names
                        and m not in {a.name for a in model.add}})
    if unknown:
        raise ArrangementError(f"{model.path}: markers {unknown} are not in the motion; "
                               f"available: {', '.join(names)}")
    remove = set(model.remove)
    kept = [n for n in names if n not in remove]
    tree = _reattach(names, motion.bones, remove)
    added_names = [a.name for a in model.add]
    all_names = kept + added_names
    missing = [n for n in all_names if n not in model.keypoints]
    if missing:
        raise ArrangementError(f"{model.path}: markers {missing} have no key point; key points: "
                               f"{', '.join(model.keypoints)}")
    keypoints = {n: model.keypoints[n] for n in all_names}

    # positions: kept markers, then added markers as affine combinations (all frames at once)
    pos = motion.positions_m[:, motion.indices(kept)]
    if model.add:
        w = np.zeros((len(model.add), motion.n_markers))
        lookup = {n: i for i, n in enumerate(names)}
        for k, a in enumerate(model.add):
            for m, wt in a.human.items():
                w[k, lookup[m]] += wt
        pos = np.concatenate([pos, np.einsum("km,tmc->tkc", w, motion.positions_m)], axis=1)
    index = {n: i for i, n in enumerate(all_names)}
    tree_idx = np.array([[index[a], index[b]] for a, b in tree], dtype=np.int64).reshape(-1, 2)
    extra = list(model.rigid) + [p for a in model.add for p in a.bones]
    pair_names = list(tree) + [p for p in extra if p not in tree and p[::-1] not in tree]
    pairs = np.array([[index[a], index[b]] for a, b in pair_names], dtype=np.int64)

    # robot lengths in the nominal pose
    frames = [robot.frame_id(k.frame) for k in keypoints.values()]
    offsets = np.array([k.offset for k in keypoints.values()], dtype=float)
    robot_pts = robot.frame_positions(robot.q_nominal, frames, offsets)
    target = np.linalg.norm(robot_pts[pairs[:, 0]] - robot_pts[pairs[:, 1]], axis=1)
    if (target < 1e-4).any():
        k = int(np.argmin(target))
        a, b = pair_names[k]
        raise ArrangementError(f"{model.path}: markers {a} and {b} sit on the same robot point "
                               f"(length {target[k]:.2g} m): a bone needs two distinct points")

    # Scale the human to the robot's size about the floor point under its centroid at frame 0.
    # The legs set the scale: strides and foot placements must be reachable by the robot's
    # legs, or the support-foot constraints conflict with the leg lengths.
    human = np.median(bone_lengths(pos, tree_idx), axis=0)
    robot_tree = np.linalg.norm(robot_pts[tree_idx[:, 0]] - robot_pts[tree_idx[:, 1]], axis=1)
    children = [b for _, b in tree]
    legs = np.array([c in LEG_MARKERS for c in children])
    if not legs.any():
        legs = np.ones(len(children), dtype=bool)
    if scale is None:
        scale = float(robot_tree[legs].sum() / human[legs].sum())
    if not (np.isfinite(scale) and scale > 0):
        raise OptionError("human-to-robot scale", scale, "a positive number")
    centre = pos[0].mean(axis=0) * [1.0, 1.0, 0.0] if centre_m is None else np.asarray(centre_m)
    pos = centre + (pos - centre) * scale
    if all(m in index for m in ("pelvis", "hip_l", "hip_r")):
        pos, turn = _align_pelvis(pos, robot_pts, index["pelvis"], index["hip_l"],
                                  index["hip_r"])
        log.info("pelvis marker turned by %.1f deg about the hip axis to the robot's waist "
                 "point", np.degrees(turn))
    carried: tuple[str, ...] = ()
    if all(m in index for m in TRUNK_MARKERS):
        carried = tuple(n for n in carried_by_trunk(robot, keypoints)
                        if n not in TRUNK_MARKERS)
        log.info("markers carried by the trunk, put on it after the morph: %s",
                 ", ".join(carried) or "none")
    arranged = MarkerMotion(positions_m=pos, fps=motion.fps, names=tuple(all_names),
                            valid=np.ones(pos.shape[:2], dtype=bool), bones=tree_idx,
                            source=motion.source, meta=motion.meta)
    all_set = set(all_names)
    directions = tuple(d for d in model.directions
                       if d.from_marker in all_set and d.to_marker in all_set)
    log.info("arranged %d -> %d markers for %s (removed %s, added %s, %d length pairs, "
             "human scaled by %.3f)", motion.n_markers, len(all_names), robot.name,
             sorted(remove) or "none", added_names or "none", len(pairs), scale)
    return Arrangement(motion=arranged, pairs=pairs, target_lengths_m=target,
                       keypoints=keypoints, directions=directions, scale=scale,
                       robot=robot.name, pair_names=tuple(pair_names), robot_points_m=robot_pts,
                       carried=carried)
