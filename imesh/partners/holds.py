"""The partners' hand holds: detected in the source, kept between the robots.

A hold is a frame where a hand marker of one person is closer than ``distance_m`` (10 cm) to a
hand marker of the other in the source. The joint morph (:mod:`.mesh`) keeps the two people's
hands together, but each robot then tracks its own markers with its own error (tens of mm of
key-point RMS), so the robots' hands can still drift apart. The second robot's solve therefore
aims its holding hand where the first robot's hand actually is, offset as the morphed markers
are:

    M'_b,k(t) = M_b,k(t) + (X_a,j(t) - M_a,j(t))

(``X_a,j`` the first robot's key point of hand j in its solved motion, ``M`` the morphed
markers), so ``X_b,k - X_a,j -> M_b,k - M_a,j``, the morphed relation, whose length is the
source's scaled by the arrangement (the mesh's Laplacian keeps it). The first robot's holding
hand keeps its own morphed marker ``M_a,j`` (so its error, which the second inherits, is
small). Both targets are weighted by ``weight^2`` on the diagonal of that frame's key-point
metric ``W + w_L L^T L`` (:attr:`imesh.solve.plan.Plan.mesh_metric`), as a foot's target is
(weight 10).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..core.motion import MarkerMotion

#: The hand markers of the standard set whose closeness to the partner's is a hold.
HAND_MARKERS = ("hand_l", "hand_r")
#: The markers of a hand whose closeness to any marker of the partner is a touch (a contact
#: whose capsules are not avoided: joined hands and wrists, a hand on the partner's back).
TOUCHING_MARKERS = ("hand_l", "wrist_l", "hand_r", "wrist_r")


@dataclass(frozen=True, eq=False)
class Holds:
    """Frames where the people hold hands (source distance below the threshold).

    Attributes:
        frames: (N,) int clip frames (of the working markers) of each held pair.
        marker_a, marker_b: (N,) the hand marker of person a and of person b.
        source_distance_m: (N,) [m] their distance in the source.
        distance_m: the threshold [m].
        touch: (T, M_a, M_b) bool clip frames where marker i of a and marker j of b (the
            people's marker order) are closer than the threshold and one of them is a hand or
            wrist (TOUCHING_MARKERS): the contacts of the dance (joined hands, a hand on the
            partner's back).
        names_a, names_b: the marker names of ``touch``'s axes.
    """

    frames: np.ndarray
    marker_a: tuple[str, ...]
    marker_b: tuple[str, ...]
    source_distance_m: np.ndarray
    distance_m: float
    touch: np.ndarray
    names_a: tuple[str, ...]
    names_b: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.frames)

    def summary(self) -> dict:
        """Held frames per hand pair (clip frames)."""
        out: dict[str, list[int]] = {}
        for t, a, b in zip(self.frames, self.marker_a, self.marker_b, strict=True):
            out.setdefault(f"{a}-{b}", []).append(int(t))
        return out


def detect_holds(human_a: MarkerMotion, human_b: MarkerMotion, distance_m: float = 0.10
                 ) -> Holds:
    """Every (frame, hand of a, hand of b) closer than ``distance_m`` [m] in the source
    (both motions standard markers, one world, same frames); where both hands of a are that
    close to one hand of b, the nearer one."""
    frames, ma, mb, dist = [], [], [], []
    touch = np.linalg.norm(human_a.positions_m[:, :, None] - human_b.positions_m[:, None],
                           axis=-1) < distance_m
    touch &= (np.isin(human_a.names, TOUCHING_MARKERS)[:, None]
              | np.isin(human_b.names, TOUCHING_MARKERS)[None, :])[None]
    for ha in HAND_MARKERS:
        for hb in HAND_MARKERS:
            d = np.linalg.norm(human_a.positions_m[:, human_a.index(ha)]
                               - human_b.positions_m[:, human_b.index(hb)], axis=1)
            t = np.flatnonzero(d < distance_m)
            frames.append(t)
            ma += [ha] * len(t)
            mb += [hb] * len(t)
            dist.append(d[t])
    t, d = np.concatenate(frames).astype(int), np.concatenate(dist)
    # one hold per hand of b and frame: the nearest hand of a (b's hand gets one target)
    order = np.lexsort((d, np.array([HAND_MARKERS.index(m) for m in mb]), t))
    seen: set = set()
    kept: list[int] = []
    for i in order:
        if (t[i], mb[i]) not in seen:
            seen.add((t[i], mb[i]))
            kept.append(int(i))
    keep = np.array(sorted(kept, key=lambda i: (t[i], mb[i])), dtype=int)
    return Holds(frames=t[keep], marker_a=tuple(ma[i] for i in keep),
                 marker_b=tuple(mb[i] for i in keep), source_distance_m=d[keep],
                 distance_m=distance_m, touch=touch, names_a=human_a.names,
                 names_b=human_b.names)


def hold_targets(plan, names: tuple[str, ...], kp_markers: np.ndarray, frames: np.ndarray,
                 markers: tuple[str, ...], shifts_m: np.ndarray | None, weight: float):
    """A plan with the holding hands' targets moved and weighted (see the module docstring).

    Args:
        plan: a robot's :class:`imesh.solve.plan.Plan` (output frames).
        names: the plan's target marker names; kp_markers: (K,) the key points' indices into
            them (:class:`imesh.fit.targets.CompiledTargets`).
        frames: (N,) output frames of the holds; markers: (N,) the robot's holding hand in
            each.
        shifts_m: (N, 3) [m] added to each hand's target (the partner robot's hand minus the
            partner's morphed marker), or None (the first robot: its own morphed markers).
        weight: the targets' weight.

    Returns:
        The plan with the held frames' hand targets moved and weighted.
    """
    kp_names = [names[i] for i in kp_markers]
    points = plan.marker_points.copy()
    metric = plan.mesh_metric.copy()
    for n, (t, m) in enumerate(zip(frames, markers, strict=True)):
        k = kp_names.index(m)
        if shifts_m is not None:
            points[t, k] += shifts_m[n]
        metric[t, k, k] += weight ** 2
    return dataclasses.replace(plan, marker_points=points, mesh_metric=metric)


def near_capsules(robot, marker: str, reach_m: float = 0.12) -> np.ndarray:
    """Indices of the robot's capsules (:meth:`imesh.robot.Robot.capsule_model`) around key
    point ``marker``: those whose segment passes within ``reach_m`` [m] of the key point in the
    nominal pose (a G1 hand: the wrist roll, pitch and yaw links; JVRC-1's: the wrist and the
    forearm's end; the chest: the torso). Empty for a marker the robot has no key point for."""
    if marker not in robot.markers.keypoints:
        return np.zeros(0, dtype=int)
    model = robot.capsule_model()
    kp = robot.markers.keypoints[marker]
    point = robot.frame_positions(robot.q_nominal, [robot.frame_id(kp.frame)],
                                  np.asarray([kp.offset], dtype=float))[0]
    M = robot.frame_placements(robot.q_nominal, model.frames)[None]
    seg = model.world_segments(M)[0]
    ab = seg[:, 1] - seg[:, 0]
    s = np.clip(np.sum((point - seg[:, 0]) * ab, axis=1) / np.maximum(np.sum(ab * ab, axis=1),
                                                                      1e-12), 0.0, 1.0)
    dist = np.linalg.norm(seg[:, 0] + s[:, None] * ab - point, axis=1)
    return np.flatnonzero(dist <= reach_m)


def held_pairs(robot_a, robot_b, holds: Holds, n_frames: int, lead_frames: int,
               release_frames: int) -> np.ndarray:
    """(T, C_b, O_a) bool the (capsule of robot b, capsule of robot a) samples of the
    source's touches (:attr:`Holds.touch`: a hand or wrist within the hold distance of a
    marker of the partner; the capsules around each marker, :func:`near_capsules`), from
    ``release_frames`` before a touch to as many after it (the hands approach and part: at the
    10 cm threshold two G1 hands' capsules, radii 39 mm, already touch): a contact meant to
    be, neither avoided in the solve nor counted as penetration."""
    C_b, O_a = len(robot_b.capsule_model().capsules), len(robot_a.capsule_model().capsules)
    out = np.zeros((n_frames, C_b, O_a), dtype=bool)
    caps_a = [near_capsules(robot_a, m) for m in holds.names_a]
    caps_b = [near_capsules(robot_b, m) for m in holds.names_b]
    for t, i, j in zip(*np.nonzero(holds.touch), strict=True):
        t = t + lead_frames
        lo, hi = max(t - release_frames, 0), min(t + release_frames + 1, n_frames)
        out[lo:hi, caps_b[j][:, None], caps_a[i][None, :]] = True
    return out
