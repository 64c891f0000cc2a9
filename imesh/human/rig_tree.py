"""The skeleton tree that rig recognition walks: bone lengths, coincident joints merged, each
joint's reach and main chain; and the tree as indented text for messages.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .errors import RigRecognitionError


class RigTree:
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
        """``j`` and its ancestors up to the root, nearest first."""
        out = []
        while j >= 0:
            out.append(int(j))
            j = self.parents[j]
        return out

    def dist(self, a: int, b: int) -> float:
        """Distance between joints ``a`` and ``b``, median over frames."""
        return float(np.nanmedian(np.linalg.norm(self.pos[:, a] - self.pos[:, b], axis=-1)))

    def error(self, part: str, reason: str) -> RigRecognitionError:
        """The error for a body part not found, with the skeleton tree printed."""
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
