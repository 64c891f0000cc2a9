"""Footprints: one flat sole placement on the ground per support phase.

For support phase s of foot f the sole keeps one pose F_s for the whole phase (DESIGN.md,
"Whole-body spacetime solve"): the sole centre on z = 0, the sole level (its normal along world
z), and x, y, yaw from the initial trajectory: the median sole centre and the circular mean of
the yaw over the middle half of the phase (the ends of a phase carry the heel strike and toe-off
of the fit).

A sliding (or pivoting) foot keeps its sole flat on the ground but moves along it: every frame
of a slide is its own one-frame footprint, level on z = 0 at the initial trajectory's sole
centre and yaw of that frame (the fit follows the human's slide), so the sole rows, the support
polygon (the ZMP inside the sliding sole) and the desired ZMP move with it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contacts.phases import SIDES, runs
from ..contacts.support import middle_half
from ..metrics.polygon import convex_hull_2d
from ..metrics.soles import SoleTracks


@dataclass(frozen=True, eq=False)
class Footprint:
    """The ground placement of one sole over one support phase.

    Attributes:
        side: ``"left"`` or ``"right"``.
        start, stop: the frames [start, stop) of the phase.
        frame_pose: (4, 4) float world pose the sole *frame* keeps (so the sole rectangle lies
            on z = 0, level).
        center_m: (3,) float [m] world sole centre (z = 0).
        corners_m: (4, 3) float [m] world sole corners (z = 0).
        polygon_m: (4, 3) float [m] world corners of the part of the sole the ZMP may use: the
            sole rectangle clipped to where the ankle can hold the largest planned load (see
            :func:`ankle_reach`).
        sliding: the sole slides (or pivots) through this one-frame placement.
    """

    side: str
    start: int
    stop: int
    frame_pose: np.ndarray
    center_m: np.ndarray
    corners_m: np.ndarray
    polygon_m: np.ndarray
    sliding: bool = False


def _yaw(rot: np.ndarray) -> np.ndarray:
    """(N,) yaw [rad] of rotation matrices (N, 3, 3) (heading of their x axis)."""
    return np.arctan2(rot[:, 1, 0], rot[:, 0, 0])


def _rz(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def split_pivots(robot, sole_poses: dict[str, np.ndarray], support: np.ndarray, fps: float,
                 yaw_tol_rad: float = 0.15, move_tol_m: float = 0.04, gap_s: float = 0.3
                 ) -> np.ndarray:
    """Turn a support foot that pivots or slides into steps.

    A human foot turns on its heel or slides while it carries weight; a robot sole that must
    keep one footprint cannot. Where the initial trajectory's sole leaves the start of its
    support run by more than ``yaw_tol_rad`` of yaw or ``move_tol_m``, the run is cut there and
    the foot gets a swing of ``gap_s`` to re-place itself, provided the other foot supports
    during the whole gap (otherwise the run is kept: one footprint, the mean).

    Args:
        robot: the robot (``soles``, ``q_nominal``).
        sole_poses: side -> (T, 4, 4) sole frame poses along the initial trajectory.
        support: (T, 2) bool planned support.
        fps: frame rate [1/s].

    Returns:
        (T, 2) bool support with the re-steps cut out.
    """
    out = np.array(support, dtype=bool)
    gap = max(2, int(round(gap_s * fps)))
    level = robot.frame_rotations(robot.q_nominal, [robot.soles[s].frame for s in SIDES])
    for k, side in enumerate(SIDES):
        poses = sole_poses[side]
        centre = poses[:, :3, :3] @ robot.soles[side].center + poses[:, :3, 3]
        yaw = np.unwrap(_yaw(poses[:, :3, :3] @ level[k].T))
        for start, stop in runs(support[:, k]):
            a = start
            t = start + 1
            while t < stop:
                moved = np.linalg.norm(centre[t, :2] - centre[a, :2])
                if abs(yaw[t] - yaw[a]) > yaw_tol_rad or moved > move_tol_m:
                    lo, hi = max(t - gap // 2, a + 1), min(t + gap - gap // 2, stop - 1)
                    if hi - lo >= 2 and out[lo:hi, 1 - k].all():
                        out[lo:hi, k] = False
                        a, t = hi, hi + 1
                        continue
                t += 1
    return out


def ankle_reach(robot, side: str, load: float = 1.0) -> float:
    """[m] how far from the ankle (the sole frame's origin) the centre of pressure may go with
    ``load`` times the whole weight on one foot: the weaker of the two ankle joints' effort
    limit over ``load m g``. G1's 35 Nm ankles hold its 33 kg 0.107 m from the ankle (0.082 m
    at the solve's largest normal force, 1.3 m g); its sole reaches 0.12 m ahead, so a ZMP at
    the toe asks 1.1-1.6x the ankle's limit (measured on the G1 walk before this bound)."""
    joints = robot.supporting_joints(robot.soles[side].frame)[-2:]
    return float(np.min(robot.effort_max[joints]) / (load * robot.mass * 9.81))


def plan_footprints(robot, sole_poses: dict[str, np.ndarray], support: np.ndarray,
                    load: float = 1.0, margin: float = 0.0,
                    sliding: np.ndarray | None = None) -> list[Footprint]:
    """One level footprint on z = 0 per support phase of each foot, and one per frame of a
    slide.

    Args:
        robot: the robot (``soles``, ``q_nominal`` give the level sole orientation).
        sole_poses: side -> (T, 4, 4) float world poses of the sole frames along the initial
            trajectory.
        support: (T, 2) bool [left, right] planned support.
        load: the largest normal force on one foot, times the weight (the polygon is clipped
            to :func:`ankle_reach` at this load).
        margin: fraction of the sole's half sizes kept free of the ZMP (the polygon is the
            sole rectangle shrunk about its centre by it, then clipped to the ankle's reach).
        sliding: (T, 2) bool support frames in which the sole slides or pivots (None: none).

    Returns:
        Footprints of both feet, in order of side then time.
    """
    out = []
    level = robot.frame_rotations(robot.q_nominal,
                                  [robot.soles[s].frame for s in SIDES])  # soles level there
    support = np.asarray(support, dtype=bool)
    sliding = np.zeros_like(support) if sliding is None else np.asarray(sliding, bool) & support
    for k, side in enumerate(SIDES):
        sole = robot.soles[side]
        rot_level = level[k]
        poses = sole_poses[side]
        reach = ankle_reach(robot, side, load)
        # in the sole frame (the ankle is its origin): the rectangle shrunk about its centre
        local = sole.center + (1.0 - margin) * (sole.corners() - sole.center)
        local[:, :2] = np.clip(local[:, :2], -reach, reach)
        # a planted phase: its middle half's placement; a slide: every frame's own
        spans: list[tuple[int, int, int, int, bool]] = [
            (start, stop, *middle_half(start, stop), False)
            for start, stop in runs(support[:, k] & ~sliding[:, k])]
        spans += [(int(t), int(t) + 1, int(t), int(t) + 1, True)
                  for t in np.flatnonzero(sliding[:, k])]
        for start, stop, a, b, slide in sorted(spans):
            sel = poses[a:b]
            centers = sel[:, :3, :3] @ sole.center + sel[:, :3, 3]
            # yaw of the sole relative to its level orientation in the nominal pose
            yaw = _yaw(sel[:, :3, :3] @ rot_level.T)
            psi = float(np.arctan2(np.sin(yaw).mean(), np.cos(yaw).mean()))
            R = _rz(psi) @ rot_level
            c = np.array([*np.median(centers[:, :2], axis=0), 0.0])
            pose = np.eye(4)
            pose[:3, :3] = R
            pose[:3, 3] = c - R @ sole.center
            corners = sole.corners() @ R.T + pose[:3, 3]
            out.append(Footprint(side=side, start=int(start), stop=int(stop), frame_pose=pose,
                                 center_m=c, corners_m=corners,
                                 polygon_m=local @ R.T + pose[:3, 3], sliding=slide))
    return out


def footprint_tracks(footprints: list[Footprint], n_frames: int, fps: float) -> SoleTracks:
    """Sole tracks of the planned support: the footprints' corners and centres in their phases,
    NaN elsewhere (for :func:`imesh.metrics.zmp.desired_zmp` and the polygons)."""
    corners = {s: np.full((n_frames, 4, 3), np.nan) for s in SIDES}
    centers = {s: np.full((n_frames, 3), np.nan) for s in SIDES}
    for f in footprints:
        corners[f.side][f.start:f.stop] = f.corners_m
        centers[f.side][f.start:f.stop] = f.center_m
    return SoleTracks(corners=corners, centers=centers, fps=fps)


def support_halfplanes(footprints: list[Footprint], support: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The support polygon of every supported frame as half-planes ``n . p >= b``: the convex
    hull of the supporting footprints' usable parts (``Footprint.polygon_m``).

    Args:
        footprints: the planned footprints.
        support: (T, 2) bool planned support.

    Returns:
        (frame (R,) int, normal (R, 2) unit inward normals, offset (R,) [m]) over all edges of
        all supported frames' convex hulls.
    """
    T = len(support)
    phase_of = {s: np.full(T, -1) for s in SIDES}
    for i, f in enumerate(footprints):
        phase_of[f.side][f.start:f.stop] = i
    frames, normals, offsets = [], [], []
    cache: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
    for t in np.flatnonzero(support.any(axis=1)):
        key = (int(phase_of["left"][t]), int(phase_of["right"][t]))
        if key not in cache:  # the polygon only changes with the phases: one hull per pair
            pts = np.concatenate([footprints[i].polygon_m[:, :2] for i in key if i >= 0])
            hull = convex_hull_2d(pts)  # counter-clockwise
            edge = np.roll(hull, -1, axis=0) - hull
            n = np.stack([-edge[:, 1], edge[:, 0]], axis=1)  # inward for counter-clockwise
            n /= np.linalg.norm(n, axis=1, keepdims=True)
            cache[key] = (n, np.sum(n * hull, axis=1))
        n, b = cache[key]
        frames.append(np.full(len(n), t))
        normals.append(n)
        offsets.append(b)
    if not frames:
        return np.zeros(0, dtype=int), np.zeros((0, 2)), np.zeros(0)
    return np.concatenate(frames), np.concatenate(normals), np.concatenate(offsets)
