"""BVH (Biovision Hierarchy) reader: joint and end-site positions by forward kinematics.

Conventions implemented (checked on the CMU cgspeed, CC3, Second Life and ReActIdle rigs):

* Rotation channels are composed in the order they are listed (intrinsic):
  ``Zrotation Yrotation Xrotation`` gives ``R = Rz @ Ry @ Rx``; any order and any subset of the
  three axes is accepted, per joint (the Second Life rig uses ZXY on non-root joints, ReActIdle
  XYZ and YXZ).
* The root's position channels are added to its OFFSET (some libraries drop the OFFSET, which
  puts e.g. ReActIdle 0.66 m into the floor).
* Position channels on a **non-root** joint hold its full local translation and REPLACE its
  OFFSET (ReActIdle and Blender exports: the channel values equal the OFFSET up to small
  animation). Components without a channel keep the OFFSET value.
* Every End Site becomes a point named ``<parent>_end`` (``_end2`` ... if a joint has several).
* Positions stay in the file's units and axes; :func:`imesh.io.finalize` settles units
  (``declared_units`` is None: BVH has no unit field) and up axis (``declared_up="+Y"``, the
  BVH world convention).
"""

from __future__ import annotations

import io
import logging
import re
import sys
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import MotionFileError
from ..human.rig_tables import rig_of
from .raw import RawMotion, is_float
from .skeleton import euler_to_matrix, forward_kinematics

log = logging.getLogger(__name__)

__all__ = ["read_bvh", "VALID_CHANNELS"]

VALID_CHANNELS = ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation")
_CANONICAL = {c.lower(): c for c in VALID_CHANNELS}

_TOKEN = re.compile(r"[{}]|[^\s{}]+")

#: OFFSET grid of the rescaled Second Life clips: 0.1 inch (the SL skeleton is in inches with
#: one decimal) x 0.01905 (the uploader's factor, 0.75 x 0.0254): one file unit is 4/3 m.
SL_SCALED_GRID = 0.001905
SL_SCALED_UNIT_M = 0.0254 / SL_SCALED_GRID * 0.1


@dataclass
class _Node:
    name: str
    parent: int
    line: int
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    channels: list[str] = field(default_factory=list)
    end_site: bool = False


class _HierarchyParser:
    """Recursive-descent parser over (token, line) pairs of the HIERARCHY section."""

    def __init__(self, path: str, tokens: list[tuple[str, int]], end_line: int):
        self.path = path
        self.tokens = tokens
        self.i = 0
        self.end_line = end_line
        self.nodes: list[_Node] = []

    def error(self, message: str, line: int | None = None) -> MotionFileError:
        if line is None:
            line = self.tokens[self.i][1] if self.i < len(self.tokens) else self.end_line
        return MotionFileError(self.path, f"malformed HIERARCHY: {message}", line=line)

    def peek(self) -> str | None:
        return self.tokens[self.i][0] if self.i < len(self.tokens) else None

    def take(self, what: str) -> tuple[str, int]:
        if self.i >= len(self.tokens):
            raise self.error(f"file ends (MOTION reached) while expecting {what}")
        tok = self.tokens[self.i]
        self.i += 1
        return tok

    def expect(self, word: str) -> int:
        tok, line = self.take(repr(word))
        if tok.lower() != word.lower():
            raise self.error(f"expected {word!r}, found {tok!r}", line)
        return line

    def number(self, what: str) -> float:
        tok, line = self.take(what)
        try:
            value = float(tok)
        except ValueError:
            raise self.error(f"expected a number for {what}, found {tok!r}", line) from None
        if not np.isfinite(value):
            raise self.error(f"non-finite {what} {tok!r}", line)
        return value

    def parse(self) -> list[_Node]:
        if not self.tokens or self.tokens[0][0].upper() != "HIERARCHY":
            found = self.tokens[0][0] if self.tokens else "nothing"
            raise self.error(f"a BVH file starts with 'HIERARCHY', found {found!r}",
                             self.tokens[0][1] if self.tokens else 1)
        self.i = 1
        while self.i < len(self.tokens):
            tok, line = self.take("ROOT")
            if tok.upper() != "ROOT":
                raise self.error(f"expected 'ROOT', found {tok!r}", line)
            self.joint(parent=-1, line=line)
        if not self.nodes:
            raise self.error("no ROOT joint", self.end_line)
        return self.nodes

    def joint(self, parent: int, line: int, end_site: bool = False) -> None:
        if end_site:
            tok, tline = self.take("'Site'")
            if tok.lower() != "site":
                raise self.error(f"expected 'End Site', found 'End {tok}'", tline)
            name_parts: list[str] = []
            while self.peek() not in (None, "{"):  # tolerate "End Site name {"
                name_parts.append(self.take("'{'")[0])
            name = ""
        else:
            name_parts = []
            while self.peek() not in (None, "{", "}"):
                name_parts.append(self.take("'{'")[0])
            if not name_parts:
                raise self.error("joint without a name", line)
            name = " ".join(name_parts)
        self.expect("{")
        node = _Node(name=name, parent=parent, line=line, end_site=end_site)
        index = len(self.nodes)
        self.nodes.append(node)
        seen_offset = False
        label = f"End Site of {self.nodes[parent].name}" if end_site else f"joint {name}"
        while True:
            tok, tline = self.take(f"'}}' closing {label}")
            key = tok.upper()
            if key == "}":
                break
            if key == "OFFSET":
                node.offset = np.array([self.number(f"OFFSET of {label}") for _ in range(3)])
                seen_offset = True
            elif key == "CHANNELS":
                if end_site:
                    raise self.error(f"{label} cannot have CHANNELS", tline)
                count_tok, cline = self.take("channel count")
                try:
                    count = int(count_tok)
                except ValueError:
                    raise self.error(f"expected a channel count, found {count_tok!r}",
                                     cline) from None
                if count < 0:
                    raise self.error(f"negative channel count {count}", cline)
                for _ in range(count):
                    ch, chline = self.take(f"channel name of {label}")
                    canon = _CANONICAL.get(ch.lower())
                    if canon is None:
                        raise MotionFileError(
                            self.path, f"unknown channel name {ch!r} in {label}; valid channel "
                            f"names: {' '.join(VALID_CHANNELS)}", line=chline)
                    if canon in node.channels:
                        raise self.error(f"channel {canon} repeated in {label}", chline)
                    node.channels.append(canon)
            elif key == "JOINT":
                if end_site:
                    raise self.error(f"{label} cannot have child joints", tline)
                self.joint(parent=index, line=tline)
            elif key == "END":
                if end_site:
                    raise self.error(f"{label} cannot have an End Site", tline)
                self.joint(parent=index, line=tline, end_site=True)
            else:
                raise self.error(f"unexpected {tok!r} in {label} (expected OFFSET, CHANNELS, "
                                 "JOINT, End Site or '}')", tline)
        if not seen_offset:
            raise self.error(f"{label} has no OFFSET", line)


def _line_of_token(text: str, k: int, first_line: int) -> int:
    """1-based line number of the k-th whitespace-separated token of ``text`` (error path)."""
    for idx, m in enumerate(re.finditer(r"\S+", text)):
        if idx == k:
            return first_line + text.count("\n", 0, m.start())
    return first_line + text.count("\n")


def _unique_names(nodes: list[_Node]) -> list[str]:
    names: list[str] = []
    used: set[str] = set()
    for node in nodes:
        base = f"{nodes[node.parent].name}_end" if node.end_site else node.name
        name, k = base, 2
        while name in used:
            name = f"{base}{k}"
            k += 1
        if name != base and not node.end_site:
            log.warning("duplicate joint name %r renamed %r", base, name)
        used.add(name)
        node.name = name
        names.append(name)
    return names


def read_bvh(path: str | Path) -> RawMotion:
    """Read a BVH file: positions of every joint and End Site for every frame.

    Args:
        path: the .bvh file.

    Returns:
        RawMotion with ``positions`` (T, J, 3) in file units and file axes (BVH world: +Y up),
        ``names`` joint names then ``<parent>_end`` for End Sites (in hierarchy order),
        ``bones`` (parent, child) pairs of the hierarchy including End Sites,
        ``fps = 1 / Frame Time``, ``rig`` detected from the joint names and ``meta`` with
        ``frame_time``, ``channels`` and ``position_channel_joints`` (non-root joints whose
        position channels replace their OFFSET, hence whose bone length may vary).

    Raises:
        MotionFileError: malformed hierarchy, unknown channel name, missing ``Frames`` or
            ``Frame Time``, empty MOTION block, truncated data or non-finite values; the message
            names the file and the line (and frame) of the problem.
    """
    p = str(path)
    try:
        streamed = _read_streamed(p, path)
    except OSError as exc:
        raise MotionFileError(p, f"cannot read file: {exc.strerror or exc}") from None
    if streamed is not None:
        return streamed
    try:
        raw_bytes = Path(path).read_bytes()
    except OSError as exc:
        raise MotionFileError(p, f"cannot read file: {exc.strerror or exc}") from None
    text = raw_bytes.decode("utf-8", errors="replace")

    m = re.search(r"^[ \t]*MOTION\b", text, flags=re.MULTILINE | re.IGNORECASE)
    n_lines = text.count("\n") + 1
    if m is None:
        raise MotionFileError(p, "no MOTION section (is this a BVH file?)", line=n_lines)
    motion_line = text.count("\n", 0, m.start()) + 1

    tokens = [(tok, i) for i, ln in enumerate(text[: m.start()].splitlines(), 1)
              for tok in _TOKEN.findall(ln)]
    try:
        nodes = _HierarchyParser(p, tokens, motion_line).parse()
    except RecursionError:
        raise MotionFileError(p, "malformed HIERARCHY: joints nested too deeply (more than "
                              f"{sys.getrecursionlimit() // 2} levels)") from None

    # ------------------------------------------------------------------ MOTION header
    rest = text[m.end():]
    rest_line = motion_line  # line of the first character of `rest`
    mf = re.match(r"\s*Frames\s*:[ \t]*(\S*)", rest, flags=re.IGNORECASE)
    if mf is None:
        raise MotionFileError(p, "expected 'Frames: <count>' after MOTION", line=motion_line + 1)
    frames_line = rest_line + rest.count("\n", 0, mf.start(1))
    try:
        n_frames = int(mf.group(1))
    except ValueError:
        raise MotionFileError(p, f"bad frame count {mf.group(1)!r} (expected 'Frames: <count>')",
                              line=frames_line) from None
    if n_frames <= 0:
        raise MotionFileError(p, f"empty MOTION block (Frames: {n_frames}): no frames to read",
                              line=frames_line)
    mt = re.match(r"\s*Frame\s+Time\s*:[ \t]*(\S*)", rest[mf.end():], flags=re.IGNORECASE)
    if mt is None:
        raise MotionFileError(p, "missing 'Frame Time: <seconds>' after 'Frames:'",
                              line=frames_line + 1)
    ft_line = rest_line + rest.count("\n", 0, mf.end() + mt.start(1))
    try:
        frame_time = float(mt.group(1))
    except ValueError:
        frame_time = float("nan")
    if not (np.isfinite(frame_time) and frame_time > 0):
        raise MotionFileError(p, f"bad Frame Time {mt.group(1)!r} (expected a positive number "
                              "of seconds)", line=ft_line)
    data = rest[mf.end() + mt.end():]
    data_line = rest_line + rest.count("\n", 0, mf.end() + mt.end())

    # ------------------------------------------------------------------ channel table
    names = _unique_names(nodes)
    chan_start = np.zeros(len(nodes), dtype=np.int64)
    n_chan = 0
    for j, node in enumerate(nodes):
        chan_start[j] = n_chan
        n_chan += len(node.channels)
    chan_label = [f"{node.name}.{c}" for node in nodes for c in node.channels]

    # ------------------------------------------------------------------ frame data
    words = data.split()
    needed = n_frames * n_chan
    if len(words) < needed:
        complete = len(words) // n_chan if n_chan else 0
        raise MotionFileError(
            p, f"truncated: {n_frames} frames x {n_chan} channels = {needed} numbers declared, "
            f"the file holds {len(words)}; only {complete} complete frames",
            line=data_line + data.rstrip().count("\n"), frame=complete)
    if len(words) > needed:
        log.warning("%s: %d numbers after the last of %d frames ignored", p, len(words) - needed,
                    n_frames)
        words = words[:needed]
    try:
        values = np.array(words, dtype=np.float64)
    except ValueError:
        k = next(i for i, w in enumerate(words) if not is_float(w))  # error path only
        raise MotionFileError(
            p, f"bad number {words[k]!r} in channel {chan_label[k % n_chan]}",
            line=_line_of_token(data, k, data_line), frame=k // n_chan) from None
    values = values.reshape(n_frames, n_chan)
    finite = np.isfinite(values)
    if not finite.all():
        t, c = (int(i[0]) for i in np.nonzero(~finite))
        k = t * n_chan + c
        raise MotionFileError(
            p, f"non-finite value {words[k]!r} in channel {chan_label[c]} (joint "
            f"{chan_label[c].rsplit('.', 1)[0]}); {int((~finite).sum())} non-finite values in all",
            line=_line_of_token(data, k, data_line), frame=t)

    # ------------------------------------------------------------------ forward kinematics
    positions, replaced, orders = _positions(nodes, names, chan_start, values)

    return _raw_motion(p, nodes, names, n_chan, frame_time, positions, replaced, orders)


def _raw_motion(p: str, nodes: list[_Node], names: list[str], n_chan: int, frame_time: float,
                positions: np.ndarray, replaced: list[str], orders: dict) -> RawMotion:
    n_frames, n_nodes = positions.shape[:2]
    bones = np.array([(n.parent, j) for j, n in enumerate(nodes) if n.parent >= 0],
                     dtype=np.int64).reshape(-1, 2)
    rig = rig_of(names)
    hint = _unit_hint(nodes)
    n_end = sum(n.end_site for n in nodes)
    fps = 1.0 / frame_time
    if replaced:
        log.info("%s: position channels of %d non-root joints replace their OFFSET (%s)", p,
                 len(replaced), ", ".join(replaced[:6]) + (" ..." if len(replaced) > 6 else ""))
    log.info("%s: %d frames at %.4g fps, %d joints + %d end sites, %d channels, rotation orders "
             "%s, rig %s", p, n_frames, fps, n_nodes - n_end, n_end, n_chan, orders, rig or "?")
    return RawMotion(
        positions=positions, fps=fps, names=tuple(names),
        valid=np.ones((n_frames, n_nodes), dtype=bool), path=p, format="bvh", bones=bones,
        declared_units=None, declared_scale_m=None, declared_up="+Y", rig=rig,
        meta={"frame_time": frame_time, "channels": n_chan, "joints": n_nodes - n_end,
              "end_sites": n_end, "rotation_orders": orders,
              "position_channel_joints": tuple(replaced), **hint},
    )


def _positions(nodes: list[_Node], names: list[str], chan_start: np.ndarray,
               values: np.ndarray) -> tuple[np.ndarray, list[str], dict[str, int]]:
    """World positions (T, J, 3) of every node from the channel values (T, C) by forward
    kinematics; also the non-root joints whose position channels replace their OFFSET and the
    count of joints per rotation order."""
    n_frames = len(values)
    parents = np.array([n.parent for n in nodes], dtype=np.int64)
    n_nodes = len(nodes)
    offsets = np.broadcast_to(np.stack([n.offset for n in nodes]), (n_frames, n_nodes, 3)).copy()
    rotations = np.broadcast_to(np.eye(3), (n_frames, n_nodes, 3, 3)).copy()
    replaced: list[str] = []
    orders: dict[str, int] = {}
    for j, node in enumerate(nodes):
        cols = {c: chan_start[j] + i for i, c in enumerate(node.channels)}
        rot_axes = "".join(c[0] for c in node.channels if c.endswith("rotation"))
        if rot_axes:
            idx = [cols[f"{a}rotation"] for a in rot_axes]
            rotations[:, j] = euler_to_matrix(np.deg2rad(values[:, idx]), rot_axes)
            orders[rot_axes] = orders.get(rot_axes, 0) + 1
        for axis, a in (("X", 0), ("Y", 1), ("Z", 2)):
            c = cols.get(f"{axis}position")
            if c is None:
                continue
            if node.parent < 0:
                offsets[:, j, a] += values[:, c]  # root: OFFSET + channel
            else:
                offsets[:, j, a] = values[:, c]   # non-root: channel replaces OFFSET
        if node.parent >= 0 and any(c.endswith("position") for c in node.channels):
            replaced.append(names[j])
    positions, _ = forward_kinematics(parents, offsets, rotations)
    return positions, replaced, orders


#: End of the header: MOTION, ``Frames: N`` and ``Frame Time: s`` on their own lines.
_HEAD_END = re.compile(rb"^[ \t]*MOTION[ \t]*\r?\n\s*Frames[ \t]*:[ \t]*\S+[ \t]*\r?\n"
                       rb"\s*Frame[ \t]+Time[ \t]*:[ \t]*\S+[ \t]*\r?\n",
                       flags=re.MULTILINE | re.IGNORECASE)
#: Frames parsed and put through forward kinematics at a time by the streamed reader.
STREAM_FRAMES = 8192


def _read_streamed(p: str, path) -> RawMotion | None:
    """The reader for well-formed files of one frame per line, in bounded memory: the frame
    lines are parsed and put through forward kinematics :data:`STREAM_FRAMES` at a time, so a
    file is never held whole (a 30-minute 120 Hz clip is 200 MB of text; held whole with its
    words, channel values and rotations it took 4 GB). Returns None for anything unusual (a
    malformed header, a bad number, a line that is not one frame, a count that differs): the
    full parser then reads the file and names the problem."""
    with open(path, "rb") as f:
        head = b""
        m = None
        while m is None and len(head) < (64 << 20):
            block = f.read(1 << 20)
            if not block:
                break
            head += block
            m = _HEAD_END.search(head)
        if m is None:
            return None
        text = head[:m.end()].decode("utf-8", errors="replace")
        mm = re.search(r"^[ \t]*MOTION\b", text, flags=re.MULTILINE | re.IGNORECASE)
        assert mm is not None  # the header's end _HEAD_END matched starts with a MOTION line
        tail = text[mm.end():].split()
        try:
            n_frames, frame_time = int(tail[1]), float(tail[-1])
        except (ValueError, IndexError):
            return None
        if n_frames <= 0 or not (np.isfinite(frame_time) and frame_time > 0):
            return None
        motion_line = text.count("\n", 0, mm.start()) + 1
        tokens = [(tok, i) for i, ln in enumerate(text[:mm.start()].splitlines(), 1)
                  for tok in _TOKEN.findall(ln)]
        try:
            nodes = _HierarchyParser(p, tokens, motion_line).parse()
        except (MotionFileError, RecursionError):
            return None
        names = _unique_names(nodes)
        chan_start = np.cumsum([0] + [len(n.channels) for n in nodes])[:-1].astype(np.int64)
        n_chan = sum(len(n.channels) for n in nodes)
        if n_chan == 0:
            return None
        positions = np.empty((n_frames, len(nodes), 3))
        replaced: list[str] = []
        orders: dict[str, int] = {}
        done = 0
        rest = head[m.end():]
        eof = False
        while not eof:
            while rest.count(b"\n") < STREAM_FRAMES and not eof:
                block = f.read(1 << 22)
                eof = not block
                rest += block
            cut = len(rest) if eof else rest.rindex(b"\n") + 1
            chunk, rest = rest[:cut], rest[cut:]
            if not chunk.strip():
                continue
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("error")
                    values = np.loadtxt(io.BytesIO(chunk), dtype=np.float64, comments=None,
                                        ndmin=2)
            except ValueError:
                return None
            if values.shape[1] != n_chan or done + len(values) > n_frames \
                    or not np.isfinite(values).all():
                return None
            pos, replaced, orders = _positions(nodes, names, chan_start, values)
            positions[done:done + len(values)] = pos
            done += len(values)
    if done != n_frames:
        return None
    return _raw_motion(p, nodes, names, n_chan, frame_time, positions, replaced, orders)


def _unit_hint(nodes: list[_Node]) -> dict:
    """``unit_hint_m`` / ``unit_hint_reason`` for rescaled Second Life files, else {}.

    A skeleton whose non-zero OFFSET components mostly (>= 25 %; finger offsets are off-grid)
    sit on the 0.001905 grid was scaled from one-decimal inches (the Second Life skeleton) by
    0.01905: 4/3 m per file unit. The test looks at the numbers only, not at the joint names,
    so a renamed skeleton gets the same hint. The hint is informative only: unit detection
    (imesh.io.units) decides.
    """
    vals = np.concatenate([n.offset for n in nodes])
    vals = vals[np.abs(vals) > 1e-9]
    q = vals / SL_SCALED_GRID
    on_grid = float(np.mean(np.abs(q - np.round(q)) < 1e-3)) if vals.size else 0.0
    if vals.size < 20 or on_grid < 0.25:
        return {}
    reason = (f"{100 * on_grid:.0f} % of the OFFSETs are multiples of {SL_SCALED_GRID} = 0.1 inch "
              f"x 0.01905: Second Life inches scaled by 0.75 x 0.0254, so 1 unit = "
              f"{SL_SCALED_UNIT_M:.4f} m")
    log.info("unit hint: %s", reason)
    return {"unit_hint_m": SL_SCALED_UNIT_M, "unit_hint_reason": reason}
