"""The human side of the arm imitation: geometric scaling (Kim, Kim & Oh 2005, sec. 2) and the
per-frame targets of eqs 3-5 in the robot's world.

The paper scales the robot arm by ``rho = L_human / L_robot`` (upper plus lower arm, each arm
separately) and matches the scaled robot to the actor. Scaling the robot arm about its shoulder
by ``rho`` is the same as scaling the actor's arm about the actor's shoulder by ``1 / rho``: every
error of eqs 3 and 4 is multiplied by ``rho`` and the minimizer does not change. imesh does the
latter, so the targets, residuals and plots are in the robot's metres:

    wrist target  = robot shoulder + R (r_wrist^ac - r_sh^ac) / rho
    hand target   = wrist target + d_hand  * unit(R (r_hand^ac - r_wrist^ac))
    thumb target  = wrist target + d_thumb * thumb_direction(R (el - sh), R (hand - wrist))
    a_hat         = unit(R (r_el^ac - r_sh^ac))                               (eq. 5, direction)

``R`` maps the actor's torso frame onto the robot's (``ArmsConfig.frame = "torso"``) or is the
identity (``"world"``); ``d_hand``, ``d_thumb`` are the robot's own wrist-to-point distances, so the
three hand points carry the actor hand's orientation at the robot hand's size (a robot that can
reach the wrist target and turn its hand can meet all three exactly). The CMU rigs have no thumb
or pinky markers, so the third point is derived from the arm geometry (see docs/arms.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.motion import MarkerMotion
from ..robot.hands import SUFFIX, thumb_direction
from .config import ArmsConfig
from .errors import ArmsError
from .geometry import ArmModel

#: Markers the torso frame is built from (pelvis -> neck up, shoulder_r -> shoulder_l across).
TORSO_MARKERS = ("pelvis", "neck", "shoulder_l", "shoulder_r")


@dataclass(frozen=True, eq=False)
class ArmScaling:
    """Geometric scaling of one arm (sec. 2).

    Attributes:
        side: ``"left"``/``"right"``.
        human_length_m: actor's upper plus lower arm length (median over frames) [m].
        robot_length_m: robot's upper plus lower arm length (nominal pose) [m].
    """

    side: str
    human_length_m: float
    robot_length_m: float

    @property
    def rho(self) -> float:
        """``L_human / L_robot``."""
        return self.human_length_m / self.robot_length_m


@dataclass(frozen=True, eq=False)
class ArmTargets:
    """Per-frame targets of one arm in the robot's world.

    Attributes:
        scaling: the arm's geometric scaling.
        hand_m: (T, 3, 3) float [m] wrist, hand and thumb targets (``r^ac`` of eq. 3, scaled).
        weights: (T, 3) float W of eq. 3 per point (the thumb's faded where undefined).
        upper_arm_dir: (T, 3) float unit actor upper-arm direction (``r_el/sh^ac`` of eq. 5
            normalized, rotated into the robot's world).
        anchor_m: (T, 3) float [m] the robot shoulder the targets hang from.
    """

    scaling: ArmScaling
    hand_m: np.ndarray
    weights: np.ndarray
    upper_arm_dir: np.ndarray
    anchor_m: np.ndarray

    @property
    def n_frames(self) -> int:
        return self.hand_m.shape[0]


def _positions(markers: MarkerMotion, names: tuple[str, ...], why: str) -> np.ndarray:
    missing = [n for n in names if n not in markers.names]
    if missing:
        raise ArmsError(f"{markers.source or 'motion'}: {why} needs the standard marker(s) "
                        f"{', '.join(missing)}; the motion has {', '.join(markers.names)}")
    pos = markers.positions_m[:, [markers.names.index(n) for n in names]]
    bad = ~np.isfinite(pos).all(axis=2)
    if bad.any():
        t, m = np.argwhere(bad)[0]
        raise ArmsError(f"{markers.source or 'motion'}: marker {names[m]} is missing at frame "
                        f"{t} ({int(bad.any(axis=1).sum())} frames): fill the gaps first "
                        "(imesh.morph.adapt.prepare_markers)")
    return pos


def torso_rotations(pelvis: np.ndarray, neck: np.ndarray, shoulder_l: np.ndarray,
                    shoulder_r: np.ndarray) -> np.ndarray:
    """(T, 3, 3) torso frames (columns x forward, y left, z up) from (T, 3) points: z along
    pelvis -> neck, y along shoulder_r -> shoulder_l made perpendicular to z."""
    z = neck - pelvis
    z = z / np.linalg.norm(z, axis=-1, keepdims=True)
    y = shoulder_l - shoulder_r
    y = y - np.sum(y * z, axis=-1, keepdims=True) * z
    y = y / np.linalg.norm(y, axis=-1, keepdims=True)
    return np.stack([np.cross(y, z), y, z], axis=-1)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def human_arm_length(markers: MarkerMotion, side: str) -> float:
    """Actor's upper plus lower arm length [m], median over frames."""
    s = SUFFIX[side]
    sh, el, wr = np.moveaxis(_positions(markers, (f"shoulder_{s}", f"elbow_{s}", f"wrist_{s}"),
                                        "arm scaling"), 1, 0)
    return float(np.median(np.linalg.norm(el - sh, axis=1) + np.linalg.norm(wr - el, axis=1)))


def arm_targets(markers: MarkerMotion, arm: ArmModel, q_ref: np.ndarray,
                config: ArmsConfig) -> ArmTargets:
    """Targets of one arm for every frame.

    Args:
        markers: standard human markers (gaps filled), T frames.
        arm: the robot arm.
        q_ref: (T, nq) float the robot's reference configurations (base, torso: where the
            shoulder and the torso frame are taken from).
        config: ArmsConfig (point weights, thumb fade, frame).

    Returns:
        ArmTargets.

    Raises:
        ArmsError: a needed marker is absent or missing in some frame, or the robot lacks a
            torso keypoint.
    """
    s = SUFFIX[arm.side]
    names = (f"shoulder_{s}", f"elbow_{s}", f"wrist_{s}", f"hand_{s}")
    sh, el, wr, ha = np.moveaxis(_positions(markers, names, "the arm imitation"), 1, 0)
    robot = arm.robot
    T = markers.n_frames
    q_ref = np.asarray(q_ref, dtype=float)
    if q_ref.shape != (T, robot.nq):
        raise ArmsError(f"reference configurations must have shape ({T}, {robot.nq}), got "
                        f"{q_ref.shape}")
    scaling = ArmScaling(side=arm.side, human_length_m=human_arm_length(markers, arm.side),
                         robot_length_m=arm.length_m)
    unique, inverse = np.unique(q_ref, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    anchor = np.array([arm.points(q)[4] for q in unique])[inverse]
    if config.frame == "torso":
        human = torso_rotations(*np.moveaxis(_positions(markers, TORSO_MARKERS, "the torso frame"),
                                             1, 0))
        kps = robot.markers.keypoints if robot.markers is not None else {}
        lacking = [m for m in TORSO_MARKERS if m not in kps]
        if lacking:
            raise ArmsError(f"robot {robot.name!r}: the torso frame needs the markers.toml "
                            f"keypoints {', '.join(lacking)} (or use ArmsConfig(frame='world'))")
        frames = [kps[m].frame for m in TORSO_MARKERS]
        offsets = np.array([kps[m].offset for m in TORSO_MARKERS])
        pts = np.array([robot.frame_positions(q, frames, offsets) for q in unique])
        rob = torso_rotations(*np.moveaxis(pts, 1, 0))[inverse]
        rot = rob @ np.swapaxes(human, 1, 2)
    else:
        rot = np.broadcast_to(np.eye(3), (T, 3, 3))

    def put(v: np.ndarray) -> np.ndarray:
        return np.einsum("tij,tj->ti", rot, v)

    wrist = anchor + put(wr - sh) / scaling.rho
    axis = put(ha - wr)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    upper = put(el - sh)
    direction, sine = thumb_direction(upper, axis)
    hand_m = np.stack([wrist, wrist + arm.hand_length_m[1] * axis,
                       wrist + arm.hand_length_m[2] * direction], axis=1)
    fade = _smoothstep(sine / np.sin(np.radians(config.thumb_fade_deg)))
    weights = np.tile(np.asarray(config.point_weights, dtype=float), (T, 1))
    weights[:, 2] *= fade
    return ArmTargets(scaling=scaling, hand_m=hand_m, weights=weights,
                      upper_arm_dir=upper / np.linalg.norm(upper, axis=1, keepdims=True),
                      anchor_m=anchor)
