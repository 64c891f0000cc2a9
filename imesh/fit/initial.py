"""Starting configurations guessed from the marker geometry: frame 0's start (the damped
least-squares iteration of frame 0 starts here unless ``q_init`` is given), and every frame's
fresh start for the restarts of the frame loop (:mod:`imesh.fit.track`)."""

from __future__ import annotations

import numpy as np

from ..core.motion import MarkerMotion
from .kinematics import Kinematics
from .targets import CompiledTargets


def _yaw_matrix(yaw: float) -> np.ndarray:
    """(3, 3) rotation about the vertical z axis by ``yaw`` [rad]."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def frame_guesses(robot, kin: Kinematics, targets: CompiledTargets, positions_m: np.ndarray,
                  valid: np.ndarray, q_nominal: np.ndarray) -> np.ndarray:
    """Per frame, a configuration from that frame's marker geometry alone: nominal joints and an
    upright base.

    Base yaw ``psi``: from the left-right direction ``hip_l - hip_r`` when both are valid
    key-point markers, ``psi = atan2(h_y, h_x) - atan2(r_y, r_x)`` with ``r`` the same robot key
    points in the nominal pose; else the yaw that best aligns the centred horizontal key-point
    layouts ``a`` (nominal) and ``b`` (markers), ``psi = atan2(sum a x b, sum a . b)`` (2-D
    Procrustes). Base position: the ``pelvis`` key point (or one on the robot's waist frame,
    else the key-point centroid) placed on its marker, ``x = m_anchor - R_z(psi) p0_anchor``.

    Args:
        robot: the robot.
        kin: its kinematics for the targets.
        targets: compiled key points.
        positions_m: (T, K, 3) the key points' markers [m].
        valid: (T, K) which are valid.
        q_nominal: (nq,) nominal configuration (its joints are used).

    Returns:
        (T, nq) configurations; NaN rows where a frame's markers define no yaw (fewer than two
        valid key points, none of them the hip pair).
    """
    q = np.array(q_nominal, dtype=np.float64)
    q[:3] = 0.0
    q[3:7] = (0.0, 0.0, 0.0, 1.0)
    p0, _ = kin.points_and_axes(q)  # nominal key points with the base at the origin
    m = np.asarray(positions_m, dtype=np.float64)
    ok = np.asarray(valid, dtype=bool) & np.isfinite(m).all(axis=2)
    n_frames = len(m)
    names = [k.marker for k in targets.keypoints]
    yaw = np.full(n_frames, np.nan)
    if "hip_l" in names and "hip_r" in names:
        il, ir = names.index("hip_l"), names.index("hip_r")
        h = m[:, il] - m[:, ir]
        r = p0[il] - p0[ir]
        use = ok[:, il] & ok[:, ir] & (np.hypot(h[:, 0], h[:, 1]) > 1e-3)
        if np.hypot(r[0], r[1]) > 1e-3:
            yaw = np.where(use, np.arctan2(h[:, 1], h[:, 0]) - np.arctan2(r[1], r[0]), np.nan)
    # 2-D Procrustes where the hips give none
    w = ok.astype(np.float64)
    count = w.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        a_mean = (w @ p0[:, :2]) / count[:, None]  # (T, 2)
        b_mean = np.einsum("tk,tkd->td", w, np.nan_to_num(m[..., :2])) / count[:, None]
    a = p0[None, :, :2] - a_mean[:, None]
    b = np.nan_to_num(m[..., :2]) - b_mean[:, None]
    cross = np.sum(w * (a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]), axis=1)
    dot = np.sum(w * np.sum(a * b, axis=2), axis=1)
    procrustes = (count >= 2) & (np.hypot(cross, dot) > 1e-6)
    yaw = np.where(np.isnan(yaw) & procrustes, np.arctan2(cross, dot), yaw)
    # base position: the anchor key point on its marker
    anchor = np.full(n_frames, -1, dtype=np.int64)
    waist = getattr(robot, "waist_frame", None)
    waist_id = robot.frame_id(waist) if waist else -1
    candidates = ([names.index("pelvis")] if "pelvis" in names else []) + [
        k for k, f in enumerate(targets.kp_frame_ids) if f == waist_id]
    for k in reversed(candidates):  # the first valid candidate wins
        anchor = np.where(ok[:, k], k, anchor)
    c, s = np.cos(np.nan_to_num(yaw)), np.sin(np.nan_to_num(yaw))
    rows = np.arange(n_frames)
    with np.errstate(invalid="ignore", divide="ignore"):
        ref_p = np.where((anchor >= 0)[:, None], p0[np.maximum(anchor, 0)],
                         (w @ p0) / count[:, None])
        ref_m = np.where((anchor >= 0)[:, None], m[rows, np.maximum(anchor, 0)],
                         np.einsum("tk,tkd->td", w, np.nan_to_num(m)) / count[:, None])
    rotated = np.stack([c * ref_p[:, 0] - s * ref_p[:, 1], s * ref_p[:, 0] + c * ref_p[:, 1],
                        ref_p[:, 2]], axis=1)
    out = np.repeat(q[None], n_frames, axis=0)
    out[:, :3] = ref_m - rotated
    out[:, 3:7] = np.stack([np.zeros(n_frames), np.zeros(n_frames), np.sin(0.5 * yaw),
                            np.cos(0.5 * yaw)], axis=1)
    out[np.isnan(yaw) | (count == 0)] = np.nan
    return out


def initial_guess(robot, kin: Kinematics, targets: CompiledTargets, markers: MarkerMotion,
                  q_nominal: np.ndarray) -> np.ndarray:
    """First-frame configuration from the marker geometry: nominal joints, upright base.

    The first frame with a valid key-point marker is placed by :func:`frame_guesses`; where its
    markers define no yaw (fewer than two valid key points), the base faces the horizontal
    walking direction of the first second.

    Args:
        robot: the robot.
        kin: its kinematics for the targets.
        targets: compiled key points.
        markers: the motion; frame 0 (or the first frame where markers are valid) is used.
        q_nominal: (nq,) nominal configuration (its joints are used).

    Returns:
        (nq,) configuration.
    """
    pos = markers.positions_m[:, targets.kp_markers]  # (T, K, 3)
    valid = markers.valid[:, targets.kp_markers]
    frame = int(np.argmax(valid.any(axis=1)))
    guess = frame_guesses(robot, kin, targets, pos[frame:frame + 1], valid[frame:frame + 1],
                          q_nominal)[0]
    if np.isfinite(guess).all():
        return guess
    q = np.array(q_nominal, dtype=np.float64)
    q[:3] = 0.0
    q[3:7] = (0.0, 0.0, 0.0, 1.0)
    p0, _ = kin.points_and_axes(q)
    m, ok = pos[frame], valid[frame]
    centre = np.nanmean(np.where(valid[..., None], pos, np.nan), axis=1)
    stop = min(markers.n_frames - 1, frame + int(round(markers.fps)))
    travel = centre[stop] - centre[frame]
    yaw = float(np.arctan2(travel[1], travel[0])) if np.all(np.isfinite(travel[:2])) and \
        np.hypot(travel[0], travel[1]) > 0.05 else 0.0
    rot = _yaw_matrix(yaw)
    if ok.any():
        q[:3] = m[ok].mean(axis=0) - rot @ p0[ok].mean(axis=0)
    else:
        q[:3] = q_nominal[:3]
    q[3:7] = (0.0, 0.0, np.sin(0.5 * yaw), np.cos(0.5 * yaw))
    return q
