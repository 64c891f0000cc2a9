"""C3D reader (marker trajectories): a bounds-checked numpy parser of the C3D format.

Only 3-D points are read; analog channels and force plates are ignored. Points that the file lists
as computed quantities (``POINT:ANGLES``, ``FORCES``, ``MOMENTS``, ``POWERS``, ``SCALARS``,
``REACTIONS``: Vicon model outputs stored as points) are dropped, because they are not positions.

A sample is missing when its residual is negative (the C3D convention), when any coordinate is
not finite, or when it is exactly (0, 0, 0): many writers store gaps as zeros.

The parser reads Intel, DEC and MIPS files with integer or float data (C3D User Guide: a 512-byte
header block, parameter blocks of group/parameter records, then frames of 4 words per point
followed by the analog samples). Every count and offset is checked against the file's size
before it is used, so a corrupt file raises :class:`~imesh.errors.MotionFileError`; it does not
crash, hang or allocate more than the file holds (ezc3d, used before, crashed on corrupt files).
"""

from __future__ import annotations

import logging
import math
import os
from pathlib import Path

import numpy as np

from ..errors import MotionFileError
from ..human.rig_tables import rig_of
from .raw import RawMotion
from .units import UP_AXES, _frame_extents

log = logging.getLogger(__name__)

#: Unit spellings found in POINT:UNITS -> imesh unit names.
_UNIT_ALIASES: dict[str, str] = {
    "mm": "mm", "millimeter": "mm", "millimeters": "mm", "millimetre": "mm", "millimetres": "mm",
    "cm": "cm", "centimeter": "cm", "centimeters": "cm", "centimetre": "cm", "centimetres": "cm",
    "m": "m", "meter": "m", "meters": "m", "metre": "m", "metres": "m",
    "in": "in", "inch": "in", "inches": "in",
}

#: POINT parameters listing labels of points that are not marker positions.
_NON_MARKER_GROUPS = ("ANGLES", "FORCES", "MOMENTS", "POWERS", "SCALARS", "REACTIONS")


def normalize_unit(text: str | None) -> str | None:
    """imesh unit name ("mm", "cm", "m", "in") for a unit spelling, or None if unknown."""
    if text is None:
        return None
    return _UNIT_ALIASES.get(str(text).strip().lower())


def unique_names(raw_names: list[str], n: int, prefix: str = "M") -> tuple[str, ...]:
    """``n`` unique, stripped names: blanks become ``M001``..., duplicates get ``_2``, ``_3``."""
    names = [str(s).strip() for s in raw_names[:n]]
    names += [""] * (n - len(names))
    names = [s if s else f"{prefix}{i + 1:03d}" for i, s in enumerate(names)]
    seen: dict[str, int] = {}
    out = []
    taken = set(names)
    for s in names:
        if s in seen:
            k = seen[s] + 1
            while f"{s}_{k}" in taken:
                k += 1
            seen[s] = k
            new = f"{s}_{k}"
            taken.add(new)
            log.warning("duplicate marker name %r renamed to %r", s, new)
            out.append(new)
        else:
            seen[s] = 1
            out.append(s)
    return tuple(out)


def _param(params: dict, group: str, name: str):
    """Value of parameter GROUP:NAME (a list of str or a 1-D array), or None."""
    return params.get(group, {}).get(name)


def _first_str(value) -> str | None:
    if value is None or len(value) == 0:
        return None
    return str(value[0]).strip()


def _point_labels(params: dict, n: int) -> list[str]:
    """POINT:LABELS followed by LABELS2, LABELS3, ... (files with more than 255 points)."""
    first = _param(params, "POINT", "LABELS")
    labels = list(first) if isinstance(first, list) else []
    k = 2
    while len(labels) < n:
        more = _param(params, "POINT", f"LABELS{k}")
        if not isinstance(more, list) or not more:
            break
        labels += list(more)
        k += 1
    return labels


def screen_up_axis(y_screen: str | None, positions: np.ndarray, valid: np.ndarray
                   ) -> tuple[str | None, str]:
    """Up axis implied by POINT:Y_SCREEN, checked against the data.

    The axis letter is taken from Y_SCREEN when the markers' median per-frame extent along it is
    at least half the largest one (a standing body is tallest along the vertical); otherwise the
    declaration is ignored. The sign is the declared one unless the markers lie on the other side
    of the origin (a lab floor is at 0 with the body above it): some writers (e.g. Qualisys
    exports) state "-Z" for Z-up data.

    Args:
        y_screen: the parameter value (e.g. "+Z"), or None.
        positions: (T, M, 3) file-unit positions, NaN where missing.
        valid: (T, M) bool.

    Returns:
        (up axis or None, reason).
    """
    if y_screen is None:
        return None, "no POINT:Y_SCREEN"
    text = y_screen.strip().upper()
    if len(text) == 1:
        text = "+" + text
    if text not in UP_AXES:
        return None, f"POINT:Y_SCREEN {y_screen!r} is not an axis"
    axis = "XYZ".index(text[1])
    ext = _frame_extents(positions, valid)
    if not np.isfinite(ext).any():
        return text, f"POINT:Y_SCREEN {text} (too few valid markers to check)"
    med = np.nanmedian(ext, axis=0)
    if not med[axis] >= 0.5 * np.nanmax(med):
        log.warning("POINT:Y_SCREEN %s ignored: median extent along %s is %.4g file units, the "
                    "largest is %.4g", text, text[1], med[axis], np.nanmax(med))
        return None, f"POINT:Y_SCREEN {text} contradicted by the marker extents"
    coord = positions[..., axis][valid]
    median = float(np.median(coord)) if coord.size else 0.0
    sign = text[0]
    if (median < 0) != (sign == "-") and median != 0:
        flipped = ("-" if sign == "+" else "+") + text[1]
        log.info("POINT:Y_SCREEN says %s but the markers lie at median %s = %.4g: using %s",
                 text, text[1], median, flipped)
        return flipped, f"POINT:Y_SCREEN axis {text[1]}, sign from the marker side of the origin"
    return text, f"POINT:Y_SCREEN {text}"


# ---------------------------------------------------------------------------------------------
# the C3D file format

_BLOCK = 512
_INTEL, _DEC, _MIPS = 84, 85, 86


class _Bytes:
    """Typed reads from the file's bytes in the processor's formats, bounds-checked."""

    def __init__(self, path: str, data: bytes, processor: int):
        self.path = path
        self.data = data
        self.processor = processor
        self.big = processor == _MIPS

    def need(self, offset: int, size: int, what: str) -> None:
        if offset < 0 or size < 0 or offset + size > len(self.data):
            raise MotionFileError(self.path, f"truncated or corrupt: {what} at byte {offset} "
                                  f"({size} bytes) lies beyond the end of the file "
                                  f"({len(self.data)} bytes)")

    def ints(self, offset: int, count: int, what: str) -> np.ndarray:
        self.need(offset, 2 * count, what)
        return np.frombuffer(self.data, ">i2" if self.big else "<i2", count, offset)

    def floats(self, offset: int, count: int, what: str) -> np.ndarray:
        self.need(offset, 4 * count, what)
        return self.decode_floats(self.data, offset, count)

    def decode_floats(self, data: bytes, offset: int, count: int) -> np.ndarray:
        with np.errstate(invalid="ignore", over="ignore"):  # NaN payloads of corrupt files
            if self.processor == _DEC:  # VAX F-float: swap the 16-bit halves, IEEE value / 4
                words = np.frombuffer(data, "<u2", 2 * count, offset).reshape(-1, 2)[:, ::-1]
                return np.ascontiguousarray(words).view("<f4").reshape(-1).astype(
                    np.float64) / 4
            return np.frombuffer(data, ">f4" if self.big else "<f4", count, offset).astype(
                np.float64)


def _int8(byte: int) -> int:
    return byte - 256 if byte > 127 else byte


def _parse_parameters(buf: _Bytes, start: int) -> dict[str, dict[str, object]]:
    """GROUP -> NAME -> value (list of str for characters, else a 1-D array) of the parameter
    section starting at byte ``start``."""
    data = buf.data
    groups: dict[int, str] = {}
    found: list[tuple[int, str, object]] = []
    pos = start + 4
    while pos + 2 <= len(data):
        n_name = abs(_int8(data[pos]))
        gid = _int8(data[pos + 1])
        if n_name == 0:
            break
        name = data[pos + 2:pos + 2 + n_name].decode("latin-1").strip().upper()
        link = pos + 2 + n_name
        offset = int(buf.ints(link, 1, f"parameter record {name!r}")[0])
        body = link + 2
        if gid < 0:
            groups[-gid] = name
        elif gid > 0:
            buf.need(body, 2, f"parameter {name!r}")
            code = _int8(data[body])
            n_dim = data[body + 1]
            buf.need(body + 2, n_dim, f"dimensions of parameter {name!r}")
            dims = list(data[body + 2:body + 2 + n_dim])
            first = body + 2 + n_dim
            count = math.prod(dims)  # Python int: no overflow before the bounds check
            if code == -1:
                buf.need(first, count, f"characters of parameter {name!r}")
                raw = data[first:first + count].decode("latin-1")
                width = dims[0] if dims else 1
                value: object = ([raw[i:i + width] for i in range(0, count, width)]
                                 if width else [])
            elif code == 1:
                buf.need(first, count, f"bytes of parameter {name!r}")
                value = np.frombuffer(data, np.uint8, count, first).astype(np.int64)
            elif code == 2:
                value = buf.ints(first, count, f"integers of parameter {name!r}").astype(
                    np.int64)
            elif code == 4:
                value = buf.floats(first, count, f"floats of parameter {name!r}")
            else:
                raise MotionFileError(buf.path, f"parameter {name!r} has data type {code}; "
                                      "valid: -1 (char), 1 (byte), 2 (int16), 4 (float)")
            found.append((gid, name, value))
        if offset <= 0:  # the last record
            break
        pos = link + offset
    params: dict[str, dict[str, object]] = {}
    for gid, name, value in found:
        params.setdefault(groups.get(gid, f"GROUP{gid}"), {})[name] = value
    return params


def _count(value) -> int | None:
    """An unsigned 16-bit count stored as int16 (C3D counts above 32767 read negative)."""
    if value is None or len(value) == 0 or isinstance(value, list):
        return None
    v = int(value[0])
    return v + 65536 if v < 0 else v


def _parse_c3d(path: str, data: bytes) -> tuple[dict, np.ndarray, np.ndarray, dict]:
    """Parameters, positions (T, M, 3) in file units, residual-valid mask (T, M) and header
    facts of a C3D file."""
    if len(data) < _BLOCK or data[1] != 0x50:
        raise MotionFileError(path, "not a readable C3D file (no C3D header: the second byte "
                              "must be 0x50)" if len(data) >= 2 else
                              "not a readable C3D file (too short)")
    param_start = (data[0] - 1) * _BLOCK
    if data[0] < 2 or param_start + 4 > len(data):
        raise MotionFileError(path, f"not a readable C3D file (parameter block {data[0]} "
                              "outside the file)")
    processor = data[param_start + 3]
    if processor not in (_INTEL, _DEC, _MIPS):
        raise MotionFileError(path, f"not a readable C3D file (processor type {processor}; "
                              f"valid: {_INTEL} Intel, {_DEC} DEC, {_MIPS} MIPS)")
    buf = _Bytes(path, data, processor)
    words = buf.ints(0, 12, "header").astype(np.int64) & 0xFFFF  # header words, unsigned
    header_points, analog_per_frame = int(words[1]), int(words[2])
    first_frame, last_frame = int(words[3]), int(words[4])
    header_scale = float(buf.floats(12, 1, "header scale")[0])
    header_start = int(words[8])
    header_rate = float(buf.floats(20, 1, "header frame rate")[0])
    params = _parse_parameters(buf, param_start)

    used = _count(_param(params, "POINT", "USED"))
    n_points = header_points if used is None else used
    if used is not None and used != header_points:
        raise MotionFileError(path, f"corrupt: the header says {header_points} points, "
                              f"POINT:USED says {used}")
    if n_points == 0:
        raise MotionFileError(path, "the file has no 3-D points (markers)")
    scale_param = _param(params, "POINT", "SCALE")
    scale = (float(scale_param[0]) if scale_param is not None and len(scale_param)
             and not isinstance(scale_param, list) else header_scale)
    if not np.isfinite(scale):
        raise MotionFileError(path, f"corrupt: POINT:SCALE {scale}")
    start_param = _count(_param(params, "POINT", "DATA_START"))
    start_block = start_param if start_param else header_start
    data_start = (start_block - 1) * _BLOCK
    if start_block < 2 or data_start > len(data):
        raise MotionFileError(path, f"corrupt: data start block {start_block} outside the "
                              f"file ({len(data)} bytes)")
    n_frames = last_frame - first_frame + 1
    long_frames = _param(params, "POINT", "LONG_FRAMES")
    if long_frames is not None and len(long_frames) and not isinstance(long_frames, list):
        declared = float(long_frames[0])
        if np.isfinite(declared) and declared > n_frames:
            n_frames = int(min(declared, 2**31))
    if n_frames <= 0:
        raise MotionFileError(path, f"the file has no frames (first frame {first_frame}, last "
                              f"{last_frame})")
    word = 4 if scale < 0 else 2
    frame_words = 4 * n_points + analog_per_frame
    frame_bytes = word * frame_words
    have = (len(data) - data_start) // frame_bytes
    if have < n_frames:
        raise MotionFileError(path, f"truncated: {have} frames of data, the header says "
                              f"{n_frames}")
    if word == 4:
        table = buf.decode_floats(data, data_start, n_frames * frame_words)
    else:
        table = np.frombuffer(data, ">i2" if buf.big else "<i2", n_frames * frame_words,
                              data_start).astype(np.float64)
    points = table.reshape(n_frames, frame_words)[:, :4 * n_points].reshape(n_frames,
                                                                            n_points, 4)
    positions = points[..., :3] * (1.0 if word == 4 else abs(scale))
    valid = points[..., 3] >= 0
    facts = {"first_frame": first_frame - 1, "rate": header_rate, "n_points": n_points}
    return params, positions, valid, facts


def read_c3d(path: str | os.PathLike) -> RawMotion:
    """Read the marker trajectories of a C3D file.

    Args:
        path: the .c3d file.

    Returns:
        RawMotion with positions (T, M, 3) float64 in the file's POINT:UNITS (NaN where missing),
        fps = POINT:RATE [1/s], names from POINT:LABELS (stripped, made unique), valid (T, M),
        declared_units "mm"/"cm"/"m"/"in" (None when absent or unknown), declared_up from
        POINT:Y_SCREEN when consistent with the data (else None), and rig "qualisys", "bts",
        "roboptim" or "" from the marker names.

    Raises:
        MotionFileError: the file cannot be parsed (not a C3D file, truncated, corrupt counts or
            offsets), or has no frames or no points.
    """
    p = str(Path(path))
    try:
        data = Path(p).read_bytes()
    except OSError as exc:
        raise MotionFileError(p, "no such file" if not Path(p).exists() else
                              f"cannot read file ({exc.strerror or exc})") from None
    params, positions, valid, facts = _parse_c3d(p, data)
    n_points = facts["n_points"]
    names = unique_names(_point_labels(params, n_points), n_points)
    valid = valid & np.isfinite(positions).all(axis=2) & (positions != 0).any(axis=2)

    # drop computed (non-marker) points
    non_marker: set[str] = set()
    for group in _NON_MARKER_GROUPS:
        labels = _param(params, "POINT", group)
        if isinstance(labels, list):
            non_marker.update(str(s).strip() for s in labels)
    keep = np.array([n not in non_marker for n in names])
    if not keep.all():
        log.info("%s: dropped %d computed points (angles/forces/moments/powers/scalars)", p,
                 int((~keep).sum()))
        if not keep.any():
            raise MotionFileError(p, "the file has only computed points (angles, forces, ...), "
                                  "no marker positions")
        positions, valid = positions[:, keep], valid[:, keep]
        names = tuple(n for n, k in zip(names, keep, strict=True) if k)
    positions[~valid] = np.nan
    n_frames = positions.shape[0]

    rate = _param(params, "POINT", "RATE")
    fps = (float(rate[0]) if rate is not None and len(rate) and not isinstance(rate, list)
           else float("nan"))
    if not (np.isfinite(fps) and fps > 0):
        fps = facts["rate"]
    if not (np.isfinite(fps) and fps > 0):
        raise MotionFileError(p, f"invalid point rate {fps} (POINT:RATE and header)")

    unit_text = _first_str(_param(params, "POINT", "UNITS"))
    units = normalize_unit(unit_text)
    if units is None:
        log.warning("%s: POINT:UNITS %r not understood: units will be detected from the data",
                    p, unit_text)

    y_screen = _first_str(_param(params, "POINT", "Y_SCREEN"))
    x_screen = _first_str(_param(params, "POINT", "X_SCREEN"))
    up, up_why = screen_up_axis(y_screen, positions, valid)

    rig = rig_of(names)
    meta = {
        "c3d_first_frame": facts["first_frame"],
        "c3d_x_screen": x_screen,
        "c3d_y_screen": y_screen,
        "c3d_up_reason": up_why,
        "c3d_units": unit_text,
        "manufacturer": _first_str(_param(params, "MANUFACTURER", "COMPANY")) or "",
    }
    log.info("%s: C3D %d frames x %d markers at %g fps, units %s, up %s (%s), rig %r, %.1f %% "
             "samples missing", p, n_frames, len(names), fps, units, up, up_why, rig or "unknown",
             100.0 * (1.0 - valid.mean()))
    return RawMotion(positions=positions, fps=fps, names=names, valid=valid, path=p,
                     format="c3d", declared_units=units, declared_up=up, rig=rig, meta=meta)
