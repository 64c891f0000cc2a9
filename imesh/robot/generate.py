"""A robot configuration from its URDF alone: ``imesh robots init ROBOT.urdf -o DIR``.

Reads the kinematic tree and the geometry of a humanoid URDF and writes the ``robot.toml`` and
``markers.toml`` a person would write by hand (docs/robots.md), plus a report of what was chosen
and which facts the URDF lacks. The rules were set so that the configurations generated for
JVRC-1, G1 and HRP-4C match their hand-written ones (``benchmarks/generate.py``).

How the URDF is read, in the zero pose (every joint at 0, clipped to its limits), with the root
link's +z up (REP-103):

* **Limbs.** The joint tree is cut at every branching joint (one with two or more child joints)
  into chains. A *leg* is a chain that reaches the lowest quarter of the robot; a humanoid has
  exactly two. The *arms* are the two mirrored chains of one branching joint above the hips that
  are the furthest apart; the *head* is the chain of that joint (or an ancestor) that ends highest
  near the middle. Fingers and grippers are what hangs below the arms' ends: they are fixed.
* **Sides** come from the joint names (``left``/``l_``/``L_``/``LHip``...); when the names say
  nothing, from the sign of y (REP-103: y points left). Forward = left x up.
* **Joints of a limb.** A joint is a *twist* when its axis runs along the limb at that joint. The
  knee (elbow) is the non-twist joint nearest the middle of the limb's path; the
  joints before it are the hip (shoulder), the ones after it the ankle (wrist).
* **Key points** (the 20 standard human markers but the spine, markerset.py): a hip is the point
  of the first hip axis closest to the other hip axes (fixed on the pelvis); ankles and wrists
  are the least-squares meeting points of their joints' axes, a shoulder the point of the
  last shoulder axis closest to the other shoulder axes; knees and elbows their joint origins;
  toes on the ball of the foot 2 cm above the sole; hands along the hand link's axis, 48 % of the
  hand's length beyond the wrist; chest 7.2 % of a leg below the shoulders; pelvis 11 % of a leg
  above the hips; the neck (the human marker: the base of the neck) on the torso 6.5 % of a leg
  above the shoulders; the head (the human marker: the skull base) at the least-squares meeting
  point of the neck joints' axes, or, with the head fixed on the torso, at the centre of the
  head's geometry.
* **Sole**: the lowest face of the foot's collision geometry (visual when the collision geometry
  is only contact spheres), in a foot frame whose z axis is vertical (the foot link, or a frame on
  it such as ``l_sole``).
* **Nominal pose**: knees bent 0.5 rad with the feet flat, arms hanging 0.2 rad away from the
  body with the elbows bent 0.4 rad forward, found by a bounded least-squares IK on the limbs.
* **Limits**: position, velocity and effort from the URDF; what is missing gets a named default
  (``DEFAULTS``) and is listed in the report.
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

import numpy as np
from scipy.optimize import least_squares

from .config import SIDES
from .errors import RobotConfigError
from .urdf_tree import (
    Limb,
    NotHumanoidError,
    UrdfTree,
    find_limbs,
    meeting_point,
    point_on_line_nearest,
)

log = logging.getLogger(__name__)

#: Facts a URDF may lack, the value imesh uses instead, and where that value comes from.
DEFAULTS: dict[str, tuple[float, str]] = {
    "velocity": (5.0, "imesh default 5 rad/s, a typical electric humanoid joint speed"),
    "effort": (100.0, "imesh default 100 Nm, the placeholder the JVRC-1 and HRP-4C URDF "
                      "conversions use (not motor data)"),
    "position": (np.pi, "imesh default +-pi rad for a joint without position limits"),
    "acceleration": (100.0, "imesh default 100 rad/s^2 of the shipped robots (docs/robots.md)"),
}

#: Shape of the generated nominal pose [rad]: knee bend, arm abduction, elbow bend.
KNEE_BEND = 0.5
ARM_ABDUCTION = 0.2
ELBOW_BEND = 0.4

# Key-point rules as fractions of the leg length (hip to ankle); the shipped robots' hand-written
# values divided by their leg lengths (0.65-0.75 m).
PELVIS_ABOVE_HIPS = 0.11
CHEST_BELOW_SHOULDERS = 0.072
NECK_ABOVE_SHOULDERS = 0.065
HEAD_ABOVE_NECK = 0.13
TOE_ABOVE_SOLE = 0.02  # [m] ball of the foot, as the shipped robots
TOE_FORWARD = 0.6      # fraction of the way from the ankle to the sole's front edge
HAND_FRACTION = 0.48   # hand point: this fraction of the hand's length beyond the wrist

__all__ = ["DEFAULTS", "GeneratedConfig", "Limb", "NotHumanoidError", "generate_robot_config"]


@dataclass(frozen=True)
class Sole:
    """The lowest face of a foot in its foot frame [m]: extent along the robot's forward and
    left directions, and its height."""

    front: float
    back: float
    centre_left: float
    length: float
    width: float
    z: float


class LimitDefaults(TypedDict):
    """Joint -> the default limit used where the URDF has no valid value."""

    position: dict[str, tuple[float, float]]  # (lower, upper) [rad]
    velocity: dict[str, float]                # [rad/s]
    effort: dict[str, float]                  # [Nm]


@dataclass(frozen=True, eq=False)
class GeneratedConfig:
    """A configuration generated from a URDF: what robot.toml and markers.toml will say
    (written by :func:`imesh.robot.generate_files.write_generated`).

    Attributes:
        name: robot name (from the URDF's ``<robot name>``).
        urdf: the URDF file.
        limbs: ``"leg_left"``, ``"arm_right"``, ``"torso"`` and, when found, ``"head"`` -> Limb.
        root_link: the waist frame (the URDF's root link).
        feet: side -> foot frame (z axis vertical in the zero pose).
        soles: side -> the foot's lowest face.
        keypoints: marker -> (frame, (3,) offset [m] in the frame).
        keypoints_nominal_m: marker -> (3,) position [m] in the nominal pose (root at the origin).
        directions: orientation key vectors (frame, (3,) unit axis in the frame, from, to).
        kept: the joints of the limbs (actuated), in the URDF's order.
        fixed: the other joints (fixed at 0).
        nominal: joint -> angle [rad] of the standing pose.
        limits: ``"position"``/``"velocity"``/``"effort"`` -> joint -> the default used where
            the URDF has no valid value.
        use_visual: foot links whose collision geometry is contact spheres only.
        defaults: one line per missing URDF fact and the default used.
        leg_length_m: mean hip-to-ankle distance.
        mass_kg: total mass of the URDF.
        segments_nominal_m: (S, 2, 3) [m] parent-child joint segments of the limbs in the
            nominal pose (for the picture).
    """

    name: str
    urdf: Path
    limbs: Mapping[str, Limb]
    root_link: str
    feet: Mapping[str, str]
    soles: Mapping[str, Sole]
    keypoints: Mapping[str, tuple[str, np.ndarray]]
    keypoints_nominal_m: Mapping[str, np.ndarray]
    directions: tuple[tuple[str, np.ndarray, str, str], ...]
    kept: tuple[str, ...]
    fixed: tuple[str, ...]
    nominal: Mapping[str, float]
    limits: LimitDefaults
    use_visual: tuple[str, ...]
    defaults: tuple[str, ...]
    leg_length_m: float
    mass_kg: float
    segments_nominal_m: np.ndarray


@dataclass(frozen=True)
class _Frame:
    """The robot's directions in the zero pose (world = root frame): up (+z), left (from the
    right hip to the left one, horizontal) and forward = left x up."""

    up: np.ndarray
    left: np.ndarray
    forward: np.ndarray


# ----------------------------------------------------------------------------------------------
# key points


def _foot_frame(tree: UrdfTree, last: int, side: str, up: np.ndarray) -> str:
    """The ankle's link when its z axis is vertical, else a level frame on it (``l_sole``)."""
    m = tree.model
    cands = []
    for fid in tree.frames_on(last):
        f = m.frames[fid]
        if tree.data.oMf[fid].rotation[:, 2] @ up > 0.99:
            rank = (f.name != tree.link_of(last), "sole" not in f.name.lower(),
                    tree.data.oMf[fid].translation[2])
            cands.append((rank, f.name))
    if not cands:
        raise NotHumanoidError(
            f"no frame of the {side} foot ({tree.link_of(last)}) has its z axis vertical in the "
            "zero pose: add a level sole frame (a fixed link) to the foot in the URDF",
            path=tree.urdf)
    return min(cands)[1]


def _sole(tree: UrdfTree, last: int, foot: str, side: str, frame: _Frame
          ) -> tuple[Sole, list[str]]:
    """The lowest face of the foot links (collision geometry; the bottoms of contact spheres),
    in the foot frame as :func:`imesh.robot.collision.derive_sole`; and the foot links whose
    proxies must come from the visual meshes (collision geometry = contact spheres)."""
    m, pin = tree.model, tree.pin
    links = [m.frames[f].name for f in tree.frames_on(last)
             if m.frames[f].type == pin.FrameType.BODY]
    coll = [it for it in tree.items if it.frame in links and it.source == "collision"]
    vis = [it for it in tree.items if it.frame in links and it.source == "visual"]
    spheres = bool(coll) and all(it.kind == "sphere" for it in coll)
    if spheres:  # contact spheres touch the ground at their bottoms
        pts = np.array([tree.frame_pose(it.frame)[:3, :3] @ it.placement[:3, 3]
                        + tree.frame_pose(it.frame)[:3, 3] - it.dims[0] * frame.up
                        for it in coll])
    else:
        pts = tree.points_of_frames(links, "collision" if coll else "visual")
    if len(pts) < 3:
        raise NotHumanoidError(f"the {side} foot ({', '.join(links)}) has no collision or "
                               "visual geometry to find its sole in", path=tree.urdf)
    T = tree.frame_pose(foot)
    R, t = T[:3, :3], T[:3, 3]
    pf = (pts - t) @ R
    low = pf[:, 2].min()
    face = pf[pf[:, 2] <= low + 0.003]
    fx, fy = face @ (R.T @ frame.forward), face @ (R.T @ frame.left)
    if np.ptp(fx) < 0.02 or np.ptp(fy) < 0.01:
        raise NotHumanoidError(f"the {side} foot's lowest face is {np.ptp(fx) * 1000:.0f} x "
                               f"{np.ptp(fy) * 1000:.0f} mm: no usable flat sole in its "
                               "geometry (give [soles] in robot.toml)", path=tree.urdf)
    sole = Sole(front=float(fx.max()), back=float(fx.min()),
                centre_left=float((fy.max() + fy.min()) / 2), length=float(np.ptp(fx)),
                width=float(np.ptp(fy)), z=float(low))
    return sole, sorted({it.frame for it in vis}) if spheres and vis else []


def _leg_points(tree: UrdfTree, leg: Limb, frame: _Frame, kp: dict
                ) -> tuple[str, Sole, list[str], float]:
    """Hip, knee, ankle and toe key points of one leg (into ``kp``); returns the foot frame,
    the sole, the foot links needing visual proxies, and the hip-ankle distance."""
    jid, pos, axis = tree.jid, tree.pos, tree.axis
    sfx = leg.side[0]
    upper = [jid[n] for n in leg.upper]
    knee = jid[leg.middle]
    lower = [jid[n] for n in leg.lower]
    # on the first hip axis: fixed on the pelvis whatever that joint's angle
    hip = point_on_line_nearest(pos[upper[0]], axis[upper[0]], pos[upper[1:]],
                                axis[upper[1:]]) if upper else pos[knee]
    ankle = meeting_point(pos[lower], axis[lower], pos[lower[-1]])
    kp[f"hip_{sfx}"] = (tree.root_link, hip)
    kp[f"knee_{sfx}"] = (tree.link_of(knee), pos[knee])
    kp[f"ankle_{sfx}"] = (tree.link_of(lower[0]), ankle)
    foot = _foot_frame(tree, lower[-1], leg.side, frame.up)
    sole, use_visual = _sole(tree, lower[-1], foot, leg.side, frame)
    T = tree.frame_pose(foot)
    R, t = T[:3, :3], T[:3, 3]
    fwd_f, left_f = R.T @ frame.forward, R.T @ frame.left
    ankle_fwd = (R.T @ (ankle - t)) @ fwd_f
    toe_f = (ankle_fwd + TOE_FORWARD * (sole.front - ankle_fwd)) * fwd_f \
        + sole.centre_left * left_f + np.array([0.0, 0.0, sole.z + TOE_ABOVE_SOLE])
    kp[f"toe_{sfx}"] = (foot, R @ toe_f + t)
    return foot, sole, use_visual, float(np.linalg.norm(ankle - hip))


def _arm_points(tree: UrdfTree, arm: Limb, leg_len: float, kp: dict,
                defaults: list[str]) -> None:
    """Shoulder, elbow, wrist and hand key points of one arm (into ``kp``)."""
    m, pin = tree.model, tree.pin
    jid, pos, axis = tree.jid, tree.pos, tree.axis
    sfx = arm.side[0]
    upper = [jid[n] for n in arm.upper]
    elbow = jid[arm.middle]
    lower = [jid[n] for n in arm.lower]
    # on the last shoulder axis, nearest the others (a first joint may sit on the torso, as
    # Talos' arm_1: its axis must not pull the point inwards)
    shoulder = point_on_line_nearest(pos[upper[-1]], axis[upper[-1]], pos[upper[:-1]],
                                     axis[upper[:-1]]) if upper else pos[elbow]
    kp[f"shoulder_{sfx}"] = (tree.link_of(upper[-1] if upper else elbow), shoulder)
    kp[f"elbow_{sfx}"] = (tree.link_of(elbow), pos[elbow])
    last = lower[-1] if lower else elbow
    hand_links = sorted({m.frames[f].name for j in tree.subtree(last) for f in tree.frames_on(j)
                         if m.frames[f].type == pin.FrameType.BODY})
    if lower:  # the distal wrist axes, and the forearm's twist axes as its centre line
        span = np.linalg.norm(pos[last] - pos[elbow])
        distal = [j for j in lower if np.linalg.norm(pos[j] - pos[last]) < 0.5 * span + 0.01]
        use = distal + [j for j in lower if j not in distal]
        wrist = meeting_point(pos[use], axis[use], pos[last])
    else:
        wrist = pos[elbow]
    direction = wrist - pos[elbow]
    if np.linalg.norm(direction) < 0.02:  # wrist joints at the elbow: the forearm geometry
        pts = tree.points_of_frames(hand_links)
        direction = pts.mean(axis=0) - pos[elbow] if len(pts) else np.array([0.0, 0.0, -1.0])
    direction /= np.linalg.norm(direction)
    # the hand link's own axis when one runs within 12 deg of the forearm (the usual
    # convention; the forearm of a zero pose may sag a little)
    R_hand = tree.frame_pose(tree.link_of(last))[:3, :3]
    cos = R_hand.T @ direction
    k = int(np.argmax(np.abs(cos)))
    if abs(cos[k]) > np.cos(np.radians(12.0)):
        direction = np.sign(cos[k]) * R_hand[:, k]
    pts = tree.points_of_frames(hand_links, "visual")
    if len(pts) == 0:
        pts = tree.points_of_frames(hand_links)
    reach = float(((pts - wrist) @ direction).max()) if len(pts) else 0.0
    if reach < 0.02:
        reach = 0.15 * leg_len
        defaults.append(f"{arm.side} hand: no geometry beyond the wrist; hand point "
                        f"{HAND_FRACTION * reach * 1000:.0f} mm beyond it (15 % of a leg)")
    kp[f"wrist_{sfx}"] = (tree.link_of(last), wrist)
    kp[f"hand_{sfx}"] = (tree.link_of(last), wrist + HAND_FRACTION * reach * direction)


def _trunk_points(tree: UrdfTree, limbs: Mapping[str, Limb], leg_len: float, up: np.ndarray,
                  kp: dict, defaults: list[str]) -> None:
    """Pelvis, chest, neck and head key points (into ``kp``)."""
    m, pin, jid = tree.model, tree.pin, tree.jid
    hip_mid = (kp["hip_l"][1] + kp["hip_r"][1]) / 2
    kp["pelvis"] = (tree.root_link, hip_mid + PELVIS_ABOVE_HIPS * leg_len * up)
    sh_mid = (kp["shoulder_l"][1] + kp["shoulder_r"][1]) / 2
    torso = limbs["torso"]
    torso_joint = jid[torso.joints[-1]] if torso.joints else 1
    torso_link = tree.link_of(torso_joint)
    kp["chest"] = (torso_link, sh_mid - CHEST_BELOW_SHOULDERS * leg_len * up)
    head = limbs.get("head")

    def bodies(j, word=""):
        return sorted({m.frames[f].name for f in tree.frames_on(j)
                       if m.frames[f].type == pin.FrameType.BODY
                       and word in m.frames[f].name.lower()})

    # The human neck marker is the base of the neck, its head marker the skull base, where the
    # head pivots: a robot's neck joints sit there, not at the base of the neck.
    neck = sh_mid + NECK_ABOVE_SHOULDERS * leg_len * up
    kp["neck"] = (torso_link, neck)
    if head:
        hids = [jid[n] for n in head.joints]
        kp["head"] = (tree.link_of(hids[-1]),
                      meeting_point(tree.pos[hids], tree.axis[hids], tree.pos[hids[0]]))
        return
    head_links, head_frame = bodies(torso_joint, "head"), torso_link  # fixed on the torso (G1)
    pts = tree.points_of_frames(head_links, "visual")
    if len(pts) == 0:
        pts = tree.points_of_frames(head_links)
    if len(pts) and (pts.max(0) - pts.min(0)).max() > 0.05:
        head_pt = (pts.max(0) + pts.min(0)) / 2
    else:
        head_pt = neck + HEAD_ABOVE_NECK * leg_len * up
        defaults.append(f"head: no head geometry; head point {HEAD_ABOVE_NECK:.2f} leg above the "
                        "neck")
    kp["head"] = (head_frame, head_pt)


# ----------------------------------------------------------------------------------------------
# joints and limits


def _limits(tree: UrdfTree, kept: list[str], defaults: list[str]) -> LimitDefaults:
    """Defaults for the limits the URDF lacks (and a note on placeholder-looking ones)."""
    m, jid = tree.model, tree.jid
    table: LimitDefaults = {"position": {}, "velocity": {}, "effort": {}}
    for n in kept:
        jm = m.joints[jid[n]]
        lo, hi = m.lowerPositionLimit[jm.idx_q], m.upperPositionLimit[jm.idx_q]
        if not (np.isfinite(lo) and np.isfinite(hi) and abs(lo) < 1e6 and abs(hi) < 1e6
                and lo < hi):
            table["position"][n] = (-DEFAULTS["position"][0], DEFAULTS["position"][0])
        v, e = m.velocityLimit[jm.idx_v], m.effortLimit[jm.idx_v]
        if not (np.isfinite(v) and 0 < v < 1e6):
            table["velocity"][n] = DEFAULTS["velocity"][0]
        if not (np.isfinite(e) and 0 < e < 1e6):
            table["effort"][n] = DEFAULTS["effort"][0]
    for what, given in (("position", table["position"]), ("velocity", table["velocity"]),
                        ("effort", table["effort"])):
        if given:
            names = list(given)
            defaults.append(f"{what} limit missing for {len(names)} joint(s) "
                            f"({', '.join(names[:6])}{'...' if len(names) > 6 else ''}): "
                            f"{DEFAULTS[what][1]}")
    vel = np.array([m.velocityLimit[m.joints[jid[n]].idx_v] for n in kept])
    if len(vel) > 4 and np.ptp(vel) == 0 and vel[0] >= 50:
        defaults.append(f"velocity limit {vel[0]:g} rad/s on every joint: probably a placeholder "
                        "of the URDF, kept (give [limits.velocity] from motor data)")
    defaults.append(f"acceleration limits: none in URDF; {DEFAULTS['acceleration'][1]}")
    return table


# ----------------------------------------------------------------------------------------------
# generation


def generate_robot_config(urdf: str | os.PathLike, name: str | None = None) -> GeneratedConfig:
    """Generate the configuration of a humanoid URDF (module docstring for the rules).

    Args:
        urdf: the URDF file (mesh files are looked up relative to it, as :func:`load_robot`).
        name: robot name; default: the URDF's ``<robot name>`` in lower case.

    Returns:
        The generated configuration; :func:`imesh.robot.generate_files.write_generated` writes
        it.

    Raises:
        RobotConfigError: the file is missing or does not parse.
        NotHumanoidError: the tree is not a biped humanoid (saying what was found), or a foot
            has no usable sole geometry.
    """
    urdf = Path(urdf).expanduser()
    if not urdf.is_file():
        raise RobotConfigError("URDF file not found", path=urdf, key="urdf")
    tree = UrdfTree(urdf)
    m, pin, jid = tree.model, tree.pin, tree.jid
    limbs = find_limbs(tree)
    up = np.array([0.0, 0.0, 1.0])
    left = tree.pos[jid[limbs["leg_left"].joints[0]]] - tree.pos[jid[limbs["leg_right"].joints[0]]]
    left[2] = 0.0
    left /= np.linalg.norm(left)
    frame = _Frame(up=up, left=left, forward=np.cross(left, up))
    if name is None:
        name = re.sub(r"[^a-z0-9_]+", "_", (m.name or urdf.stem).lower()).strip("_") or "robot"

    defaults: list[str] = []
    kp: dict[str, tuple[str, np.ndarray]] = {}  # marker -> (frame, world point in the zero pose)
    feet, soles, use_visual, lengths = {}, {}, [], []
    for s in SIDES:
        feet[s], soles[s], vis, length = _leg_points(tree, limbs[f"leg_{s}"], frame, kp)
        use_visual += vis
        lengths.append(length)
    leg_len = float(np.mean(lengths))
    for s in SIDES:
        _arm_points(tree, limbs[f"arm_{s}"], leg_len, kp, defaults)
    _trunk_points(tree, limbs, leg_len, up, kp, defaults)

    kept = [n for limb in limbs.values() for n in limb.joints]
    fixed = tuple(n for n in tree.names[2:] if n not in kept)
    bad = [n for n in kept if not tree.revolute(jid[n])]
    if bad:
        raise NotHumanoidError(f"limb joints that are not 1-DOF revolute: {', '.join(bad)}",
                               path=urdf, found={k: [list(v.joints)] for k, v in limbs.items()})
    limits = _limits(tree, kept, defaults)

    q = _nominal_pose(tree, limbs, kp, frame)
    nominal = {n: float(q[m.joints[jid[n]].idx_q]) for n in kept
               if abs(q[m.joints[jid[n]].idx_q]) > 1e-4}
    keypoints = {}
    for mk, (f, p) in kp.items():
        T = tree.frame_pose(f)
        keypoints[mk] = (f, T[:3, :3].T @ (p - T[:3, 3]))
    data = m.createData()
    pin.framesForwardKinematics(m, data, q)
    world = {}
    for mk, (f, off) in keypoints.items():
        M = data.oMf[m.getFrameId(f)]
        world[mk] = M.rotation @ off + M.translation
    # orientation key vectors: the robot's own key-point directions in the nominal pose
    pairs = [(feet["left"], "ankle_l", "toe_l"), (feet["right"], "ankle_r", "toe_r"),
             (kp["hand_l"][0], "wrist_l", "hand_l"), (kp["hand_r"][0], "wrist_r", "hand_r")]
    if "head" in limbs:
        pairs.append((kp["head"][0], "neck", "head"))
    directions = []
    for f, a, b in pairs:
        d = world[b] - world[a]
        R = data.oMf[m.getFrameId(f)].rotation
        directions.append((f, R.T @ d / np.linalg.norm(d), a, b))
    segs = np.array([[data.oMi[int(m.parents[j])].translation, data.oMi[j].translation]
                     for j in range(2, m.njoints) if tree.names[j] in kept])
    kept_ordered = tuple(n for n in tree.names[2:] if n in kept)
    return GeneratedConfig(
        name=name, urdf=urdf, limbs=limbs, root_link=tree.root_link, feet=feet, soles=soles,
        keypoints=keypoints, keypoints_nominal_m=world, directions=tuple(directions),
        kept=kept_ordered, fixed=fixed, nominal=nominal, limits=limits,
        use_visual=tuple(use_visual), defaults=tuple(defaults), leg_length_m=leg_len,
        mass_kg=float(sum(i.mass for i in m.inertias)), segments_nominal_m=segs)


def _nominal_pose(tree: UrdfTree, limbs: Mapping[str, Limb], kp: dict, frame: _Frame
                  ) -> np.ndarray:
    """Zero pose with each leg and arm moved by a bounded least-squares IK (module docstring)."""
    m, pin = tree.model, tree.pin
    jid, up, forward, left = tree.jid, frame.up, frame.forward, frame.left
    data = m.createData()
    q = tree.q0.copy()

    def solve(joints, targets, orient=None, reg=0.05):
        idx = np.array([m.joints[jid[n]].idx_q for n in joints])
        lo, hi = m.lowerPositionLimit[idx], m.upperPositionLimit[idx]
        lo = np.where(np.isfinite(lo) & (np.abs(lo) < 1e6), lo, -np.pi)
        hi = np.where(np.isfinite(hi) & (np.abs(hi) < 1e6), hi, np.pi)
        x0 = np.clip(q[idx], lo + 1e-6, hi - 1e-6)
        fids = {f: m.getFrameId(f) for f, _, _ in targets}
        if orient is not None:
            fids[orient[0]] = m.getFrameId(orient[0])

        def res(x):
            qq = q.copy()
            qq[idx] = x
            pin.framesForwardKinematics(m, data, qq)
            r = []
            for f, off, target in targets:
                M = data.oMf[fids[f]]
                r.append(M.rotation @ off + M.translation - target)
            if orient is not None:
                R = data.oMf[fids[orient[0]]].rotation
                r.append(0.1 * pin.log3(orient[1].T @ R))
            r.append(reg * (x - x0))
            return np.concatenate(r)

        sol = least_squares(res, x0, bounds=(lo, hi), xtol=1e-10, ftol=1e-10)
        q[idx] = sol.x

    def local(marker):
        frame, p = kp[marker]
        T = tree.frame_pose(frame)
        return frame, T[:3, :3].T @ (p - T[:3, 3]), p

    a = KNEE_BEND / 2
    for s in SIDES:
        sfx = s[0]
        leg = limbs[f"leg_{s}"]
        hip = kp[f"hip_{sfx}"][1]
        fk, ok, k0 = local(f"knee_{sfx}")
        fa, oa, a0 = local(f"ankle_{sfx}")

        def sag(v):
            lat = (v @ left) * left
            return lat, np.linalg.norm(v - lat)

        lat1, l1 = sag(k0 - hip)
        lat2, l2 = sag(a0 - k0)
        knee_t = hip + lat1 + l1 * (np.sin(a) * forward - np.cos(a) * up)
        ankle_t = knee_t + lat2 + l2 * (-np.sin(a) * forward - np.cos(a) * up)
        foot = tree.link_of(jid[leg.joints[-1]])
        solve(leg.joints, [(fk, ok, knee_t), (fa, oa, ankle_t)],
              orient=(foot, tree.frame_pose(foot)[:3, :3]), reg=0.01)
    b, c = ARM_ABDUCTION, ELBOW_BEND
    for s in SIDES:
        sfx = s[0]
        arm = limbs[f"arm_{s}"]
        out = left if s == "left" else -left
        sh = kp[f"shoulder_{sfx}"][1]
        fe, oe, e0 = local(f"elbow_{sfx}")
        fw, ow, w0 = local(f"wrist_{sfx}")
        fh, oh, h0 = local(f"hand_{sfx}")
        l1, l2, l3 = (np.linalg.norm(e0 - sh), np.linalg.norm(w0 - e0), np.linalg.norm(h0 - w0))
        elbow_t = sh + l1 * (-np.cos(b) * up + np.sin(b) * out)
        fdir = -np.cos(c) * up + np.sin(c) * forward + np.sin(b) * out
        fdir /= np.linalg.norm(fdir)
        wrist_t = elbow_t + l2 * fdir
        solve(arm.joints, [(fe, oe, elbow_t), (fw, ow, wrist_t), (fh, oh, wrist_t + l3 * fdir)])
    return q

