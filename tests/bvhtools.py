"""Test helper: read a BVH into an editable tree, change it, write it back.

Used to make variants of real clips (renamed joints, other units, extra bones, missing parts)
without storing them. Only what the tests need: OFFSETs, channels and per-joint motion columns.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass
class Node:
    name: str
    offset: np.ndarray
    channels: list[str] = field(default_factory=list)
    children: list[Node] = field(default_factory=list)
    end_site: bool = False
    data: np.ndarray | None = None  # (T, len(channels))


@dataclass
class Bvh:
    roots: list[Node]
    frames: int
    frame_time: float

    def walk(self):
        stack = list(reversed(self.roots))
        while stack:
            node = stack.pop()
            yield node
            stack.extend(reversed(node.children))

    def find(self, name: str) -> Node:
        return next(n for n in self.walk() if n.name == name and not n.end_site)

    def parent_of(self, child: Node) -> Node | None:
        return next((n for n in self.walk() if any(c is child for c in n.children)), None)


def read(path: str | Path) -> Bvh:
    text = Path(path).read_text()
    head, motion = re.split(r"^\s*MOTION\s*$", text, maxsplit=1, flags=re.M)
    tokens = re.findall(r"[{}]|[^\s{}]+", head)
    i = 1  # after HIERARCHY
    roots: list[Node] = []
    order: list[Node] = []

    def node(end_site: bool) -> Node:
        nonlocal i
        if end_site:
            i += 1  # "Site"
            name = ""
        else:
            name = tokens[i]
            i += 1
        assert tokens[i] == "{"
        i += 1
        n = Node(name=name, offset=np.zeros(3), end_site=end_site)
        order.append(n)
        while tokens[i] != "}":
            key = tokens[i].upper()
            if key == "OFFSET":
                n.offset = np.array([float(t) for t in tokens[i + 1:i + 4]])
                i += 4
            elif key == "CHANNELS":
                count = int(tokens[i + 1])
                n.channels = tokens[i + 2:i + 2 + count]
                i += 2 + count
            elif key == "JOINT":
                i += 1
                n.children.append(node(False))
            elif key == "END":
                i += 1
                n.children.append(node(True))
            else:
                raise ValueError(tokens[i])
        i += 1
        return n

    while i < len(tokens):
        assert tokens[i].upper() == "ROOT"
        i += 1
        roots.append(node(False))
    frames = int(re.search(r"Frames:\s*(\d+)", motion).group(1))
    frame_time = float(re.search(r"Frame Time:\s*(\S+)", motion).group(1))
    body = motion[re.search(r"Frame Time:\s*\S+", motion).end():]
    values = np.array(body.split(), dtype=float).reshape(frames, -1)
    col = 0
    for n in order:
        n.data = values[:, col:col + len(n.channels)]
        col += len(n.channels)
    return Bvh(roots=roots, frames=frames, frame_time=frame_time)


def write(bvh: Bvh, path: str | Path) -> Path:
    lines = ["HIERARCHY"]

    def emit(n: Node, depth: int, root: bool) -> None:
        pad = "  " * depth
        kind = "End Site" if n.end_site else ("ROOT " if root else "JOINT ") + n.name
        lines.append(f"{pad}{kind}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {' '.join(f'{v:.17g}' for v in n.offset)}")
        if not n.end_site:
            lines.append(f"{pad}  CHANNELS {len(n.channels)} {' '.join(n.channels)}".rstrip())
        for c in n.children:
            emit(c, depth + 1, False)
        lines.append(f"{pad}}}")

    for r in bvh.roots:
        emit(r, 0, True)
    cols = [n.data for n in bvh.walk() if not n.end_site and len(n.channels)]
    data = np.concatenate(cols, axis=1)
    lines += ["MOTION", f"Frames: {bvh.frames}", f"Frame Time: {bvh.frame_time:.9g}"]
    lines += [" ".join(f"{v:.17g}" for v in row) for row in data]
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)


def scale(bvh: Bvh, factor: float) -> Bvh:
    """All lengths (OFFSETs and position channels) times ``factor``."""
    for n in bvh.walk():
        n.offset = n.offset * factor
        if n.data is not None:
            pos = [k for k, c in enumerate(n.channels) if c.lower().endswith("position")]
            n.data = n.data.copy()
            n.data[:, pos] *= factor
    return bvh


def rename(bvh: Bvh, new_name) -> dict[str, str]:
    """Rename every joint with ``new_name(old)``; returns old -> new."""
    mapping = {}
    for n in bvh.walk():
        if not n.end_site:
            mapping[n.name] = new_name(n.name)
            n.name = mapping[n.name]
    return mapping


def add_child(bvh: Bvh, parent: Node, name: str, offset, rotate_deg: float = 0.0,
              rng: np.random.Generator | None = None, end: tuple | None = None) -> Node:
    """A joint under ``parent``: rigid (no channels) or rotating by random angles up to
    ``rotate_deg``; optionally with an End Site at ``end``."""
    n = Node(name=name, offset=np.asarray(offset, float))
    if rotate_deg:
        n.channels = ["Zrotation", "Xrotation", "Yrotation"]
        n.data = rng.uniform(-rotate_deg, rotate_deg, size=(bvh.frames, 3))
    else:
        n.data = np.zeros((bvh.frames, 0))
    if end is not None:
        n.children.append(Node(name="", offset=np.asarray(end, float), end_site=True))
    parent.children.append(n)
    return n


def split_bone(bvh: Bvh, child: Node, name: str, at: float = 0.5) -> Node:
    """A rigid joint inside the bone parent -> ``child`` (a twist joint in the chain)."""
    parent = bvh.parent_of(child)
    mid = Node(name=name, offset=child.offset * at, data=np.zeros((bvh.frames, 0)))
    child.offset = child.offset * (1 - at)
    for k, c in enumerate(child.channels):  # position channels replace the OFFSET: shorten them
        if c.lower().endswith("position"):
            child.data = child.data.copy()
            child.data[:, k] -= mid.offset["xyz".index(c[0].lower())]
    parent.children[[c is child for c in parent.children].index(True)] = mid
    mid.children.append(child)
    return mid


def remove(bvh: Bvh, node: Node) -> None:
    parent = bvh.parent_of(node)
    parent.children = [c for c in parent.children if c is not node]
