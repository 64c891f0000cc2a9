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

The result, :class:`Recognition`, gives a :class:`~imesh.human.rig_tables.RigTable` for the 21
standard markers (:meth:`Recognition.table`), the performer's standing height (for the unit choice)
and how sure each part is.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .errors import RigRecognitionError
from .markerset import STANDARD_MARKERS
from .rig_tables import RigTable

log = logging.getLogger(__name__)

__all__ = ["RECOGNIZED", "Leg", "Arm", "Recognition", "recognize", "recognize_motion",
           "skeleton_tree", "CHEST_BELOW_SHOULDERS_M", "HAND_EXTRAPOLATION", "SPINE_FRACTION"]

#: Name of the rig table a recognition gives.
RECOGNIZED = "recognized"
#: Frames sampled (evenly) for the statistics.
MAX_FRAMES = 240
#: Largest mean |log ratio| of the first bones of two twin (left/right) chains.
TWIN_TOLERANCE = 0.15
#: Typical thigh/shin and upper-arm/forearm length ratios, and the spread allowed (log).
LEG_RATIO, ARM_RATIO, RATIO_SIGMA = 1.0, 1.2, 0.3
#: Spine marker: joint or bone midpoint nearest this fraction of the pelvis -> neck chain.
SPINE_FRACTION = 0.4
#: Chest marker: this far below the shoulder line (along the trunk), on the arm-branch -> neck
#: bone [m].
CHEST_BELOW_SHOULDERS_M = 0.065
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
#: Body up is an axis of the file when within this angle of it [deg].
UP_AXIS_TOLERANCE_DEG = 30.0

_SIDE_WORDS = {("l", "r"): 1, ("left", "right"): 1, ("lft", "rgt"): 1, ("lt", "rt"): 1}


# ---------------------------------------------------------------------------- results
@dataclass(frozen=True)
class Leg:
    """Joint indices of one leg."""

    side: str
    hip: int
    knee: int
    ankle: int
    toe: int


@dataclass(frozen=True)
class Arm:
    """Joint indices of one arm; ``hand`` is the hand marker as (joint, weight) pairs (one joint,
    a point towards a fingertip, or extrapolated from the forearm)."""

    side: str
    clavicle: int | None
    shoulder: int
    elbow: int
    wrist: int
    hand: tuple[tuple[int, float], ...]


@dataclass(frozen=True, eq=False)
class Recognition:
    """A skeleton read as a human body.

    Attributes:
        names: joint names of the skeleton.
        parents: parent index per joint (-1 for roots).
        source: the file (or motion) recognized.
        pelvis: joint the legs branch from.
        spine: the spine marker as (joint, weight) pairs.
        chest_branch: joint the arms branch from.
        neck: first spine point above the arm branch.
        head: the head joint (top of the neck).
        legs: left and right leg.
        arms: left and right arm.
        up: (3,) body up in the file's axes (unit vector).
        up_axis: the file axis ("+Y", "-Z", ...) along body up, None when the body is not within
            30 deg of an axis.
        shoulder_height: the shoulder line above the arm branch, along the trunk (pelvis -> arm
            branch), median over frames [file units].
        neck_height: the neck above the arm branch, along the trunk [file units].
        height: standing height, head joint above the lowest foot point [file units].
        confidence: part -> margin in [0, 1] (1 = unambiguous).
        notes: decisions worth reporting (names that disagreed, extrapolations, ...).
        ignored: how many joints no standard marker uses (fingers, twist, face, props ...).
    """

    names: tuple[str, ...]
    parents: tuple[int, ...]
    source: str
    pelvis: int
    spine: tuple[tuple[int, float], ...]
    chest_branch: int
    neck: int
    head: int
    legs: tuple[Leg, Leg]
    arms: tuple[Arm, Arm]
    up: tuple[float, float, float]
    up_axis: str | None
    shoulder_height: float
    neck_height: float
    height: float
    confidence: dict
    notes: tuple[str, ...]
    ignored: int

    @property
    def overall_confidence(self) -> float:
        """The smallest part confidence."""
        return float(min(self.confidence.values()))

    def chest_weights(self, unit_scale_m: float) -> tuple[tuple[int, float], ...]:
        """The chest marker as (joint, weight) pairs for a length unit [m per file unit]."""
        target = self.shoulder_height - CHEST_BELOW_SHOULDERS_M / unit_scale_m
        t = float(np.clip(np.round(target / max(self.neck_height, 1e-12), 1), 0.0, 0.9))
        if t == 0.0:
            return ((self.chest_branch, 1.0),)
        return ((self.chest_branch, round(1.0 - t, 1)), (self.neck, t))

    def markers(self, unit_scale_m: float = 1.0) -> dict[str, tuple[tuple[str, float], ...]]:
        """Standard marker -> ((joint name, weight), ...) for a length unit [m per file unit]."""
        n = self.names
        left_leg, right_leg = self.legs
        left_arm, right_arm = self.arms
        out: dict[str, tuple[tuple[str, float], ...]] = {
            "pelvis": ((n[self.pelvis], 1.0),),
            "spine": tuple((n[j], w) for j, w in self.spine),
            "chest": tuple((n[j], w) for j, w in self.chest_weights(unit_scale_m)),
            "neck": ((n[self.neck], 1.0),),
            "head": ((n[self.head], 1.0),),
        }
        for leg in (left_leg, right_leg):
            s = leg.side
            out[f"hip_{s}"] = ((n[leg.hip], 1.0),)
            out[f"knee_{s}"] = ((n[leg.knee], 1.0),)
            out[f"ankle_{s}"] = ((n[leg.ankle], 1.0),)
            out[f"toe_{s}"] = ((n[leg.toe], 1.0),)
        for arm in (left_arm, right_arm):
            s = arm.side
            out[f"shoulder_{s}"] = ((n[arm.shoulder], 1.0),)
            out[f"elbow_{s}"] = ((n[arm.elbow], 1.0),)
            out[f"wrist_{s}"] = ((n[arm.wrist], 1.0),)
            out[f"hand_{s}"] = tuple((n[j], w) for j, w in arm.hand)
        return {m: out[m] for m in STANDARD_MARKERS}

    def table(self, unit_scale_m: float = 1.0, name: str = RECOGNIZED) -> RigTable:
        """The recognized mapping as a rig table (what ``imesh rig`` writes)."""
        return RigTable(
            name=name,
            description=f"recognized from the skeleton of {self.source} (confidence "
                        f"{self.overall_confidence:.2f})",
            detect=(), markers=self.markers(unit_scale_m), path=self.source)

    def describe(self, unit_scale_m: float = 1.0) -> list[str]:
        """Human-readable lines: each standard marker, its joints and the confidences."""
        lines = []
        for marker, combo in self.markers(unit_scale_m).items():
            if len(combo) == 1:
                text = combo[0][0]
            else:
                text = " + ".join(f"{w:g} {j}" for j, w in combo)
            lines.append(f"{marker:>10} = {text}")
        conf = ", ".join(f"{k} {v:.2f}" for k, v in self.confidence.items())
        lines.append(f"confidence {self.overall_confidence:.2f} ({conf}); {self.ignored} joints "
                     "unused (fingers, twist, face, props ...)")
        lines.extend(f"note: {note}" for note in self.notes)
        return lines


# ---------------------------------------------------------------------------- the tree
class _Tree:
    """Skeleton tree with bone lengths, coincident joints merged, reaches and main chains."""

    def __init__(self, names: Sequence[str], parents: np.ndarray, pos: np.ndarray, source: str):
        self.names = tuple(names)
        self.parents = parents
        self.pos = pos
        self.source = source
        n = len(names)
        self.children: list[list[int]] = [[] for _ in range(n)]
        for j, p in enumerate(parents):
            if p >= 0:
                self.children[p].append(j)
        roots = [j for j in range(n) if parents[j] < 0]
        self.order: list[int] = []
        stack = list(reversed(roots))
        while stack:
            j = stack.pop()
            self.order.append(j)
            stack.extend(reversed(self.children[j]))
        has_parent = parents >= 0
        diff = pos[:, has_parent] - pos[:, parents[has_parent]]
        self.length = np.zeros(n)
        self.length[has_parent] = np.nanmedian(np.linalg.norm(diff, axis=-1), axis=0)
        depth = np.zeros(n)
        for j in self.order:
            if parents[j] >= 0:
                depth[j] = depth[parents[j]] + self.length[j]
        self.scale = float(depth.max()) if n else 0.0
        eps = 1e-4 * self.scale
        self.rep = np.arange(n)
        for j in self.order:
            if parents[j] >= 0 and self.length[j] <= eps:
                self.rep[j] = self.rep[parents[j]]
        self.kids: list[list[int]] = [[] for _ in range(n)]
        for j in self.order:
            if parents[j] >= 0 and self.rep[j] == j:
                self.kids[self.rep[parents[j]]].append(j)
        self.reach = np.zeros(n)
        self.main = np.full(n, -1)
        for j in reversed(self.order):
            if self.rep[j] != j:
                continue
            best = -1.0
            for c in self.kids[j]:
                r = self.length[c] + self.reach[c]
                if r > best:
                    best, self.main[j] = r, c
            self.reach[j] = max(best, 0.0)

    def leaf(self, j: int) -> bool:
        """True when the joint has no children at all (before merging)."""
        return not self.children[j]

    def chain(self, start: int, through: int | None = None) -> list[int]:
        """Main chain from ``start`` (optionally through one of its children) to a leaf."""
        out = [start]
        j = through if through is not None else self.main[start]
        while j >= 0:
            out.append(int(j))
            j = self.main[j]
        return out

    def ancestors(self, j: int) -> list[int]:
        out = []
        while j >= 0:
            out.append(int(j))
            j = self.parents[j]
        return out

    def dist(self, a: int, b: int) -> float:
        return float(np.nanmedian(np.linalg.norm(self.pos[:, a] - self.pos[:, b], axis=-1)))

    def error(self, part: str, reason: str) -> RigRecognitionError:
        return RigRecognitionError(self.source, part, reason,
                                   skeleton_tree(self.names, self.parents, self.length),
                                   self.names)


def skeleton_tree(names: Sequence[str], parents: Sequence[int] | np.ndarray,
                  lengths: Sequence[float] | np.ndarray | None = None, max_lines: int = 400
                  ) -> str:
    """The skeleton as an indented tree, one joint a line with its bone length."""
    parents = list(parents)
    children: list[list[int]] = [[] for _ in names]
    for j, p in enumerate(parents):
        if p >= 0:
            children[p].append(j)
    lines: list[str] = []
    stack = [(j, 0) for j in reversed(range(len(names))) if parents[j] < 0]
    while stack and len(lines) < max_lines:
        j, depth = stack.pop()
        length = "" if lengths is None or parents[j] < 0 else f"  {lengths[j]:.4g}"
        lines.append(f"{'  ' * depth}{names[j]}{length}")
        stack.extend((c, depth + 1) for c in reversed(children[j]))
    if stack:
        lines.append(f"... ({len(names) - len(lines)} more joints)")
    return "\n".join(lines)


# ---------------------------------------------------------------------------- helpers
def _twins(tree: _Tree) -> list[tuple[float, int, int, int, float]]:
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


def _straight(tree: _Tree, chain: list[int]) -> list[int]:
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


def _limb(tree: _Tree, chain: list[int], ratio: float, part: str) -> tuple[int, float]:
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


def _side_hint(tree: _Tree, chain_a: list[int], chain_b: list[int]) -> int:
    """+1 when the names say chain a is the left one, -1 right, 0 when they say nothing."""
    votes = 0
    for a, b in zip(chain_a[1:], chain_b[1:], strict=False):
        na, nb = tree.names[a], tree.names[b]
        i = 0
        while i < min(len(na), len(nb)) and na[i] == nb[i]:
            i += 1
        k = 0
        while k < min(len(na), len(nb)) - i and na[-1 - k] == nb[-1 - k]:
            k += 1
        da, db = na[i:len(na) - k].lower(), nb[i:len(nb) - k].lower()
        for left, right in _SIDE_WORDS:
            if (da, db) == (left, right):
                votes += 1
            elif (da, db) == (right, left):
                votes -= 1
    return int(np.sign(votes))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _decide_side(tree: _Tree, frac_a_left: float, hint: int, part: str,
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


def _up_axis(up: np.ndarray) -> str | None:
    k = int(np.argmax(np.abs(up)))
    if np.degrees(np.arccos(min(1.0, abs(float(up[k]))))) > UP_AXIS_TOLERANCE_DEG:
        return None
    return f"{'+' if up[k] > 0 else '-'}{'XYZ'[k]}"


def _limb_pairs(tree: _Tree) -> tuple[tuple, tuple]:
    """The legs' and the arms' twin pairs (size, joint, child a, child b, difference)."""
    names, pos = tree.names, tree.pos
    twins = _twins(tree)
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


def _neck_and_head(tree: _Tree, chest: int, arms: Sequence[int]) -> tuple[int, int]:
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


def _spine_marker(tree: _Tree, pelvis: int, chest: int, neck: int
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


def _standing_height(tree: _Tree, legs: Sequence[Leg], head: int, up: np.ndarray) -> float:
    """Head joint above the floor when standing: the head above the hip joints in upright
    frames (90th percentile along up) + straight legs + the ankles above the toes (median)."""
    pos = tree.pos
    mid_hip = 0.5 * (pos[:, legs[0].hip] + pos[:, legs[1].hip])
    trunk = float(np.nanpercentile(np.sum((pos[:, head] - mid_hip) * up, axis=-1), 90))
    legs_len = np.mean([tree.dist(g.hip, g.knee) + tree.dist(g.knee, g.ankle) for g in legs])
    ankle = float(np.nanmedian(np.concatenate(
        [np.sum((pos[:, g.ankle] - pos[:, g.toe]) * up, axis=-1) for g in legs])))
    return trunk + float(legs_len) + max(ankle, 0.0)


# ---------------------------------------------------------------------------- recognition
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
    tree = _Tree(names, parents, pos, source)
    if not len(bones):
        raise tree.error("skeleton", "the motion has no bones")
    notes: list[str] = []
    confidence: dict[str, float] = {}

    legs_t, arms_t = _limb_pairs(tree)
    pelvis, chest = legs_t[1], arms_t[1]
    confidence["twins"] = float(1.0 - (max(legs_t[4], arms_t[4]) / TWIN_TOLERANCE) ** 2)

    # ---- legs
    leg_chains, leg_k, margins = [], [], []
    for c in legs_t[2:4]:
        chain = _straight(tree, tree.chain(pelvis, c))
        k, margin = _limb(tree, chain, LEG_RATIO, "legs (hip, knee, ankle)")
        if k + 3 >= len(chain):
            raise tree.error("toe", f"nothing follows the ankle {names[chain[k + 2]]}")
        leg_chains.append(chain)
        leg_k.append(k)
        margins.append(margin)
    confidence["legs"] = float(min(margins))

    # ---- arms
    arm_chains, arm_k, margins = [], [], []
    for c in arms_t[2:4]:
        chain = _straight(tree, tree.chain(chest, c))
        k, margin = _limb(tree, chain, ARM_RATIO, "arms (shoulder, elbow, wrist)")
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

    neck, head = _neck_and_head(tree, chest, arms_t[2:4])

    # ---- up, forward, sides
    up_t = _unit(pos[:, neck] - 0.5 * (ankles[0] + ankles[1]))
    mean_up = np.nanmean(up_t, axis=0)
    confidence["up"] = float(np.linalg.norm(mean_up))
    up = _unit(mean_up)
    foot = (toes[0] - ankles[0]) + (toes[1] - ankles[1])
    forward = _unit(foot - np.sum(foot * up, axis=-1, keepdims=True) * up)
    left_t = np.cross(up, forward)
    frac = float(np.nanmean(np.sum((hips[0] - hips[1]) * left_t, axis=-1) > 0))
    leg_a_left, conf_legs = _decide_side(tree, frac, _side_hint(tree, *leg_chains), "legs",
                                         notes)
    lateral = (hips[0] - hips[1]) if leg_a_left else (hips[1] - hips[0])
    frac = float(np.nanmean(np.sum((shoulders[0] - shoulders[1]) * lateral, axis=-1) > 0))
    arm_a_left, conf_arms = _decide_side(tree, frac, _side_hint(tree, *arm_chains), "arms",
                                         notes)
    confidence["left/right"] = float(min(conf_legs, conf_arms))

    legs = []
    for chain, k, left in zip(leg_chains, leg_k, (leg_a_left, not leg_a_left), strict=True):
        legs.append(Leg("l" if left else "r", chain[k], chain[k + 1], chain[k + 2],
                        chain[k + 3]))
    arms = []
    for chain, k, left in zip(arm_chains, arm_k, (arm_a_left, not arm_a_left), strict=True):
        wrist, elbow = chain[k + 2], chain[k + 1]
        hand, note = _hand(tree, wrist, elbow)
        if note:
            notes.append(f"hand_{'l' if left else 'r'}: {note}")
        arms.append(Arm("l" if left else "r", chain[1] if k > 1 else None, chain[k],
                        elbow, wrist, hand))
    legs.sort(key=lambda leg: leg.side)
    arms.sort(key=lambda arm: arm.side)

    spine = _spine_marker(tree, pelvis, chest, neck)

    # ---- chest geometry: shoulder line and neck above the arm branch, along the trunk
    trunk_axis = _unit(pos[:, chest] - pos[:, pelvis])
    mid_sh = 0.5 * (shoulders[0] + shoulders[1])
    shoulder_h = float(np.nanmedian(np.sum((mid_sh - pos[:, chest]) * trunk_axis, axis=-1)))
    neck_h = float(np.nanmedian(np.sum((pos[:, neck] - pos[:, chest]) * trunk_axis, axis=-1)))

    height = _standing_height(tree, legs, head, up)

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
        up_axis=_up_axis(up),
        shoulder_height=shoulder_h, neck_height=neck_h, height=height,
        confidence={k: round(max(0.0, min(1.0, v)), 3) for k, v in confidence.items()},
        notes=tuple(notes), ignored=ignored)
    log.info("%s: human skeleton recognized (confidence %.2f): pelvis %s, arms from %s, head %s,"
             " up %s, standing height %.4g file units", source, result.overall_confidence,
             names[pelvis], names[chest], names[head], result.up_axis or "oblique", height)
    return result


def _hand(tree: _Tree, wrist: int, elbow: int) -> tuple[tuple[tuple[int, float], ...], str]:
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
        direction = _unit(tree.pos[:, wrist] - tree.pos[:, elbow])
        align = [float(np.nanmedian(np.sum(_unit(tree.pos[:, c] - tree.pos[:, wrist]) *
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
