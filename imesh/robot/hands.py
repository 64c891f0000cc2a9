"""The three hand points of a robot's hands (Kim, Kim & Oh 2005, eq. 3: wrist, hand = knuckles
and a third "thumb" point, fixed on the hand link), derived from markers.toml keypoints at the
nominal pose. The arm imitation (:mod:`imesh.arms`) reads them from ``[arms.<side>]`` of
markers.toml; ``imesh robots init`` writes those tables with :func:`suggest_hand_points`.
"""

from __future__ import annotations

import numpy as np

from .errors import RobotConfigError

#: Suffix of the standard marker names per side.
SUFFIX = {"left": "l", "right": "r"}


def _keypoint(robot, marker: str):
    kp = robot.markers.keypoints if robot.markers is not None else {}
    if marker not in kp:
        valid = ", ".join(kp) or "(no markers.toml)"
        raise RobotConfigError(f"robot {robot.name!r}: hand points need the markers.toml "
                               f"keypoint {marker!r}; valid keypoints: {valid}")
    return kp[marker]


def thumb_direction(upper_arm: np.ndarray, hand_axis: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Unit direction of the derived third hand point and how well it is defined.

    The direction is the component of the reversed upper arm (elbow -> shoulder) perpendicular to
    the hand axis (wrist -> hand): in the plane of the arm, across the hand, towards the side of
    the body the upper arm comes from. With the forearm in neutral rotation this is where the
    thumb points (thumb up with the elbow bent and the arm hanging; thumb medial in a wave).

    Args:
        upper_arm: (..., 3) elbow - shoulder.
        hand_axis: (..., 3) hand - wrist.

    Returns:
        (direction (..., 3) unit (zero where undefined), sine (...,) of the angle between the
        upper arm and the hand axis: 0 when they are parallel and the direction is undefined).
    """
    h = hand_axis / np.maximum(np.linalg.norm(hand_axis, axis=-1, keepdims=True), 1e-12)
    u = -np.asarray(upper_arm, dtype=float)
    perp = u - np.sum(u * h, axis=-1, keepdims=True) * h
    norm = np.linalg.norm(perp, axis=-1)
    sine = norm / np.maximum(np.linalg.norm(u, axis=-1), 1e-12)
    direction = np.where(norm[..., None] > 1e-12, perp / np.maximum(norm, 1e-12)[..., None], 0.0)
    return direction, sine


def suggest_hand_points(robot, side: str) -> tuple[str, np.ndarray]:
    """Hand link and the three hand points on it, from markers.toml keypoints at the nominal pose.

    Wrist and hand are the ``wrist_<s>`` and ``hand_<s>`` keypoints re-expressed on the hand link
    (the frame of ``hand_<s>``); the third point sits at the wrist-hand distance from the wrist
    along :func:`thumb_direction` of the robot's own arm (the nominal elbow must be bent). This
    is how the ``[arms]`` tables of the shipped robots were made.

    Returns:
        (hand frame name, (3, 3) float [m] wrist, hand, thumb offsets in that frame).
    """
    s = SUFFIX[side]
    frame = _keypoint(robot, f"hand_{s}").frame
    names = [f"{m}_{s}" for m in ("wrist", "hand", "elbow", "shoulder")]
    kps = [_keypoint(robot, n) for n in names]
    p = robot.frame_positions(robot.q_nominal, [k.frame for k in kps],
                              np.array([k.offset for k in kps]))
    wrist, hand, elbow, shoulder = p
    direction, sine = thumb_direction(elbow - shoulder, hand - wrist)
    if sine < 0.05:
        raise RobotConfigError(f"robot {robot.name!r}: the nominal {side} arm is straight "
                               "(upper arm parallel to the hand): bend its elbow in [nominal] "
                               f"or give [arms.{side}].thumb in markers.toml")
    thumb = wrist + np.linalg.norm(hand - wrist) * direction
    placement = robot.frame_placements(robot.q_nominal, [frame])[0]
    rot, origin = placement[:3, :3], placement[:3, 3]
    local = (np.stack([wrist, hand, thumb]) - origin) @ rot
    return frame, local
