"""The robot side of the arm imitation: which joints form an arm, where its hand points are, and
the kinematics one frame's objective needs (Kim, Kim & Oh 2005, sec. 3.1).

Every arm has five robot points: the three hand points of eq. 3 (wrist, hand = knuckles, and a
third "thumb" point, all fixed on the hand link; ``[arms.<side>]`` of markers.toml, or derived
by :func:`suggest_hand_points`) and the shoulder and elbow of eq. 6 (the markers.toml keypoints
``shoulder_<s>`` and ``elbow_<s>``). All kinematics go through :class:`imesh.robot.Robot`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..robot.config import SIDES, closest_first
from .errors import ArmsError

if TYPE_CHECKING:  # pragma: no cover - typing only
    from ..robot import Robot

log = logging.getLogger(__name__)

#: Suffix of the standard marker names per side.
SUFFIX = {"left": "l", "right": "r"}
#: Row order of :meth:`ArmModel.points`: the hand points of eq. 3, then eq. 6's elbow, shoulder.
POINTS = ("wrist", "hand", "thumb", "elbow", "shoulder")
HAND_POINTS = POINTS[:3]


def _keypoint(robot, marker: str):
    kp = robot.markers.keypoints if robot.markers is not None else {}
    if marker not in kp:
        raise ArmsError(f"robot {robot.name!r}: the arm imitation needs the markers.toml keypoint "
                        f"{marker!r}; valid keypoints: {', '.join(kp) or '(no markers.toml)'}")
    return kp[marker]


def chain_joints(robot, frame: str) -> list[int]:
    """Indices (in ``q[7:]``) of the joints that move ``frame``, from the root outwards.

    Read from the Jacobian at the nominal pose: a joint moves the frame when its column of the
    frame's (linear or angular) Jacobian is non-zero.
    """
    q = robot.q_nominal
    fid = robot.frame_id(frame)
    lin = robot.point_jacobians(q, [fid])[0][:, 6:]
    ang = robot.frame_angular_jacobians(q, [fid])[0][:, 6:]
    moving = (np.abs(lin).max(axis=0) > 1e-12) | (np.abs(ang).max(axis=0) > 1e-12)
    return [int(j) for j in np.flatnonzero(moving)]


def derived_arm_joints(robot, side: str) -> tuple[str, ...]:
    """The arm joints of ``side``: the joints moving its hand frame but not the other hand's
    (the torso joints they share are not arm joints)."""
    other = "right" if side == "left" else "left"
    mine = chain_joints(robot, _keypoint(robot, f"hand_{SUFFIX[side]}").frame)
    theirs = set(chain_joints(robot, _keypoint(robot, f"hand_{SUFFIX[other]}").frame))
    return tuple(robot.joint_names[j] for j in mine if j not in theirs)


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
        raise ArmsError(f"robot {robot.name!r}: the nominal {side} arm is straight (upper arm "
                        "parallel to the hand): bend its elbow in [nominal] or give "
                        f"[arms.{side}].thumb in markers.toml")
    thumb = wrist + np.linalg.norm(hand - wrist) * direction
    placement = robot.frame_placements(robot.q_nominal, [frame])[0]
    rot, origin = placement[:3, :3], placement[:3, 3]
    local = (np.stack([wrist, hand, thumb]) - origin) @ rot
    return frame, local


@dataclass(frozen=True, eq=False)
class ArmModel:
    """One robot arm for the imitation.

    Attributes:
        robot: the :class:`imesh.robot.Robot`.
        side: ``"left"`` or ``"right"``.
        joints: the arm joint names from shoulder to hand (q_1..q_n of eq. 1).
        joint_index: (n,) int their indices in ``q[7:]``.
        frames: (5,) int frame ids of the points in :data:`POINTS` order.
        offsets_m: (5, 3) float [m] the points in their frames.
        length_m: upper plus lower arm length in the nominal pose [m] (L_robot of sec. 2).
        hand_length_m: (3,) float [m] distance of each hand point from the wrist point.
    """

    robot: Robot
    side: str
    joints: tuple[str, ...]
    joint_index: np.ndarray
    frames: np.ndarray
    offsets_m: np.ndarray
    length_m: float
    hand_length_m: np.ndarray

    @property
    def n(self) -> int:
        """Number of arm joints."""
        return len(self.joints)

    @property
    def v_columns(self) -> np.ndarray:
        """(n,) int columns of the arm joints in a velocity / Jacobian (``6 + joint_index``)."""
        return 6 + self.joint_index

    def points(self, q: np.ndarray | None) -> np.ndarray:
        """(5, 3) float [m] world positions of wrist, hand, thumb, elbow, shoulder at ``q`` (None:
        the robot's last configuration)."""
        return self.robot.frame_positions(q, self.frames, self.offsets_m)

    def points_and_jacobians(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points (5, 3) [m] and their Jacobians (5, 3, n) with respect to the arm joints."""
        jac = self.robot.point_jacobians(q, self.frames, self.offsets_m)[:, :, self.v_columns]
        return self.points(None), jac


def arm_model(robot, side: str) -> ArmModel:
    """The arm of ``side`` (``"left"``/``"right"``) from markers.toml (``[arms.<side>]`` when
    given, else :func:`suggest_hand_points` and :func:`derived_arm_joints`).

    Raises:
        ArmsError: unknown side, missing keypoints, an unknown or non-arm joint in
            ``[arms.<side>].joints``.
    """
    if side not in SIDES:
        raise ArmsError(f"unknown arm side {side!r}; valid: {', '.join(SIDES)}")
    s = SUFFIX[side]
    table = robot.markers.arms.get(side) if robot.markers is not None else None
    if table is not None:
        frame = table.frame
        hand_points = np.stack([table.wrist, table.hand, table.thumb])
        joints = table.joints or derived_arm_joints(robot, side)
    else:
        frame, hand_points = suggest_hand_points(robot, side)
        joints = derived_arm_joints(robot, side)
        log.info("robot %s: no [arms.%s] in markers.toml: hand points derived on %s", robot.name,
                 side, frame)
    moving = chain_joints(robot, frame)
    index = []
    for name in joints:
        j = robot.joint_names.index(name) if name in robot.joint_names else -1
        if j not in moving:
            what = "does not move" if j >= 0 else "is not an actuated joint and cannot move"
            valid = ", ".join(closest_first(name, [robot.joint_names[k] for k in moving]))
            raise ArmsError(f"robot {robot.name!r}: joint {name!r} of [arms.{side}].joints "
                            f"{what} the hand link {frame!r}; valid: {valid}")
        index.append(j)
    if not index:
        raise ArmsError(f"robot {robot.name!r}: the {side} arm has no joints (hand link {frame!r})")
    kps = [_keypoint(robot, f"{m}_{s}") for m in ("elbow", "shoulder")]
    frames = [robot.frame_id(frame)] * 3 + [robot.frame_id(k.frame) for k in kps]
    offsets = np.concatenate([hand_points, np.array([k.offset for k in kps])])
    arm = ArmModel(robot=robot, side=side, joints=tuple(joints),
                   joint_index=np.array(index, dtype=np.int64),
                   frames=np.array(frames, dtype=np.int64), offsets_m=offsets, length_m=0.0,
                   hand_length_m=np.zeros(3))
    p = arm.points(robot.q_nominal)
    length = float(np.linalg.norm(p[3] - p[4]) + np.linalg.norm(p[0] - p[3]))
    hand = np.linalg.norm(p[:3] - p[0], axis=1)
    return ArmModel(robot=robot, side=side, joints=arm.joints, joint_index=arm.joint_index,
                    frames=arm.frames, offsets_m=offsets, length_m=length, hand_length_m=hand)
