"""Standing lead-in and lead-out: settled double support before and after the clip.

A controller has to start from rest and stop at rest, but mocap clips start and end in motion
(the CMU walk starts in single support with the CoM outside the stance sole). The whole-body
solve therefore gets ``n_in`` frames before the clip and ``n_out`` after it in which both feet
are in support: a foot in support at the clip's first (last) frame keeps that phase's footprint,
a foot in the air is put down under where it is (level, same heading) and swings over the
lead's last (first) ``step_frames`` into (out of) the clip. The initializer and the marker
targets hold the first (last) frame, except on a foot put down (:class:`LeadFeet`): its markers
stand with the foot and follow its swing, a smooth rigid motion from the footprint to where the
clip has the foot, and in the initializer its leg stands on the footprint (its joints alone,
:func:`put_down`) and blends into the clip's over the swing. The jump from rest into the
clip's velocity is covered by the elastic acceleration rows of the solve, which then moves the
CoM over the support and the swing foot into its first step with the ZMP inside the support
polygon.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from ..contacts.phases import SIDES
from .footprints import level_placement
from .operators import log3

#: Least height [m] of the swinging sole's corners above the ground in the middle of a lead
#: swing (a sin(pi u) profile, u the swing's progress): the straight motion from the footprint
#: to the clip's foot pose would pass through the floor where the clip has the toe pitched down.
LEAD_SWING_CLEARANCE_M = 0.02
#: Key points on a leg's chain within this distance [m] of its sole centre are carried with the
#: foot in the lead's swings (the ankle's; the knee is 0.3-0.4 m away on the shipped robots).
LEAD_FOOT_RADIUS_M = 0.15


@dataclass(frozen=True, eq=False)
class Lead:
    """A clip extended by standing frames.

    Attributes:
        q: (n_in + T + n_out, nq) initializer.
        markers: (n_in + T + n_out, M, 3) marker targets [m].
        support: (n_in + T + n_out, 2) bool support, both feet in the added frames.
        n_in, n_out: added frames before and after the clip.
    """

    q: np.ndarray
    markers: np.ndarray
    support: np.ndarray
    n_in: int
    n_out: int


@dataclass(frozen=True, eq=False)
class LeadFeet:
    """The feet at the clip's ends and the markers they carry, for the lead's swings.

    Attributes:
        markers: per side (left, right) (k,) int indices of the markers on that foot: those
            whose key point or direction is on a link rigidly attached to the sole frame, and
            key points on the leg within ``LEAD_FOOT_RADIUS_M`` of the sole centre.
        first, last: (2, 4, 4) world poses of the sole frames at the clip's first and last
            frames [m].
        down_first, down_last: (2, 4, 4) the same soles laid level under them (where the lead
            stands them: :func:`imesh.solve.footprints.level_placement`), on z = 0 or on the
            prop's top under them.
        corners: (2, 4, 3) sole corners in the sole frames [m].
        legs: per side (left, right) (k,) int indices into ``q[7:]`` of the leg's joints.
        q_first, q_last: (2, nq) the clip's first and last configurations with that side's
            leg alone standing its sole on ``down_first`` / ``down_last``, or as near as it
            reaches from the clip's hips (:func:`put_down`); the clip's own where that
            footprint is on a prop's top.
    """

    markers: tuple[np.ndarray, np.ndarray]
    first: np.ndarray
    last: np.ndarray
    down_first: np.ndarray
    down_last: np.ndarray
    corners: np.ndarray
    legs: tuple[np.ndarray, np.ndarray]
    q_first: np.ndarray
    q_last: np.ndarray


def put_down(robot, q: np.ndarray, frame: str, target: np.ndarray, joints: np.ndarray,
             iterations: int = 60, damping: float = 0.01, max_step_rad: float = 0.2
             ) -> np.ndarray:
    """(nq,) ``q`` with the ``joints`` alone moved so that ``frame`` reaches ``target``.

    Damped least squares on the frame's error ``e = [p_T - p; log(R_T R^T)]`` (the sole rows'
    of the whole-body solve, :func:`imesh.solve.contacts.sole_errors`): ``dq = J^T (J J^T +
    damping^2 I)^-1 e`` over the columns of ``joints``, each step at most ``max_step_rad`` per
    joint, the joints clipped into their limits. A foot the clip has in the air at its first
    frame (a run's rear foot kicked up behind, pitched 109 degrees) then stands on its lead
    footprint in the initializer, where the SQP's trust region would need more iterations than
    it has to unfold the knee (the Bandai Namco run on G1: the sole still 370 mm off after 20).

    Args:
        robot: the robot.
        q: (nq,) configuration.
        frame: the sole frame.
        target: (4, 4) its world pose to reach.
        joints: (k,) indices into ``q[7:]`` of the joints to move (the leg's).
    """
    cols = 6 + np.asarray(joints, dtype=np.int64)
    q = np.array(q, dtype=float)
    for _ in range(iterations):
        M = robot.frame_placements(q, [frame])[0]
        e = np.concatenate([target[:3, 3] - M[:3, 3],
                            log3((target[:3, :3] @ M[:3, :3].T)[None])[0]])
        if np.linalg.norm(e) < 1e-6:
            break
        J = robot.frame_jacobians(q, [frame])[0][:, cols]
        dq = J.T @ np.linalg.solve(J @ J.T + damping ** 2 * np.eye(6), e)
        dq *= min(1.0, max_step_rad / max(np.abs(dq).max(), 1e-12))
        dv = np.zeros(robot.nv)
        dv[cols] = dq
        q = robot.clip(robot.integrate(q, dv))
    return q


def lead_feet(robot, q: np.ndarray, targets, heights_m: np.ndarray | None = None) -> LeadFeet:
    """The :class:`LeadFeet` of a clip.

    Args:
        robot: the robot.
        q: (T, nq) initializer of the clip (its first and last frames are used).
        targets: the compiled key points and directions (:func:`imesh.fit.compile_targets`).
        heights_m: (2, 2) [first, last] x [left, right] height of the surface a foot put down
            in the lead stands on [m] (a prop's top under it: the plan's lead footprint is
            there, :func:`imesh.pipeline.retarget.lead_heights`, and the foot's markers stand
            on it with the foot); None: the floor, z = 0.
    """
    frames = [robot.soles[s].frame for s in SIDES]
    level = robot.frame_rotations(robot.q_nominal, frames)
    first = robot.frame_placements(q[0], frames)
    last = robot.frame_placements(q[-1], frames)
    kps = targets.keypoints
    kp_at = robot.frame_positions(q[0], [k.frame for k in kps], targets.kp_offsets)
    markers = []
    for k, side in enumerate(SIDES):
        sole = robot.soles[side]
        foot = set(robot.rigid_links(sole.frame))
        chain = robot.supporting_joints(sole.frame).tolist()
        centre = first[k, :3, :3] @ sole.center + first[k, :3, 3]
        # key points on the foot, or on the leg next to it (G1's ankle marker is on the link
        # between its ankle's pitch and roll joints: it moves with the foot)
        on = {int(m) for kp, m, p in zip(kps, targets.kp_markers, kp_at, strict=True)
              if set(robot.rigid_links(kp.frame)) == foot
              or (chain[:len(js := robot.supporting_joints(kp.frame).tolist())] == js
                  and np.linalg.norm(p - centre) < LEAD_FOOT_RADIUS_M)}
        on |= {int(m) for d, a, b in zip(targets.directions, targets.dir_from, targets.dir_to,
                                         strict=True)
               if set(robot.rigid_links(d.frame)) == foot for m in (a, b)}
        markers.append(np.array(sorted(on), dtype=np.int64))
    down = np.array([[level_placement(robot.soles[s], level[k], ends[k:k + 1])
                      for k, s in enumerate(SIDES)] for ends in (first, last)])  # (2, 2, 4, 4)
    if heights_m is not None:
        down[..., 2, 3] += np.asarray(heights_m, dtype=float)
    legs = tuple(robot.supporting_joints(f) for f in frames)
    stood = np.zeros((2, 2, len(q[0])))
    for e, i in enumerate((0, -1)):
        for k in range(2):
            if heights_m is not None and heights_m[e][k] > 1e-3:
                # a foot put down on a prop's top keeps the clip's leg and its footprint under
                # it: moved within the leg's reach, the footprint leaves the top (the holosoma
                # seq_1 window's lead-out stands the left foot on box2's top 0.55 m below the
                # person's foot: 37 -> 158 mm into box1 with it moved and the leg stood)
                stood[e, k] = q[i]
                continue
            stood[e, k] = put_down(robot, q[i], frames[k], down[e, k], legs[k])
    return LeadFeet(markers=(markers[0], markers[1]), first=first, last=last,
                    down_first=down[0], down_last=down[1],
                    corners=np.array([robot.soles[s].corners() for s in SIDES]),
                    legs=(legs[0], legs[1]), q_first=stood[0], q_last=stood[1])


def _smoothstep(n: int) -> np.ndarray:
    """(n,) progress ``3 u^2 - 2 u^3`` of a move over ``n`` frames, both ends excluded."""
    u = np.arange(1, n + 1) / (n + 1)
    return u * u * (3.0 - 2.0 * u)


def _swing_poses(down: np.ndarray, up: np.ndarray, corners: np.ndarray, n: int) -> np.ndarray:
    """(n, 4, 4) sole poses of a swing from ``down`` (a level footprint) to ``up`` (the clip's
    pose), excluding both ends: the sole centre moves along a smoothstep, the orientation is
    slerped, and the pose is raised until its corners clear the ground by
    ``LEAD_SWING_CLEARANCE_M sin(pi u)``."""
    u = np.arange(1, n + 1) / (n + 1)
    s = _smoothstep(n)
    rot = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([down[:3, :3], up[:3, :3]])))(s)
    R = rot.as_matrix()
    centre = corners.mean(axis=0)
    c = (1 - s)[:, None] * (down[:3, :3] @ centre + down[:3, 3]) \
        + s[:, None] * (up[:3, :3] @ centre + up[:3, 3])
    low = np.min((R @ corners.T)[:, 2, :] - (R @ centre)[:, 2, None], axis=1) + c[:, 2]
    c[:, 2] += np.maximum(LEAD_SWING_CLEARANCE_M * np.sin(np.pi * u) - low, 0.0)
    out = np.repeat(np.eye(4)[None], n, axis=0)
    out[:, :3, :3] = R
    out[:, :3, 3] = c - R @ centre
    return out


def _stand_leg(q: np.ndarray, joints: np.ndarray, stood: np.ndarray, frames: slice,
               swing: slice, reverse: bool) -> None:
    """The leg ``joints`` (indices into ``q[7:]``) of the lead's standing ``frames`` at the
    configuration ``stood``, blended along a smoothstep into the clip's over the ``swing``
    frames (which end at the clip, or start from it with ``reverse``) (in place)."""
    cols = 7 + np.asarray(joints, dtype=np.int64)
    q[frames, cols] = stood[cols]
    n = swing.stop - swing.start
    if n <= 0:
        return
    s = _smoothstep(n)
    if reverse:
        s = s[::-1]
    clip = q[swing.stop if not reverse else swing.start - 1, cols]
    q[swing, cols] = (1 - s)[:, None] * stood[cols] + s[:, None] * clip


def _carry(markers: np.ndarray, index: np.ndarray, frames: slice, poses: np.ndarray,
           at: np.ndarray) -> None:
    """Move the markers ``index`` of ``frames`` rigidly with the foot: from its pose ``at``
    (where they are) to ``poses`` (n, 4, 4) (in place)."""
    rel = np.linalg.inv(at)
    m = markers[frames][:, index]  # (n, k, 3)
    T = poses @ rel  # (n, 4, 4)
    markers[frames, index] = np.einsum("nij,nkj->nki", T[:, :3, :3], m) + T[:, None, :3, 3]


def add_lead(q: np.ndarray, markers: np.ndarray, support: np.ndarray, n_in: int,
             n_out: int, step_frames: int = 0, land_frames: int = 0,
             feet: LeadFeet | None = None) -> Lead:
    """Extend a clip by ``n_in`` standing frames before it and ``n_out`` after it.

    A foot in the air at the clip's first frame stands during the lead-in and swings over its
    last ``step_frames`` frames to where the clip has it (its targets are the first frame's);
    a foot in the air at the last frame swings over the lead-out's first ``step_frames``
    frames before it stands. Without this, the sole would have to leave the ground in one
    frame (the CMU wave starts with the right foot lifted and pitched 54 degrees).

    Args:
        q: (T, nq) initializer of the clip.
        markers: (T, M, 3) marker targets [m].
        support: (T, 2) bool planned support.
        n_in, n_out: frames to add (>= 0).
        step_frames: frames of those swings (at most half the lead).
        land_frames: a foot in the air at the clip's first frame that lands within this many
            frames (the end of a swing: the CMU walk starts 2 frames before a heel strike)
            stands through instead: its support runs from the lead-in into the clip's landing.
            Lifted in the lead-in, the robot would have to start walking from rest on its
            rear toe for the swing it does not take (0.5 s with the CoM 15 cm in front of the
            stance sole on the G1 walk). Alike for a foot that lifts within the clip's last
            ``land_frames`` frames.
        feet: where the feet are at the clip's ends and their markers: the markers of a foot
            that steps out of (into) the lead stand with it on its footprint and follow its
            swing (None: they hold the clip's first (last) frame throughout, and the solve
            lifts the sole in the frame the support ends: G1's sole rose 99 mm and pitched
            32 deg in one frame into the CMU veer); the initializer's leg of such a foot
            stands on its footprint (``feet.q_first`` / ``q_last``) and blends into the clip's
            over the swing (None: it holds the clip's first (last) frame).
    """
    def pad(a: np.ndarray) -> np.ndarray:
        return np.concatenate([np.repeat(a[:1], n_in, axis=0), a,
                               np.repeat(a[-1:], n_out, axis=0)])

    sup = pad(np.asarray(support, dtype=bool))
    sup[:n_in] = True
    sup[len(sup) - n_out:] = True
    marks = pad(np.asarray(markers, dtype=np.float64))
    q_out = pad(np.asarray(q, dtype=np.float64))
    T = len(support)
    for k in range(sup.shape[1]):
        down = np.flatnonzero(support[:, k])
        if n_in and not support[0, k]:
            if len(down) and down[0] <= land_frames:
                sup[n_in:n_in + down[0], k] = True
            else:
                n = min(step_frames, n_in // 2)
                sup[n_in - n:n_in, k] = False
                if feet is not None and len(feet.markers[k]):
                    at = feet.first[k]
                    _carry(marks, feet.markers[k], slice(0, n_in - n),
                           np.repeat(feet.down_first[k][None], n_in - n, axis=0), at)
                    _carry(marks, feet.markers[k], slice(n_in - n, n_in),
                           _swing_poses(feet.down_first[k], at, feet.corners[k], n), at)
                if feet is not None:
                    _stand_leg(q_out, feet.legs[k], feet.q_first[k], slice(0, n_in - n),
                               slice(n_in - n, n_in), reverse=False)
        if n_out and not support[-1, k]:
            if len(down) and T - 1 - down[-1] <= land_frames:
                sup[n_in + down[-1]:n_in + T, k] = True
            else:
                n = min(step_frames, n_out // 2)
                sup[n_in + T:n_in + T + n, k] = False
                if feet is not None and len(feet.markers[k]):
                    at = feet.last[k]
                    _carry(marks, feet.markers[k], slice(n_in + T, n_in + T + n),
                           _swing_poses(feet.down_last[k], at, feet.corners[k], n)[::-1], at)
                    _carry(marks, feet.markers[k], slice(n_in + T + n, n_in + T + n_out),
                           np.repeat(feet.down_last[k][None], n_out - n, axis=0), at)
                if feet is not None:
                    _stand_leg(q_out, feet.legs[k], feet.q_last[k],
                               slice(n_in + T + n, n_in + T + n_out),
                               slice(n_in + T, n_in + T + n), reverse=True)
    return Lead(q=q_out, markers=marks, support=sup, n_in=n_in, n_out=n_out)
