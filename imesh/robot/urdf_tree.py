"""A humanoid URDF read as limbs: the pinocchio model in its zero pose, its joint chains, and
which chains are the legs, arms, head and torso (the first step of :mod:`imesh.robot.generate`).

The rules are in :func:`find_limbs`; joint axes and positions come from pinocchio in the zero
pose (every joint at 0, clipped to its limits) with the root link's +z up (REP-103).
"""

from __future__ import annotations

import logging
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .build import _package_dirs
from .errors import RobotConfigError
from .geometry import geometry_items
from .pin import _pinocchio

log = logging.getLogger(__name__)

#: A joint whose axis makes less than ~45 deg with its limb segment is a twist (not a knee/elbow).
TWIST_COS = 0.7

class NotHumanoidError(RobotConfigError):
    """The URDF is not a biped humanoid imesh can generate a configuration for.

    Attributes:
        found: what was found, by kind (``"legs"``, ``"arms"``...) -> chains as joint-name lists.
    """

    def __init__(self, message: str, *, path, found: Mapping[str, list[list[str]]] | None = None):
        self.found = dict(found or {})
        super().__init__(message, path=path)


@dataclass(frozen=True)
class Limb:
    """One limb chain of the tree.

    Attributes:
        kind: ``"leg"``, ``"arm"``, ``"head"`` or ``"torso"``.
        side: ``"left"``, ``"right"`` or ``""``.
        joints: joint names from the trunk outwards.
        upper: joints before the knee/elbow (hip/shoulder); empty for head and torso.
        middle: the knee/elbow joint, or "".
        lower: joints after the knee/elbow (ankle/wrist).
    """

    kind: str
    side: str
    joints: tuple[str, ...]
    upper: tuple[str, ...] = ()
    middle: str = ""
    lower: tuple[str, ...] = ()


# ----------------------------------------------------------------------------------------------
# geometry helpers


def meeting_point(points: np.ndarray, axes: np.ndarray, anchor: np.ndarray,
                   reg: float = 1e-4) -> np.ndarray:
    """Least-squares point closest to the lines ``points[i] + t axes[i]``, pulled weakly to
    ``anchor`` (parallel axes leave a direction free)."""
    A = reg * np.eye(3)
    b = reg * anchor
    for p, a in zip(points, axes, strict=True):
        P = np.eye(3) - np.outer(a, a)
        A = A + P
        b = b + P @ p
    return np.linalg.solve(A, b)


def point_on_line_nearest(p0: np.ndarray, a0: np.ndarray, points: np.ndarray,
                           axes: np.ndarray) -> np.ndarray:
    """The point ``p0 + t a0`` closest (least squares) to the lines ``points[i] + s axes[i]``."""
    if len(points) == 0:
        return p0
    num = den = 0.0
    for p, a in zip(points, axes, strict=True):
        P = np.eye(3) - np.outer(a, a)
        den += a0 @ P @ a0
        num += a0 @ P @ (p - p0)
    return p0 + (num / den if den > 1e-12 else 0.0) * a0


_GRIPPER = re.compile(r"gripper|finger|thumb|index|pinky|claw")
_LEFT = re.compile(r"(^|[^a-z])(l|left|lft)([^a-z]|$)")
_RIGHT = re.compile(r"(^|[^a-z])(r|right|rgt)([^a-z]|$)")


def _name_side(names: Sequence[str]) -> str:
    """``"left"``/``"right"`` from joint names (``left_hip``, ``l_hip``, ``L_HIP_P``,
    ``LHipYaw``, ``LLEG_JOINT0``), or "" when they do not say."""
    votes = 0
    for n in names:
        low = n.lower()
        if _LEFT.search(low) or re.match(r"^L(?=[A-Z_])", n) or "left" in low:
            votes += 1
        if _RIGHT.search(low) or re.match(r"^R(?=[A-Z_])", n) or "right" in low:
            votes -= 1
    return "left" if votes > 0 else "right" if votes < 0 else ""


# ----------------------------------------------------------------------------------------------
# the tree


class UrdfTree:
    """The URDF's pinocchio model in its zero pose with the facts the rules need."""

    def __init__(self, urdf: Path):
        pin = _pinocchio()
        self.pin = pin
        self.urdf = urdf
        try:
            ET.parse(urdf)
            self.model = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
        except Exception as exc:
            raise RobotConfigError(f"URDF does not parse: {exc}", path=urdf) from None
        m = self.model
        dirs = _package_dirs(urdf)
        self.items = []
        for kind, gtype in (("collision", pin.GeometryType.COLLISION),
                            ("visual", pin.GeometryType.VISUAL)):
            try:
                gm = pin.buildGeomFromUrdf(m, str(urdf), gtype, None, dirs)
            except Exception as exc:
                log.warning("%s: cannot load the %s geometry (%s): key points that need it "
                            "use joint positions only", urdf.name, kind, exc)
                continue
            self.items += geometry_items(m, gm, kind)
        self.names = list(m.names)
        self.jid = {n: i for i, n in enumerate(self.names)}
        self.children: dict[int, list[int]] = {j: [] for j in range(m.njoints)}
        for j in range(2, m.njoints):
            self.children[int(m.parents[j])].append(j)
        q = pin.neutral(m)
        for j in range(2, m.njoints):
            jm = m.joints[j]
            if jm.nq == 1:
                q[jm.idx_q] = np.clip(0.0, m.lowerPositionLimit[jm.idx_q],
                                      m.upperPositionLimit[jm.idx_q])
        self.q0 = q
        self.data = m.createData()
        pin.computeJointJacobians(m, self.data, q)
        pin.framesForwardKinematics(m, self.data, q)
        self.pos = np.array([self.data.oMi[j].translation for j in range(m.njoints)])
        self.axis = np.zeros((m.njoints, 3))
        for j in range(2, m.njoints):
            jm = m.joints[j]
            if jm.nv == 1:
                J = pin.getJointJacobian(m, self.data, j, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
                w = J[3:, jm.idx_v]
                self.axis[j] = w / np.linalg.norm(w) if np.linalg.norm(w) > 1e-9 else 0.0
        self.root_link = self.link_of(1)

    def revolute(self, j: int) -> bool:
        return bool(self.model.joints[j].nq == 1 and np.linalg.norm(self.axis[j]) > 0.5)

    def link_of(self, j: int) -> str:
        """The link a joint moves (the first body frame on it)."""
        pin = self.pin
        for f in self.model.frames:
            if f.parentJoint == j and f.type == pin.FrameType.BODY:
                return f.name
        raise RobotConfigError(f"joint {self.names[j]!r} moves no link", path=self.urdf)

    def frames_on(self, j: int) -> list[int]:
        pin = self.pin
        return [i for i, f in enumerate(self.model.frames) if f.parentJoint == j
                and f.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME)]

    def frame_pose(self, name: str) -> np.ndarray:
        fid = self.model.getFrameId(name)
        return self.data.oMf[fid].homogeneous

    def points_of_frames(self, frames: Sequence[str], source: str | None = None) -> np.ndarray:
        """(P, 3) world points of the geometry of the given link frames (zero pose)."""
        pts = []
        for it in self.items:
            if it.frame in frames and (source is None or it.source == source):
                T = self.frame_pose(it.frame)
                p = it.points_in_frame()
                pts.append(p @ T[:3, :3].T + T[:3, 3])
        return np.concatenate(pts) if pts else np.zeros((0, 3))

    def subtree(self, j: int) -> list[int]:
        out, stack = [], [j]
        while stack:
            k = stack.pop()
            out.append(k)
            stack += self.children[k]
        return out

    def chains(self) -> list[tuple[int, list[int]]]:
        """(branching joint, chain) for every chain between branching joints and leaves."""
        out = []
        starts = [1] + [j for j in range(2, self.model.njoints) if len(self.children[j]) >= 2]
        for b in starts:
            for c in self.children[b]:
                chain = [c]
                while len(self.children[chain[-1]]) == 1:
                    chain.append(self.children[chain[-1]][0])
                out.append((b, chain))
        return out

    def path_to_root(self, j: int) -> list[int]:
        out = []
        while j > 1:
            out.append(j)
            j = int(self.model.parents[j])
        return out[::-1]


def _chain_length(tree: UrdfTree, chain: Sequence[int], end: np.ndarray | None = None) -> float:
    pts = tree.pos[list(chain)]
    if end is not None:
        pts = np.vstack([pts, end])
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())


def _split_limb(tree: UrdfTree, chain: list[int], end: np.ndarray, kind: str, side: str,
                found) -> Limb:
    """Upper joints, middle (knee/elbow) and lower joints of a leg or arm chain."""
    names = [tree.names[j] for j in chain]
    start = tree.pos[chain[0]]
    pts = np.vstack([tree.pos[chain], end])
    # position along the chain's path (a shoulder may sit well off the torso joint, as Talos')
    along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    length = max(along[-1], 1e-6)
    middle, best = -1, np.inf
    for i, j in enumerate(chain):
        if not tree.revolute(j):
            continue
        nxt = [p for p in pts[i + 1:] if np.linalg.norm(p - pts[i]) > 0.01]
        seg = (nxt[0] - pts[i]) if nxt else (pts[i] - start)
        if np.linalg.norm(seg) < 1e-9:
            continue
        twist = abs(tree.axis[j] @ seg / np.linalg.norm(seg)) > TWIST_COS
        frac = along[i] / length
        # the bending joint nearest the middle of the limb
        if not twist and 0.2 < frac < 0.85 and abs(frac - 0.5) < best:
            middle, best = i, abs(frac - 0.5)
    what = "knee" if kind == "leg" else "elbow"
    if middle < 0 or middle == len(chain) - 1 and kind == "leg":
        raise NotHumanoidError(f"the {side} {kind} chain {', '.join(names)} has no {what} (a "
                               f"joint bending the {kind} between 20 and 85 % of its "
                               f"length){' or no ankle after it' if middle >= 0 else ''}",
                               path=tree.urdf, found=found)
    return Limb(kind=kind, side=side, joints=tuple(names), upper=tuple(names[:middle]),
                middle=names[middle], lower=tuple(names[middle + 1:]))


def find_limbs(tree: UrdfTree) -> dict[str, Limb]:
    """Legs, arms, head and torso of a humanoid tree (module docstring).

    Raises:
        NotHumanoidError: not two legs, not two arms, or a limb without knee/elbow.
    """
    chains = tree.chains()
    pos = tree.pos
    z_all = pos[2:, 2]
    if len(z_all) == 0:
        raise NotHumanoidError("the URDF has no joints", path=tree.urdf)
    top, bottom = float(max(z_all.max(), 0.0)), float(min(z_all.min(), 0.0))
    height = top - bottom
    extent = np.ptp(pos[1:], axis=0)
    lying = ""
    if extent[2] < 0.6 * extent[:2].max():  # even arms spread wide span about the height
        lying = (f"; the model does not stand along z in its zero pose (its joints span "
                 f"{extent[2]:.2f} m along z and {extent[:2].max():.2f} m along "
                 f"{'xy'[int(np.argmax(extent[:2]))]}): a humanoid URDF needs the root link's z "
                 "axis up (REP-103)")

    def named(chs):
        return [[tree.names[j] for j in c] for _, c in chs]

    def end_point(chain):  # the chain's last joint, or its link's geometry tip for a leaf
        return pos[chain[-1]]

    legs = [(b, c) for b, c in chains if end_point(c)[2] < bottom + 0.25 * height
            and end_point(c)[2] < -0.1 * height]
    found = {"leg chains": named(legs)}
    if len(legs) != 2:
        what = "no leg chain" if not legs else f"{len(legs)} leg chains"
        raise NotHumanoidError(
            f"{what} found{': ' + '; '.join(', '.join(c) for c in named(legs)) if legs else ''}"
            " (a biped humanoid has exactly two joint chains reaching the ground in the zero "
            "pose, with the root link's z axis up)" + lying, path=tree.urdf, found=found)

    leg_ids = {j for _, c in legs for j in c}
    hip_z = min(pos[c[0], 2] for _, c in legs)
    leg_len = np.mean([np.linalg.norm(pos[c[-1]] - pos[c[0]]) for _, c in legs])
    candidates = []
    for b, c in chains:
        if set(c) & leg_ids:
            continue
        length = _chain_length(tree, c)
        if length < 0.15 * leg_len or pos[c[0], 2] < hip_z:
            continue
        candidates.append((b, c))
    pairs = []
    for i, (b1, c1) in enumerate(candidates):
        for b2, c2 in candidates[i + 1:]:
            if b1 != b2:
                continue
            p1, p2 = pos[c1[0]], pos[c2[0]]
            mirrored = abs(p1[2] - p2[2]) < 0.02 + 0.05 * leg_len and abs(p1[0] - p2[0]) < 0.05
            if mirrored and np.linalg.norm(p1[:2] - p2[:2]) > 0.05 * leg_len:
                pairs.append((np.linalg.norm(p1 - p2), b1, c1, c2))
    found["arm chains"] = [[tree.names[j] for j in c] for _, c in candidates]
    if not pairs:
        raise NotHumanoidError(
            "no pair of arm chains found above the hips (two mirrored chains branching from "
            "the same joint); chains found: "
            + ("; ".join(", ".join(c) for c in found["arm chains"]) or "none"),
            path=tree.urdf, found=found)
    _, branch, a1, a2 = max(pairs, key=lambda p: p[0])

    # sides: names first, y (REP-103: y is left) when the names do not tell
    def sides(c1, c2):
        s1, s2 = _name_side([tree.names[j] for j in c1]), _name_side([tree.names[j] for j in c2])
        if not s1 or not s2 or s1 == s2:
            s1 = "left" if pos[c1[-1], 1] > pos[c2[-1], 1] else "right"
            s2 = "right" if s1 == "left" else "left"
        return s1, s2

    limbs: dict[str, Limb] = {}
    (l1, l2), (s1, s2) = (legs[0][1], legs[1][1]), sides(legs[0][1], legs[1][1])
    left_vec = pos[l1[0]] - pos[l2[0]] if s1 == "left" else pos[l2[0]] - pos[l1[0]]
    left_vec[2] = 0.0
    if np.linalg.norm(left_vec) < 1e-6:
        left_vec = np.array([0.0, 1.0, 0.0])
    for c, s in ((l1, s1), (l2, s2)):
        limbs[f"leg_{s}"] = _split_limb(tree, c, pos[c[-1]], "leg", s, found)
    t1, t2 = sides(a1, a2)
    # a gripper or finger joint at the end of an arm chain (Talos) is part of the hand: fixed
    a1, a2 = ([j for k, j in enumerate(c) if not (k > 2 and _GRIPPER.search(tree.names[j].lower())
                                                  and all(_GRIPPER.search(tree.names[i].lower())
                                                          for i in c[k:]))]
              for c in (a1, a2))
    for c, s in ((a1, t1), (a2, t2)):
        limbs[f"arm_{s}"] = _split_limb(tree, c, pos[c[-1]], "arm", s, found)
    torso = tree.path_to_root(branch) if branch > 1 else []
    limbs["torso"] = Limb(kind="torso", side="", joints=tuple(tree.names[j] for j in torso))
    # head: a chain from the arms' branching joint (or the torso) ending highest near the middle
    arm_ids = set(a1) | set(a2)
    heads = [(b, c) for b, c in chains if (b == branch or b in torso) and not set(c) & arm_ids
             and not set(c) & leg_ids and pos[c[-1], 2] > pos[a1[0], 2]
             and abs(pos[c[-1]] @ (left_vec / np.linalg.norm(left_vec))) < 0.05]
    if heads:
        _, hc = max(heads, key=lambda bc: pos[bc[1][-1], 2])
        limbs["head"] = Limb(kind="head", side="", joints=tuple(tree.names[j] for j in hc))
    return limbs
