"""C3D reader (marker trajectories) built on ezc3d.

Only 3-D points are read; analog channels and force plates are ignored. Points that the file lists
as computed quantities (``POINT:ANGLES``, ``FORCES``, ``MOMENTS``, ``POWERS``, ``SCALARS``,
``REACTIONS``: Vicon model outputs stored as points) are dropped, because they are not positions.

A sample is missing when its residual is negative (the C3D convention), when any coordinate is
not finite, or when it is exactly (0, 0, 0): many writers store gaps as zeros.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np

from ..errors import ImeshError, MotionFileError
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

#: Marker names that identify a marker protocol (all must be present). Kept equal to the
#: ``detect`` lists of the rig tables in ``imesh/data/rigs``.
RIG_SIGNATURES: dict[str, tuple[str, ...]] = {
    "qualisys": ("L_IAS", "R_IAS", "L_FLE"),
    "bts": ("r asis", "l asis", "sacrum", "r knee 1", "l knee 1"),
    "roboptim": ("HEADF", "RSHO", "LSHO", "RPEL", "LPEL", "STERNUP"),
}

#: POINT parameters listing labels of points that are not marker positions.
_NON_MARKER_GROUPS = ("ANGLES", "FORCES", "MOMENTS", "POWERS", "SCALARS", "REACTIONS")


class C3DDependencyError(ImeshError, ImportError):
    """ezc3d, needed to read C3D files, is not installed."""


def detect_rig(names: tuple[str, ...] | list[str]) -> str:
    """Rig (marker protocol) name whose signature markers are all in ``names``, or ""."""
    present = set(names)
    for rig, needed in RIG_SIGNATURES.items():
        if set(needed) <= present:
            return rig
    return ""


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
    """Value of parameter GROUP:NAME, or None."""
    try:
        return params[group][name]["value"]
    except (KeyError, TypeError):
        return None


def _first_str(value) -> str | None:
    if value is None or len(value) == 0:
        return None
    return str(value[0]).strip()


def _point_labels(params: dict, n: int) -> list[str]:
    """POINT:LABELS followed by LABELS2, LABELS3, ... (files with more than 255 points)."""
    labels = list(_param(params, "POINT", "LABELS") or [])
    k = 2
    while len(labels) < n:
        more = _param(params, "POINT", f"LABELS{k}")
        if not more:
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
        C3DDependencyError: ezc3d is not installed (an ImeshError and an ImportError).
        MotionFileError: the file cannot be parsed, or has no frames or no points.
    """
    try:
        import ezc3d
    except ImportError as exc:
        raise C3DDependencyError(
            f"reading C3D files needs the ezc3d package: pip install ezc3d ({exc})"
        ) from exc
    p = str(Path(path))
    if not Path(p).is_file():
        raise MotionFileError(p, "no such file")
    try:
        c3d = ezc3d.c3d(p, extract_forceplat_data=False)
        params = c3d["parameters"]
        points = np.asarray(c3d["data"]["points"], dtype=np.float64)
        residuals = np.asarray(c3d["data"]["meta_points"]["residuals"], dtype=np.float64)
    except Exception as exc:  # ezc3d raises RuntimeError/IOError/ValueError on corrupt input
        raise MotionFileError(p, f"not a readable C3D file ({type(exc).__name__}: {exc})"
                              ) from exc

    if points.ndim != 3 or points.shape[0] < 3:
        raise MotionFileError(p, f"unexpected point array shape {points.shape}")
    n_points, n_frames = points.shape[1], points.shape[2]
    if n_frames == 0:
        raise MotionFileError(p, "the file has no frames")
    if n_points == 0:
        raise MotionFileError(p, "the file has no 3-D points (markers)")
    # ezc3d silently shortens a file cut mid-data (and rewrites POINT:FRAMES); POINT:LONG_FRAMES,
    # when present, still holds the written frame count.
    long_frames = _param(params, "POINT", "LONG_FRAMES")
    if long_frames is not None and len(long_frames) and float(long_frames[0]) > n_frames:
        raise MotionFileError(p, f"truncated: {n_frames} frames of data, POINT:LONG_FRAMES says "
                              f"{int(float(long_frames[0]))}")

    names = unique_names(_point_labels(params, n_points), n_points)
    positions = points[:3].transpose(2, 1, 0).copy()  # (T, M, 3)
    res = residuals.reshape(-1, n_points, n_frames)[0].T if residuals.size else \
        np.zeros((n_frames, n_points))
    valid = (res >= 0) & np.isfinite(positions).all(axis=2) & (positions != 0).any(axis=2)

    # drop computed (non-marker) points
    non_marker: set[str] = set()
    for group in _NON_MARKER_GROUPS:
        non_marker.update(str(s).strip() for s in (_param(params, "POINT", group) or []))
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

    rate = _param(params, "POINT", "RATE")
    fps = float(rate[0]) if rate is not None and len(rate) else float("nan")
    if not (np.isfinite(fps) and fps > 0):
        fps = float(c3d["header"]["points"].get("frame_rate", float("nan")))
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

    rig = detect_rig(names)
    header = c3d["header"]["points"]
    meta = {
        "c3d_first_frame": int(header.get("first_frame", 0)),
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
