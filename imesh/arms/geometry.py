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

from ..robot.config import SIDES
from ..robot.errors import closest_first
from ..robot.hands import SUFFIX, suggest_hand_points
from .errors import ArmsError

if TYPE_CHECKING:  # pragma: no cover - typing only
    from ..robot import Robot

log = logging.getLogger(__name__)

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
