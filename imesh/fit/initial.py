"""The first frame's starting configuration, guessed from the marker geometry (the damped
least-squares iteration of frame 0 starts here unless ``q_init`` is given)."""

from __future__ import annotations

import numpy as np

from ..core.motion import MarkerMotion
from .kinematics import Kinematics
from .targets import CompiledTargets


def _yaw_matrix(yaw: float) -> np.ndarray:
    """(3, 3) rotation about the vertical z axis by ``yaw`` [rad]."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def initial_guess(robot, kin: Kinematics, targets: CompiledTargets, markers: MarkerMotion,
                  q_nominal: np.ndarray) -> np.ndarray:
    """First-frame configuration from the marker geometry: nominal joints, upright base.

    Base yaw: from the left-right direction ``hip_l - hip_r`` when both are key-point markers
    (matched against the same robot key points in the nominal pose); else the yaw that best
    aligns the horizontal key-point layout of the nominal pose with frame 0's markers
    (2-D Procrustes); else, with fewer than two usable key points, the horizontal walking
    direction of the first second. Base position: the ``pelvis`` key point (or one on the robot's
    waist frame, else the key-point centroid) placed on its marker.

    Args:
        robot: the robot.
        kin: its kinematics for the targets.
        targets: compiled key points.
        markers: the motion; frame 0 (or the first frame where markers are valid) is used.
        q_nominal: (nq,) nominal configuration (its joints are used).

    Returns:
        (nq,) configuration.
    """
    q = np.array(q_nominal, dtype=np.float64)
    q[:3] = 0.0
    q[3:7] = (0.0, 0.0, 0.0, 1.0)
    p0, _ = kin.points_and_axes(q)  # nominal key points with the base at the origin
    pos = markers.positions_m[:, targets.kp_markers]  # (T, K, 3)
    valid = markers.valid[:, targets.kp_markers]
    frame = int(np.argmax(valid.any(axis=1)))
    m = pos[frame]
    ok = valid[frame]
    names = [k.marker for k in targets.keypoints]
    yaw = None
    if "hip_l" in names and "hip_r" in names:
        il, ir = names.index("hip_l"), names.index("hip_r")
        if ok[il] and ok[ir]:
            h = m[il] - m[ir]
            r = p0[il] - p0[ir]
            if np.hypot(h[0], h[1]) > 1e-3 and np.hypot(r[0], r[1]) > 1e-3:
                yaw = np.arctan2(h[1], h[0]) - np.arctan2(r[1], r[0])
    if yaw is None and ok.sum() >= 2:
        a = p0[ok, :2] - p0[ok, :2].mean(axis=0)
        b = m[ok, :2] - m[ok, :2].mean(axis=0)
        cross = np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
        dot = np.sum(a * b)
        if np.hypot(cross, dot) > 1e-6:
            yaw = np.arctan2(cross, dot)
    if yaw is None:
        centre = np.nanmean(np.where(valid[..., None], pos, np.nan), axis=1)
        stop = min(markers.n_frames - 1, frame + int(round(markers.fps)))
        travel = centre[stop] - centre[frame]
        yaw = float(np.arctan2(travel[1], travel[0])) if np.all(np.isfinite(travel[:2])) and \
            np.hypot(travel[0], travel[1]) > 0.05 else 0.0
    rot = _yaw_matrix(float(yaw))
    anchor = None
    if "pelvis" in names and ok[names.index("pelvis")]:
        anchor = names.index("pelvis")
    else:
        waist = getattr(robot, "waist_frame", None)
        waist_id = robot.frame_id(waist) if waist else -1
        on_waist = [k for k, f in enumerate(targets.kp_frame_ids) if f == waist_id and ok[k]]
        anchor = on_waist[0] if on_waist else None
    if anchor is not None:
        q[:3] = m[anchor] - rot @ p0[anchor]
    elif ok.any():
        q[:3] = m[ok].mean(axis=0) - rot @ p0[ok].mean(axis=0)
    else:
        q[:3] = q_nominal[:3]
    half = 0.5 * float(yaw)
    q[3:7] = (0.0, 0.0, np.sin(half), np.cos(half))
    return q
