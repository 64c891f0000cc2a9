"""The body-part finders of rig recognition, each on a :class:`~imesh.human.rig_tree.RigTree`:
the legs' and the arms' twin (left/right) chains, the hip/knee/ankle and shoulder/elbow/wrist in a
limb chain (twist joints skipped), the neck and head, the spine marker and the hand marker.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .rig_geometry import unit
from .rig_tree import RigTree

#: Largest mean |log ratio| of the first bones of two twin (left/right) chains.
TWIN_TOLERANCE = 0.15
#: Typical thigh/shin and upper-arm/forearm length ratios, and the spread allowed (log).
LEG_RATIO, ARM_RATIO, RATIO_SIGMA = 1.0, 1.2, 0.3
#: Spine marker: joint or bone midpoint nearest this fraction of the pelvis -> neck chain.
SPINE_FRACTION = 0.4
#: Hand marker of a rig without hand joints: wrist + this x (wrist - elbow).
HAND_EXTRAPOLATION = 0.35
#: Hand marker: the first point beyond the wrist at least HAND_NEAR forearms away (closer ones
#: are carpal joints); when it lies beyond HAND_FAR forearms (a fingertip), the point HAND_AT
#: forearms along the way to it (weights rounded to 0.1).
HAND_NEAR, HAND_FAR, HAND_AT = 0.1, 0.6, 0.45
#: A branch of the wrist reaching further than this x the forearm is a prop, not a hand.
PROP_REACH = 1.3
#: Interior chain points that never bend more than this [deg], between two bones of comparable
#: length (ratio within TWIST_SPLIT), are twist joints.
STRAIGHT_DEG = 0.5
TWIST_SPLIT = (0.6, 1.67)


def twin_pairs(tree: RigTree) -> list[tuple[float, int, int, int, float]]:
    """Twin child pairs, largest first: (reach of the shorter twin, joint, child a, child b,
    mean |log| difference of their first three bones)."""
    out = []
    for j in tree.order:
        kids = tree.kids[j] if tree.rep[j] == j else []
        if len(kids) < 2:
            continue
        sig = {c: tree.length[tree.chain(j, c)[1:5]] for c in kids}
        for ia, a in enumerate(kids):
            for b in kids[ia + 1:]:
                sa, sb = sig[a], sig[b]
                m = min(len(sa), len(sb), 3)
                if m < 2:
                    continue
                d = float(np.mean(np.abs(np.log(sa[:m] / sb[:m]))))
                if d < TWIN_TOLERANCE:
                    size = min(tree.length[a] + tree.reach[a], tree.length[b] + tree.reach[b])
                    out.append((float(size), j, a, b, d))
    return sorted(out, key=lambda t: -t[0])


def limb_pairs(tree: RigTree) -> tuple[tuple, tuple]:
    """The legs' and the arms' twin pairs (size, joint, child a, child b, difference)."""
    names, pos = tree.names, tree.pos
    twins = twin_pairs(tree)
    if not twins:
        raise tree.error("legs", "no joint has two mirror-image (left/right) chains")
    first = twins[0]
    second = next((t for t in twins[1:] if t[1] != first[1] and t[0] >= 0.3 * first[0]), None)
    if second is None:
        raise tree.error("second pair of limbs",
                         f"only {names[first[1]]} has two long mirror-image chains ("
                         f"{names[first[2]]}, {names[first[3]]}); legs and arms make two pairs")
    if first[1] in tree.ancestors(second[1]):
        return first, second
    if second[1] in tree.ancestors(first[1]):
        return second, first

    # legs and spine hang side by side from a common root: the feet are far from the arms'
    # joint, the hands near the pelvis (median over frames)
    def spread(pair: tuple, other: tuple) -> float:
        ends = [tree.chain(pair[1], c)[-1] for c in pair[2:4]]
        return float(np.nanmedian(np.linalg.norm(pos[:, ends] - pos[:, [other[1]]], axis=-1)))

    return (first, second) if spread(first, second) >= spread(second, first) else (second, first)


def straight_chain(tree: RigTree, chain: list[int]) -> list[int]:
    """The chain without twist joints inside a bone: interior points that never bend and split
    their bone into comparable parts (a wrist that only twists, followed by a short hand bone,
    stays).

    Only when the chain moves (some point bends by 10 deg or more): in a still pose a straight
    elbow cannot be told from a twist joint.
    """
    if len(chain) < 4 or tree.pos.shape[0] < 2:
        return chain
    a = tree.pos[:, chain[1:-1]] - tree.pos[:, chain[:-2]]
    b = tree.pos[:, chain[2:]] - tree.pos[:, chain[1:-1]]
    cos = np.sum(a * b, axis=-1) / np.maximum(
        np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1), 1e-300)
    bend = np.degrees(np.arccos(np.clip(np.nanmin(cos, axis=0), -1.0, 1.0)))
    if bend.max() < 10.0:
        return chain
    before = np.linalg.norm(np.nanmedian(a, axis=0), axis=-1)
    after = np.linalg.norm(np.nanmedian(b, axis=0), axis=-1)
    ratio = before / np.maximum(after, 1e-300)
    twist = (bend <= STRAIGHT_DEG) & (ratio > TWIST_SPLIT[0]) & (ratio < TWIST_SPLIT[1])
    return [chain[0], *(j for j, t in zip(chain[1:-1], twist, strict=True) if not t), chain[-1]]


def limb_joints(tree: RigTree, chain: list[int], ratio: float, part: str) -> tuple[int, float]:
    """Index k in ``chain`` such that chain[k:k+3] is (hip, knee, ankle) or (shoulder, elbow,
    wrist), and the margin over the runner-up."""
    if len(chain) < 4:
        raise tree.error(part, f"its chain has {len(chain) - 1} bones, a limb needs 3")
    lengths = np.array([tree.dist(chain[k], chain[k + 1]) for k in range(len(chain) - 1)])
    scores = []
    for k in range(1, len(lengths) - 1):  # chain[0] is the pelvis / the arms' spine joint
        upper, lower = lengths[k], lengths[k + 1]
        if upper <= 0 or lower <= 0:
            scores.append(0.0)
            continue
        fit = np.exp(-(np.log(upper / lower / ratio) ** 2) / (2 * RATIO_SIGMA ** 2))
        # what follows the limb (foot, hand) is shorter than its lower bone
        nxt = [tree.length[c] for c in tree.kids[tree.rep[chain[k + 2]]]]
        after = min(nxt) / lower if nxt else 0.0
        short = 1.0 if after <= 0.75 else float(np.exp(-((after - 0.75) / 0.25) ** 2))
        scores.append((upper + lower) * fit * short)
    if not scores or max(scores) <= 0:
        raise tree.error(part, "no two consecutive bones look like a limb")
    order = np.argsort(scores)[::-1]
    best = float(scores[order[0]])
    second = float(scores[order[1]]) if len(order) > 1 else 0.0
    return int(order[0]) + 1, 1.0 - second / best


def neck_and_head(tree: RigTree, chest: int, arms: Sequence[int]) -> tuple[int, int]:
    """The neck (first point of the arms' joint's longest other branch) and the head joint
    (where that chain branches, or the last joint before a leaf)."""
    others = [c for c in tree.kids[chest] if c not in arms]
    if not others:
        raise tree.error("neck", f"the arms' joint {tree.names[chest]} has no other branch")
    cur = neck = max(others, key=lambda c: tree.length[c] + tree.reach[c])
    while len(tree.kids[cur]) == 1 and not tree.leaf(tree.kids[cur][0]):
        cur = tree.kids[cur][0]
    if cur == neck and len(tree.kids[neck]) == 1:  # neck -> head leaf: the leaf is the head
        return neck, tree.kids[neck][0]
    return neck, cur


def spine_marker(tree: RigTree, pelvis: int, chest: int, neck: int
                  ) -> tuple[tuple[int, float], ...]:
    """The joint or bone midpoint of the pelvis -> arm branch -> neck path nearest
    SPINE_FRACTION of its length, not above the arm branch."""
    up_chest = tree.ancestors(chest)
    if pelvis in up_chest:
        path = up_chest[:up_chest.index(pelvis) + 1][::-1]
    else:  # pelvis beside the spine: skip the common root below them
        common = next(a for a in tree.ancestors(pelvis) if a in up_chest)
        path = [pelvis] + up_chest[:up_chest.index(common)][::-1]
    path = path + [neck]
    seg = np.array([tree.dist(path[k], path[k + 1]) for k in range(len(path) - 1)])
    keep = np.concatenate([[True], seg > 1e-4 * tree.scale])
    keep[-1] = True
    path = [p for p, kk in zip(path, keep, strict=True) if kk]
    if len(path) < 3:
        raise tree.error("spine", "the pelvis, the arms' joint and the neck do not make a chain")
    seg = np.array([tree.dist(path[k], path[k + 1]) for k in range(len(path) - 1)])
    f = np.concatenate([[0.0], np.cumsum(seg)]) / seg.sum()
    f_chest = f[path.index(chest)] if chest in path else f[-2]
    candidates: list[tuple[float, tuple[tuple[int, float], ...]]]
    candidates = [(abs(f[k] - SPINE_FRACTION), ((path[k], 1.0),))
                  for k in range(1, len(path) - 1) if f[k] <= f_chest + 1e-9]
    candidates += [(abs(0.5 * (f[k] + f[k + 1]) - SPINE_FRACTION),
                    ((path[k], 0.5), (path[k + 1], 0.5)))
                   for k in range(len(path) - 2) if f[k + 1] <= f_chest + 1e-9]
    return min(candidates, key=lambda c: c[0])[1]


def hand_marker(tree: RigTree, wrist: int, elbow: int) -> tuple[tuple[tuple[int, float], ...], str]:
    """The hand marker as (joint, weight) pairs, and a note when it is not a joint.

    On the wrist's longest finger-like branch (the middle finger; the best aligned with the
    forearm among equals; props are not finger-like): the first point at least HAND_NEAR
    forearms from the wrist, or HAND_AT forearms towards it when it lies beyond HAND_FAR (a
    fingertip). Nothing beyond the wrist: extrapolated along the forearm.
    """
    names = tree.names
    forearm = tree.dist(elbow, wrist)
    options = [c for c in tree.kids[tree.rep[wrist]]
               if tree.length[c] + tree.reach[c] <= PROP_REACH * forearm]
    if not options:
        return (((wrist, 1.0 + HAND_EXTRAPOLATION), (elbow, -HAND_EXTRAPOLATION)),
                f"nothing follows the wrist {names[wrist]}: extrapolated "
                f"{HAND_EXTRAPOLATION} forearms beyond it")
    reach = np.array([tree.length[c] + tree.reach[c] for c in options])
    close = [c for c, r in zip(options, reach, strict=True) if r >= reach.max() * (1 - 1e-9)]
    if len(close) == 1:  # the longest finger: the middle one
        branch = int(close[0])
    else:
        direction = unit(tree.pos[:, wrist] - tree.pos[:, elbow])
        align = [float(np.nanmedian(np.sum(unit(tree.pos[:, c] - tree.pos[:, wrist]) *
                                           direction, axis=-1))) for c in close]
        branch = int(close[int(np.argmax(align))])
    chain = tree.chain(wrist, branch)[1:]
    point = next((j for j in chain if tree.dist(wrist, j) >= HAND_NEAR * forearm), chain[-1])
    far = tree.dist(wrist, point) / forearm
    if far <= HAND_FAR:
        return ((point, 1.0),), ""
    t = round(HAND_AT / far, 1)
    return (((wrist, round(1.0 - t, 1)), (point, t)),
            f"the first point beyond the wrist, {names[point]}, is {far:.2f} forearms away (a "
            f"fingertip): the hand is {t:g} of the way to it")
