"""Body geometry for rig recognition: unit directions, the file axis along body up, the
left/right hint of joint names, and the standing height.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .rig_result import Leg
from .rig_tree import RigTree

#: Body up is an axis of the file when within this angle of it [deg].
UP_AXIS_TOLERANCE_DEG = 30.0

#: Name parts (left, right) that tell a left/right pair of joint names apart.
_SIDE_WORDS = {("l", "r"): 1, ("left", "right"): 1, ("lft", "rgt"): 1, ("lt", "rt"): 1}


def unit(v: np.ndarray) -> np.ndarray:
    """``v`` divided by its norm along the last axis (zero vectors stay near zero)."""
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def up_axis(up: np.ndarray) -> str | None:
    """The file axis ("+Y", "-Z", ...) within UP_AXIS_TOLERANCE_DEG of ``up``, else None."""
    k = int(np.argmax(np.abs(up)))
    if np.degrees(np.arccos(min(1.0, abs(float(up[k]))))) > UP_AXIS_TOLERANCE_DEG:
        return None
    return f"{'+' if up[k] > 0 else '-'}{'XYZ'[k]}"


def side_hint(tree: RigTree, chain_a: list[int], chain_b: list[int]) -> int:
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


def standing_height(tree: RigTree, legs: Sequence[Leg], head: int, up: np.ndarray) -> float:
    """Head joint above the floor when standing: the head above the hip joints in upright
    frames (90th percentile along up) + straight legs + the ankles above the toes (median)."""
    pos = tree.pos
    mid_hip = 0.5 * (pos[:, legs[0].hip] + pos[:, legs[1].hip])
    trunk = float(np.nanpercentile(np.sum((pos[:, head] - mid_hip) * up, axis=-1), 90))
    legs_len = np.mean([tree.dist(g.hip, g.knee) + tree.dist(g.knee, g.ankle) for g in legs])
    ankle = float(np.nanmedian(np.concatenate(
        [np.sum((pos[:, g.ankle] - pos[:, g.toe]) * up, axis=-1) for g in legs])))
    return trunk + float(legs_len) + max(ankle, 0.0)
