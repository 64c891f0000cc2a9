"""Recognition of a human rig from its skeleton tree and its motion, without name tables.

Joint names are never needed: a skeleton (joints, parents, positions over frames) is read as a
body by its structure and geometry.

1. **Tree.** Bone lengths are the median over frames of each joint's distance to its parent;
   joints that coincide with their parent (zero offsets, End Sites on their joint) merge into it.
   Each joint's *main chain* continues through the child with the longest reach.
2. **Limb pairs.** Left and right limbs are mirror twins: two child branches of one joint whose
   first bones have the same lengths (within 15 %). The two twin pairs reaching furthest are the
   legs and the arms; the legs branch from the joint nearer the root (the pelvis), the arms from a
   joint of the spine above it (when neither is above the other, the legs are the pair whose ends
   lie further from the other pair's joint). Fingers, toes, eyes, face and breast bones are twins
   too, but short ones.
3. **Limb joints.** In a limb's main chain the two consecutive bones that look most like
   thigh + shin (length ratio ~1) or upper arm + forearm (~1.2), followed by something short, give
   hip/knee/ankle or shoulder/elbow/wrist. Chain points that never bend and split a bone into
   comparable parts (twist joints inside a bone) are skipped. The toe is the first point after
   the ankle; the hand the first point after the wrist on the longest finger-like branch (props
   reaching beyond 1.3 forearms are ignored; carpal joints nearer than 0.1 forearms skipped; a
   fingertip beyond 0.6 forearms replaced by the point 0.45 forearms towards it), extrapolated
   0.35 forearms beyond the wrist when nothing follows it.
4. **Spine and head.** The neck is the first spine point above the joint the arms branch from;
   the head joint is where the chain above the neck branches (eyes, jaw) or ends in a leaf (skull
   top, End Site). The spine marker is the joint or bone midpoint nearest 40 % of the way from the
   pelvis to the neck; the chest marker lies on the bone from the arm branch to the neck, 6.5 cm
   below the shoulder line along the trunk (median over frames; weights rounded to 0.1).
5. **Geometry.** Body up is the median direction from the ankles to the neck; forward the
   direction the feet point. Left is up x forward: a limb is left when it lies on that side in
   most frames. Names (``LeftLeg``/``RightLeg``, ``l``/``r``, ``.L``/``.R``) are only a hint, used
   when the geometry is unclear, and a disagreement is logged.

The result, :class:`~imesh.human.rig_result.Recognition`, gives a
:class:`~imesh.human.rig_tables.RigTable` for the 21 standard markers
(:meth:`~imesh.human.rig_result.Recognition.table`), the performer's standing height (for the unit
choice) and how sure each part is.

This module runs the steps in order; step 1 is :mod:`imesh.human.rig_tree`, steps 2-4 are
:mod:`imesh.human.rig_parts`, the measures of step 5 :mod:`imesh.human.rig_geometry` (the
left/right decision, which logs, stays here).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np

from .rig_geometry import side_hint, standing_height, unit, up_axis
from .rig_parts import (
    ARM_RATIO,
    LEG_RATIO,
    TWIN_TOLERANCE,
    hand_marker,
    limb_joints,
    limb_pairs,
    neck_and_head,
    spine_marker,
    straight_chain,
)
from .rig_result import Arm, Leg, Recognition
from .rig_tree import RigTree

log = logging.getLogger(__name__)

__all__ = ["recognize", "recognize_motion"]

#: Frames sampled (evenly) for the statistics.
MAX_FRAMES = 240


def _decide_side(tree: RigTree, frac_a_left: float, hint: int, part: str,
                 notes: list[str]) -> tuple[bool, float]:
    """Whether chain a is the left one, and the confidence, from geometry and the name hint."""
    conf = abs(2.0 * frac_a_left - 1.0)
    geometric = frac_a_left >= 0.5
    if conf >= 0.5:
        if hint and (hint > 0) != geometric:
            msg = (f"{part}: the names say left/right the other way round; the geometry "
                   f"({100 * max(frac_a_left, 1 - frac_a_left):.0f} % of frames) wins")
            log.warning("%s: %s", tree.source, msg)
            notes.append(msg)
        return geometric, conf
    if hint:
        notes.append(f"{part}: left/right unclear from the geometry ({100 * frac_a_left:.0f} % "
                     "of frames), taken from the names")
        return hint > 0, conf
    notes.append(f"{part}: left/right unclear from the geometry and the names")
    return geometric, conf


def recognize(names: Sequence[str], bones: np.ndarray, positions: np.ndarray, *,
              source: str = "") -> Recognition:
    """Recognize a human skeleton from its tree and joint positions.

    Args:
        names: (J,) joint names (only used to name the result, and as a left/right hint).
        bones: (B, 2) (parent, child) joint index pairs of the tree.
        positions: (T, J, 3) joint positions over frames, in any unit and axes (NaN allowed).
        source: the file, for messages.

    Returns:
        The recognition (joints of every body part, up, height in the positions' unit).

    Raises:
        RigRecognitionError: a body part cannot be found; the message names it and prints the
            skeleton tree.
    """
    names = tuple(str(n) for n in names)
    pos = np.asarray(positions, dtype=np.float64)
    n_joints = len(names)
    parents = np.full(n_joints, -1, dtype=np.int64)
    bones = np.asarray(bones, dtype=np.int64).reshape(-1, 2)
    parents[bones[:, 1]] = bones[:, 0]
    if pos.shape[0] > MAX_FRAMES:
        pos = pos[np.linspace(0, pos.shape[0] - 1, MAX_FRAMES).round().astype(int)]
    tree = RigTree(names, parents, pos, source)
    if not len(bones):
        raise tree.error("skeleton", "the motion has no bones")
    notes: list[str] = []
    confidence: dict[str, float] = {}

    legs_t, arms_t = limb_pairs(tree)
    pelvis, chest = legs_t[1], arms_t[1]
    confidence["twins"] = float(1.0 - (max(legs_t[4], arms_t[4]) / TWIN_TOLERANCE) ** 2)

    # ---- legs
    leg_chains, leg_k, margins = [], [], []
    for c in legs_t[2:4]:
        chain = straight_chain(tree, tree.chain(pelvis, c))
        k, margin = limb_joints(tree, chain, LEG_RATIO, "legs (hip, knee, ankle)")
        if k + 3 >= len(chain):
            raise tree.error("toe", f"nothing follows the ankle {names[chain[k + 2]]}")
        leg_chains.append(chain)
        leg_k.append(k)
        margins.append(margin)
    confidence["legs"] = float(min(margins))

    # ---- arms
    arm_chains, arm_k, margins = [], [], []
    for c in arms_t[2:4]:
        chain = straight_chain(tree, tree.chain(chest, c))
        k, margin = limb_joints(tree, chain, ARM_RATIO, "arms (shoulder, elbow, wrist)")
        arm_chains.append(chain)
        arm_k.append(k)
        margins.append(margin)
    confidence["arms"] = float(min(margins))

    def at(chain: list[int], k: int) -> np.ndarray:
        return pos[:, chain[k]]

    ankles = [at(ch, k + 2) for ch, k in zip(leg_chains, leg_k, strict=True)]
    toes = [at(ch, k + 3) for ch, k in zip(leg_chains, leg_k, strict=True)]
    hips = [at(ch, k) for ch, k in zip(leg_chains, leg_k, strict=True)]
    shoulders = [at(ch, k) for ch, k in zip(arm_chains, arm_k, strict=True)]

    neck, head = neck_and_head(tree, chest, arms_t[2:4])

    # ---- up, forward, sides
    up_t = unit(pos[:, neck] - 0.5 * (ankles[0] + ankles[1]))
    mean_up = np.nanmean(up_t, axis=0)
    confidence["up"] = float(np.linalg.norm(mean_up))
    up = unit(mean_up)
    foot = (toes[0] - ankles[0]) + (toes[1] - ankles[1])
    forward = unit(foot - np.sum(foot * up, axis=-1, keepdims=True) * up)
    left_t = np.cross(up, forward)
    frac = float(np.nanmean(np.sum((hips[0] - hips[1]) * left_t, axis=-1) > 0))
    leg_a_left, conf_legs = _decide_side(tree, frac, side_hint(tree, *leg_chains), "legs",
                                         notes)
    lateral = (hips[0] - hips[1]) if leg_a_left else (hips[1] - hips[0])
    frac = float(np.nanmean(np.sum((shoulders[0] - shoulders[1]) * lateral, axis=-1) > 0))
    arm_a_left, conf_arms = _decide_side(tree, frac, side_hint(tree, *arm_chains), "arms",
                                         notes)
    confidence["left/right"] = float(min(conf_legs, conf_arms))

    legs = []
    for chain, k, left in zip(leg_chains, leg_k, (leg_a_left, not leg_a_left), strict=True):
        legs.append(Leg("l" if left else "r", chain[k], chain[k + 1], chain[k + 2],
                        chain[k + 3]))
    arms = []
    for chain, k, left in zip(arm_chains, arm_k, (arm_a_left, not arm_a_left), strict=True):
        wrist, elbow = chain[k + 2], chain[k + 1]
        hand, note = hand_marker(tree, wrist, elbow)
        if note:
            notes.append(f"hand_{'l' if left else 'r'}: {note}")
        arms.append(Arm("l" if left else "r", chain[1] if k > 1 else None, chain[k],
                        elbow, wrist, hand))
    legs.sort(key=lambda leg: leg.side)
    arms.sort(key=lambda arm: arm.side)

    spine = spine_marker(tree, pelvis, chest, neck)

    # ---- chest geometry: shoulder line and neck above the arm branch, along the trunk
    trunk_axis = unit(pos[:, chest] - pos[:, pelvis])
    mid_sh = 0.5 * (shoulders[0] + shoulders[1])
    shoulder_h = float(np.nanmedian(np.sum((mid_sh - pos[:, chest]) * trunk_axis, axis=-1)))
    neck_h = float(np.nanmedian(np.sum((pos[:, neck] - pos[:, chest]) * trunk_axis, axis=-1)))

    height = standing_height(tree, legs, head, up)

    used = {pelvis, chest, neck, head, *(j for j, _ in spine)}
    for g in legs:
        used |= {g.hip, g.knee, g.ankle, g.toe}
    for a in arms:
        used |= {a.shoulder, a.elbow, a.wrist} | {j for j, _ in a.hand}
    used_reps = {int(tree.rep[j]) for j in used}
    ignored = int(sum(tree.rep[j] not in used_reps for j in range(n_joints)))
    result = Recognition(
        names=names, parents=tuple(int(p) for p in parents), source=source, pelvis=pelvis,
        spine=spine, chest_branch=chest, neck=neck, head=head, legs=(legs[0], legs[1]),
        arms=(arms[0], arms[1]), up=(float(up[0]), float(up[1]), float(up[2])),
        up_axis=up_axis(up),
        shoulder_height=shoulder_h, neck_height=neck_h, height=height,
        confidence={k: round(max(0.0, min(1.0, v)), 3) for k, v in confidence.items()},
        notes=tuple(notes), ignored=ignored)
    log.info("%s: human skeleton recognized (confidence %.2f): pelvis %s, arms from %s, head %s,"
             " up %s, standing height %.4g file units", source, result.overall_confidence,
             names[pelvis], names[chest], names[head], result.up_axis or "oblique", height)
    return result


def recognize_motion(motion) -> tuple[Recognition, float]:
    """The recognition of a loaded skeleton motion and the metres per unit of its lengths.

    The one :func:`imesh.io.load_motion` made (``meta['rig_recognition']``, in file units) when
    it still fits the motion's joints, else a new one on the motion itself (metres).

    Raises:
        RigRecognitionError: see :func:`recognize`.
    """
    body = motion.meta.get("rig_recognition")
    if isinstance(body, Recognition) and body.names == tuple(motion.names):
        return body, float(motion.meta.get("unit_scale_m", 1.0))
    return recognize(motion.names, motion.bones, motion.positions_m, source=motion.source), 1.0
