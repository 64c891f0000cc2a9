"""TRC reader: the tab-separated marker text format of Motion Analysis Cortex and OpenSim.

Layout (1-based line numbers)::

    1  PathFileType  4  (X/Y/Z)  <file name>
    2  DataRate  CameraRate  NumFrames  NumMarkers  Units  OrigDataRate ...   (keys)
    3  200.00    200.00      2387       35          mm     200.00 ...         (values)
    4  Frame#  Time  HEADF  <tab> <tab>  HEADR ...                            (marker names)
    5  <tab> <tab>  X1  Y1  Z1  X2 ...                                        (coordinate labels)
    6+ data rows: frame number, time [s], then x y z per marker; a missing sample is empty
       fields. Blank lines are skipped; a trailing tab (an empty last field) is allowed.

Files whose header has no tabs are read as whitespace-separated (then missing samples cannot
be empty fields; "NaN" is understood in both layouts).
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np

from ..errors import MotionFileError
from ..human.rig_tables import rig_of
from .c3d import normalize_unit, unique_names
from .raw import RawMotion

log = logging.getLogger(__name__)

_HEADER_LINES = 5


def _split(line: str, tabs: bool) -> list[str]:
    return line.split("\t") if tabs else line.split()


def _bad_field_position(cells: np.ndarray) -> int:
    """Flat index of the first cell that float() rejects (only called on the error path)."""
    for k, cell in enumerate(cells.tolist()):
        try:
            float(cell)
        except ValueError:
            return k
    return -1


#: Longest number field a data row may hold (characters); longer fields are corrupt.
_MAX_FIELD = 40


def _header_count(path: str, header: dict, key: str, low: int, high: int) -> int:
    """A header count (NumFrames, NumMarkers): an integer in [low, high] (for NumMarkers, high is
    what the file's longest line can hold), checked before it sizes anything."""
    text = header[key]
    try:
        value = float(text)
    except ValueError:
        raise MotionFileError(path, f"{key} {text!r} is not a number", line=3) from None
    if not (np.isfinite(value) and value == int(value) and low <= value <= high):
        raise MotionFileError(path, f"{key} {text!r} is not a count this file can hold; valid: "
                              f"an integer from {low} to {high}", line=3)
    return int(value)


def read_trc(path: str | os.PathLike) -> RawMotion:
    """Read a TRC marker file.

    Args:
        path: the .trc file.

    Returns:
        RawMotion with positions (T, M, 3) float64 in the file's Units (NaN where missing), fps =
        DataRate [1/s], names from the marker-name line (made unique), valid (T, M),
        declared_units from Units ("mm", "cm", "m", "in"; None when not understood),
        declared_up None (TRC does not state it; detected from the data) and rig "roboptim"
        (or "") from the marker names. ``meta`` holds the frame numbers' first value and the
        time of the first row.

    Raises:
        MotionFileError: with the 1-based line number for a malformed header, a data row with the
            wrong number of columns, a non-numeric value, or fewer rows than NumFrames.
    """
    p = str(Path(path))
    try:
        with open(p, encoding="utf-8", errors="replace", newline="") as fh:
            text = fh.read()
    except OSError as exc:
        raise MotionFileError(p, f"cannot read file ({exc})") from exc
    lines = text.splitlines()
    if len(lines) < _HEADER_LINES:
        raise MotionFileError(p, f"a TRC file needs {_HEADER_LINES} header lines, found "
                              f"{len(lines)}", line=len(lines) + 1)
    if not lines[0].startswith("PathFileType"):
        raise MotionFileError(p, "not a TRC file: the first line should start with "
                              "'PathFileType'", line=1)
    tabs = "\t" in lines[1]

    keys = [k.strip() for k in _split(lines[1], tabs)]
    values = [v.strip() for v in _split(lines[2], tabs)]
    header = {k: v for k, v in zip(keys, values, strict=False) if k}
    for key in ("DataRate", "NumFrames", "NumMarkers"):
        if key not in header:
            raise MotionFileError(p, f"header lacks {key} (keys found: {', '.join(keys)})",
                                  line=2)
    try:
        fps = float(header["DataRate"])
    except ValueError:
        raise MotionFileError(p, f"DataRate {header['DataRate']!r} is not a number", line=3
                              ) from None
    if not (np.isfinite(fps) and fps > 0):
        raise MotionFileError(p, f"DataRate {header['DataRate']!r} is not a frame rate; valid: "
                              "a finite number > 0", line=3)
    # counts are checked against what the file can hold before anything is allocated
    n_frames = _header_count(p, header, "NumFrames", 0, 10**9)  # only compared with the rows
    longest = max(map(len, lines))  # a marker takes at least 3 characters of every row
    n_markers = _header_count(p, header, "NumMarkers", 1, max(longest // 3, 1))
    unit_text = header.get("Units")
    units = normalize_unit(unit_text)
    if units is None:
        log.warning("%s: Units %r not understood: units will be detected from the data", p,
                    unit_text)

    name_cells = [c.strip() for c in _split(lines[3], tabs)]
    if len(name_cells) < 2:
        raise MotionFileError(p, "marker-name line has no markers", line=4)
    marker_cells = [c for c in name_cells[2:] if c]
    if tabs and len(marker_cells) != n_markers:
        # names sit every 3rd cell; fall back to those positions when the count disagrees
        marker_cells = [name_cells[2 + 3 * i] if 2 + 3 * i < len(name_cells) else ""
                        for i in range(n_markers)]
    if not tabs and len(marker_cells) != n_markers:
        raise MotionFileError(p, f"{len(marker_cells)} marker names for NumMarkers = "
                              f"{n_markers}", line=4)
    names = unique_names(marker_cells, n_markers)

    # ---- data block: all rows at once
    n_cols = 2 + 3 * n_markers
    body = lines[_HEADER_LINES:]
    lengths = np.fromiter(map(len, body), dtype=np.int64, count=len(body))
    too_long = np.flatnonzero(lengths > _MAX_FIELD * n_cols + 64)
    if too_long.size:  # also bounds the fixed-width string arrays below
        k = int(too_long[0])
        raise MotionFileError(p, f"data row of {lengths[k]} characters, more than {n_cols} "
                              f"numbers of at most {_MAX_FIELD} characters can fill",
                              line=_HEADER_LINES + k + 1)
    rows = np.char.rstrip(np.array(body, dtype=str), "\r\n")
    line_no = np.arange(_HEADER_LINES, _HEADER_LINES + rows.size) + 1
    keep = np.char.strip(rows) != ""
    rows, line_no = rows[keep], line_no[keep]
    if rows.size == 0:
        raise MotionFileError(p, f"no data rows (NumFrames says {n_frames})",
                              line=_HEADER_LINES + 1)
    if tabs:
        counts = np.char.count(rows, "\t") + 1
        # a trailing tab (empty last field) is allowed: give every row one, then drop that column
        trailing = np.char.endswith(rows, "\t") & (counts == n_cols + 1)
        counts = counts - trailing
        rows = np.where(trailing, rows, np.char.add(rows, "\t"))
    else:
        counts = np.array([len(r.split()) for r in rows.tolist()], dtype=np.int64)
    bad = np.flatnonzero(counts != n_cols)
    if bad.size:
        k = int(bad[0])
        hint = " (file truncated?)" if k == rows.size - 1 and counts[k] < n_cols else ""
        raise MotionFileError(p, f"{counts[k]} columns, expected {n_cols} (Frame#, Time and "
                              f"X/Y/Z of {n_markers} markers){hint}", line=int(line_no[k]))
    if rows.size < n_frames:
        raise MotionFileError(p, f"truncated: {rows.size} data rows, NumFrames says {n_frames}",
                              line=int(line_no[-1]) + 1)
    if rows.size > n_frames:
        log.warning("%s: %d data rows, NumFrames says %d: reading all rows", p, rows.size,
                    n_frames)

    if tabs:
        flat = np.array("\t".join(rows.tolist()).split("\t")).reshape(-1, n_cols + 1)[:, :-1]
        flat = flat.ravel()
    else:
        flat = np.array(" ".join(rows.tolist()).split())
    widths = np.char.str_len(flat)
    if widths.max(initial=0) > _MAX_FIELD:
        k = int(np.argmax(widths))
        row, col = divmod(k, n_cols)
        raise MotionFileError(p, f"a field of {widths[k]} characters in column {col + 1}: not a "
                              f"number of at most {_MAX_FIELD} characters",
                              line=int(line_no[row]))
    flat = np.char.strip(flat)
    flat = np.where(flat == "", "nan", flat)  # np.where widens the dtype to fit "nan"
    try:
        table = flat.astype(np.float64).reshape(-1, n_cols)
    except ValueError:
        k = _bad_field_position(flat)
        row, col = divmod(k, n_cols)
        what = ("Frame#" if col == 0 else "Time" if col == 1 else
                f"{'XYZ'[(col - 2) % 3]} of marker {names[(col - 2) // 3]}")
        raise MotionFileError(p, f"non-numeric value {str(flat[k])!r} in column {col + 1} "
                              f"({what})", line=int(line_no[row])) from None

    positions = table[:, 2:].reshape(-1, n_markers, 3)
    valid = np.asarray(np.isfinite(positions).all(axis=2))
    positions[~valid] = np.nan
    times = table[:, 1]
    rig = rig_of(names)
    meta = {"trc_first_frame": float(table[0, 0]), "trc_start_time_s": float(times[0]),
            "trc_units": unit_text, "trc_header": header}
    if np.isfinite(times).all() and times.size > 1:
        dt = np.median(np.diff(times))
        if dt > 0 and abs(1.0 / dt - fps) > 0.01 * fps:
            log.warning("%s: Time column steps %.6g s (%.4g fps) but DataRate is %g", p, dt,
                        1.0 / dt, fps)
    log.info("%s: TRC %d frames x %d markers at %g fps, units %s, rig %r, %.1f %% samples "
             "missing", p, positions.shape[0], n_markers, fps, units, rig or "unknown",
             100.0 * (1.0 - valid.mean()))
    return RawMotion(positions=positions, fps=fps, names=names, valid=valid, path=p,
                     format="trc", declared_units=units, declared_up=None, rig=rig, meta=meta)
