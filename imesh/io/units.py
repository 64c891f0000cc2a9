"""Units, up axis and floor: detection with logged decisions, and the conversion to MarkerMotion.

For a skeleton (BVH, ASF/AMC) the human body is recognized first (:mod:`imesh.human.rig`): its
up axis is the direction from the ankles to the neck, and its standing height (head joint above
the floor, from bone lengths and upright frames) picks the length unit. For marker sets the up
axis is the axis of largest extent and the height the median vertical extent. A unit is chosen
only when exactly one candidate puts the height in the human range; otherwise a
:class:`~imesh.human.errors.UnitsError` says what each unit would give and asks for ``--units``.
A clip whose planted feet lie on a tilted plane (a capture calibrated with its vertical off the
floor's normal) is levelled on that plane first (:mod:`imesh.io.floor`), then shifted to z = 0.
"""

from __future__ import annotations

import logging

import numpy as np

from ..core.motion import MarkerMotion, check_plausible
from ..errors import ImplausibleMotionError, OptionError
from ..human.errors import RigRecognitionError, UnitsError
from ..human.rig import recognize
from ..human.rig_result import RECOGNIZED, Recognition
from ..human.timing import TimingConfig, check_timing
from .floor import fit_floor, floor_meta, floor_offset, level_positions, lowest_markers
from .raw import RawMotion

log = logging.getLogger(__name__)

#: Metres per unit for the unit names imesh understands (the candidates of unit detection).
UNIT_SCALES_M: dict[str, float] = {
    "m": 1.0,
    "dm": 0.1,  # MakeHuman's internal unit
    "cm": 0.01,
    "mm": 0.001,
    "in": 0.0254,
    "cmu": 0.0254 / 0.45,  # CMU ASF/BVH length unit: 1/0.45 inch = 0.05644 m
}
UP_AXES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")
#: Possible heights of a performer [m]: a joint rig's standing height (head joint above the
#: floor, ~0.88 x stature) or a marker set's extent, from small children to very tall adults.
PLAUSIBLE_HEIGHT_M = (0.8, 2.3)
#: Heights of adults [m]; a unit giving one is preferred over units giving a merely possible one.
ADULT_HEIGHT_M = (1.2, 2.0)


def rotation_to_z_up(up_axis: str) -> np.ndarray:
    """Proper rotation R (3x3) with ``R @ up = +Z`` for an axis name like "+Y".

    +Y up maps by the cyclic permutation (x, y, z) -> (z, x, y), the usual BVH/C3D convention
    (file Z, pointing at the viewer, becomes world X).
    """
    if up_axis not in UP_AXES:
        raise OptionError("up axis", up_axis, UP_AXES)
    sign = 1.0 if up_axis[0] == "+" else -1.0
    axis = "XYZ".index(up_axis[1])
    # cyclic permutation putting `axis` last keeps det = +1
    order = [(axis + 1) % 3, (axis + 2) % 3, axis]
    r = np.zeros((3, 3))
    for row, col in enumerate(order):
        r[row, col] = 1.0
    if sign < 0:  # rotate 180 deg about the new X to flip Z (and Y) keeping handedness
        r = np.diag([1.0, -1.0, -1.0]) @ r
    return r


def _frame_extents(positions: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(T, 3) extent of the valid markers per frame per axis (NaN for too-sparse frames)."""
    enough = valid.sum(axis=1) >= max(2, positions.shape[1] // 2)
    ext = np.full((positions.shape[0], 3), np.nan)
    if enough.any():
        p = positions[enough]
        ext[enough] = np.nanmax(p, axis=1) - np.nanmin(p, axis=1)
    return ext


def detect_up_axis(raw: RawMotion) -> tuple[str, str]:
    """Up axis and the reason: the file's declaration, else the axis of largest median extent
    per frame, signed by the median coordinate (lab floors sit at 0 with the body above)."""
    if raw.declared_up is not None:
        return raw.declared_up, "declared by the file format"
    ext = np.nanmedian(_frame_extents(raw.positions, raw.valid), axis=0)
    axis = int(np.nanargmax(ext))
    median = np.nanmedian(raw.positions[..., axis])
    sign = "+" if median >= 0 else "-"
    why = (f"axis of largest per-frame extent ({ext[axis]:.4g} file units), signed by the "
           "median coordinate")
    return f"{sign}{'XYZ'[axis]}", why


def choose_units(height_units: float, path: str = "", what: str = "height"
                 ) -> tuple[str, float, str]:
    """The length unit that makes a performer of this height human.

    A unit whose height is adult (:data:`ADULT_HEIGHT_M`) wins when it is the only one; else a
    unit whose height is possible (:data:`PLAUSIBLE_HEIGHT_M`, children included) when it is the
    only one. The candidate ratios keep adult ranges apart (inch and CMU unit differ by 2.2x),
    so ambiguity only arises between child-sized and giant readings.

    Args:
        height_units: the height in file units.
        path: the file, for messages.
        what: what the height is ("standing height" or "height"), for messages.

    Returns:
        (unit name, metres per unit, reason).

    Raises:
        UnitsError: no unit, or several, give a possible height; lists what each would give.
    """
    heights = {u: height_units * scale for u, scale in UNIT_SCALES_M.items()}
    if not np.isfinite(height_units) or height_units <= 0:
        raise UnitsError(path, height_units, heights, [], list(UNIT_SCALES_M), what=what,
                         limits_m=PLAUSIBLE_HEIGHT_M)
    for (lo, hi), kind in ((ADULT_HEIGHT_M, "adult"), (PLAUSIBLE_HEIGHT_M, "possible")):
        fits = [u for u, h in heights.items() if lo <= h <= hi]
        if len(fits) == 1:
            unit = fits[0]
            others = ", ".join(f"{u} {h:.3g} m" for u, h in heights.items() if u != unit)
            why = (f"{what} {height_units:.4g} units = {heights[unit]:.3f} m is the only {kind} "
                   f"one ({lo:g}-{hi:g} m; {others})")
            if kind != "adult":
                log.warning("%s: %s", path, why)
            return unit, UNIT_SCALES_M[unit], why
        if len(fits) > 1:
            break
    plausible = [u for u, h in heights.items()
                 if PLAUSIBLE_HEIGHT_M[0] <= h <= PLAUSIBLE_HEIGHT_M[1]]
    raise UnitsError(path, height_units, heights, plausible, list(UNIT_SCALES_M), what=what,
                     limits_m=PLAUSIBLE_HEIGHT_M)


def recognize_body(raw: RawMotion) -> Recognition | None:
    """The human body of a skeleton file, or None (marker set, or not a recognizable human:
    the reason is logged, and mapping to the standard markers will raise it)."""
    if raw.format not in ("bvh", "asf/amc") or not len(raw.bones):
        return None
    try:
        return recognize(raw.names, raw.bones, raw.positions, source=raw.path)
    except RigRecognitionError as exc:
        log.info("%s: skeleton not recognized as a human (%s: %s)", raw.path, exc.part,
                 exc.reason)
        return None


def _file_units(raw: RawMotion, height_units: float, what: str) -> tuple[str, float, str]:
    """Declared units win, then a reader's hint, then the height's plausibility."""
    if raw.declared_scale_m is not None:
        name = raw.declared_units or f"{raw.declared_scale_m:.6g} m"
        return name, float(raw.declared_scale_m), "declared by the file"
    if raw.declared_units is not None:
        unit = raw.declared_units.lower()
        if unit not in UNIT_SCALES_M:
            raise OptionError("unit", raw.declared_units, UNIT_SCALES_M)
        return unit, UNIT_SCALES_M[unit], "declared by the file"
    hint = raw.meta.get("unit_hint_m")
    if hint is not None:
        return (f"{float(hint):.6g} m", float(hint),
                str(raw.meta.get("unit_hint_reason", "reader hint")))
    return choose_units(height_units, raw.path, what)


def _check_raw(raw: RawMotion) -> None:
    """What unit and up-axis detection need: some frame with half of the markers present."""
    if not raw.valid.any():
        raise ImplausibleMotionError(
            raw.path, "missing markers", f"all {raw.valid.shape[1]} markers are missing in all "
            f"{raw.valid.shape[0]} frames", valid="a clip with markers present")
    bad = raw.valid & ~np.isfinite(raw.positions).all(axis=2)
    if bad.any():
        t, j = (int(i[0]) for i in np.nonzero(bad))
        raise ImplausibleMotionError(
            raw.path, "non-finite", f"position {raw.positions[t, j].tolist()} is not finite "
            f"({int(bad.sum())} samples; values too large for the forward kinematics?)",
            valid="finite positions", frame=t, marker=raw.names[j])
    need = max(2, raw.valid.shape[1] // 2)
    counts = raw.valid.sum(axis=1)
    if counts.max() < need:
        raise ImplausibleMotionError(
            raw.path, "missing markers", f"no frame has {need} of the {raw.valid.shape[1]} "
            f"markers present (at most {int(counts.max())}), so units, up axis and body height "
            "cannot be measured", valid=f"frames with at least {need} markers present")


#: Frames converted at a time when ``finalize`` works in place.
_BLOCK_FRAMES = 16384


def finalize(raw: RawMotion, *, units: str | float | None = None, up_axis: str | None = None,
             ground: str | float = "auto", check: bool = True,
             consume: bool = False, timing: bool = False) -> MarkerMotion:
    """Convert a RawMotion to a MarkerMotion in metres, Z up, floor at z = 0.

    A skeleton is recognized as a human body first; ``meta`` then holds the recognition
    (``rig_recognition``), its ``rig_confidence`` and the ``standing_height_m``.

    Args:
        raw: the parsed file.
        units: override: a unit name (m, dm, cm, mm, in, cmu) or metres per file unit.
        up_axis: override: "+X", "-X", "+Y", "-Y", "+Z" or "-Z".
        ground: "auto" levels the clip on the plane of its planted feet when that plane is a
            floor tilted 0.25-2 degrees (:func:`imesh.io.floor.fit_floor`; ``meta``:
            ``floor_tilt_rad``, ``floor_level_rotation``, ``floor_level_pivot_m``), then shifts
            the motion vertically so the floor (the 2nd percentile of the per-frame lowest
            marker) is at z = 0 when it is more than 3 cm away; "none" keeps the file's
            orientation and vertical origin; a number shifts by that many metres (up).
        check: run the plausibility checks (:func:`imesh.core.motion.check_plausible`: frame rate,
            body height, position range, marker speed); on by default.
        consume: the caller gives ``raw`` up: its positions array is converted in place and
            becomes the motion's (no second copy: a 30-minute clip's positions are 200 MB).
        timing: check the file's frame rate by the performer's balance and read the clip at
            a lower one when it says so (:func:`imesh.human.timing.check_timing`; ``meta``:
            ``fps_reason``, and ``header_fps`` when the rate changed).

    Raises:
        ImplausibleMotionError: every marker missing, positions that overflow when converted to
            metres, or (``check``) a failed plausibility check.
        UnitsError: no unit given or declared, and the height does not tell it.
        OptionError: an invalid override.
    """
    _check_raw(raw)
    body = recognize_body(raw)
    if up_axis is not None:
        up, up_why = up_axis, "given by the user"
        if up not in UP_AXES:
            raise OptionError("up axis", up, UP_AXES)
    elif body is not None and body.up_axis is not None:
        up = body.up_axis
        up_why = (f"the body: ankles -> neck (agreement {body.confidence['up']:.2f} over "
                  "frames)")
        if raw.declared_up is not None and raw.declared_up != up:
            log.warning("%s: the body stands along %s, not along the format's %s", raw.path, up,
                        raw.declared_up)
            up_why += f"; the format's convention {raw.declared_up} disagrees"
    else:
        up, up_why = detect_up_axis(raw)
    rot = rotation_to_z_up(up)
    with np.errstate(over="ignore", invalid="ignore"):
        if consume:  # in place, a block of frames at a time
            pos = raw.positions
            for a in range(0, len(pos), _BLOCK_FRAMES):
                pos[a:a + _BLOCK_FRAMES] = pos[a:a + _BLOCK_FRAMES] @ rot.T
        else:
            pos = raw.positions @ rot.T
    if body is not None:
        height_units, what = body.height, "standing height"
    else:
        ext = _frame_extents(pos, raw.valid)
        height_units = (float(np.nanmedian(ext[:, 2])) if np.isfinite(ext[:, 2]).any()
                        else float("nan"))
        what = "height"

    if units is None:
        unit_name, scale, unit_why = _file_units(raw, height_units, what)
    elif isinstance(units, str):
        if units.lower() not in UNIT_SCALES_M:
            raise OptionError("units", units, list(UNIT_SCALES_M))
        unit_name, scale = units.lower(), UNIT_SCALES_M[units.lower()]
        unit_why = "given by the user"
    else:
        unit_name, scale, unit_why = f"{float(units):.6g} m", float(units), "given by the user"
    if not (np.isfinite(scale) and scale > 0):
        raise OptionError("units", units if units is not None else unit_name,
                          "a unit name (m, cm, mm, in, cmu) or a positive number of metres")
    with np.errstate(over="ignore", invalid="ignore"):
        pos *= scale
    overflow = raw.valid & ~np.isfinite(pos).all(axis=2)
    if overflow.any():
        t, j = (int(i[0]) for i in np.nonzero(overflow))
        shown = (pos[t, j] / scale) @ rot if consume else raw.positions[t, j]
        raise ImplausibleMotionError(
            raw.path, "non-finite", f"position {shown.tolist()} (file units) is "
            f"not a finite number in metres ({int(overflow.sum())} samples)",
            valid="finite positions", frame=t, marker=raw.names[j])

    fps, timing_meta = _capture_rate(raw, pos, scale, body) if timing else (raw.fps, {})
    floor = 0.0
    level = None
    if ground == "auto":
        level = fit_floor(pos, raw.valid, fps)
        level_positions(pos, level, _BLOCK_FRAMES)
        floor, ground_why = floor_offset(lowest_markers(pos, raw.valid))
    elif ground == "none":
        ground_why = "kept (ground='none')"
    else:
        try:
            floor = -float(ground)
        except (TypeError, ValueError):
            raise OptionError("ground", ground, "'auto', 'none' or a number of metres") from None
        ground_why = "given by the user"
    pos[..., 2] -= floor
    if consume:
        pos.setflags(write=False)  # the motion keeps it as it is (imesh.core.motion._frozen)

    log.info("%s: units %s (%.6g m/unit; %s); up axis %s (%s); floor %s%s", raw.path, unit_name,
             scale, unit_why, up, up_why, ground_why, f"; {level.reason}" if level else "")
    meta = dict(raw.meta)
    meta.update(
        format=raw.format, rig=raw.rig or (RECOGNIZED if body is not None else ""),
        units=unit_name, unit_scale_m=scale, units_reason=unit_why,
        up_axis=up, up_axis_reason=up_why, floor_offset_m=floor, floor_reason=ground_why,
    )
    if level is not None:
        meta.update(floor_meta(level, floor, ground_why))
    if body is not None:
        meta.update(rig_recognition=body, standing_height_m=body.height * scale,
                    rig_confidence=body.overall_confidence)
    meta.update(timing_meta)
    motion = MarkerMotion(positions_m=pos, fps=fps, names=raw.names, valid=raw.valid,
                          bones=raw.bones, source=raw.path, meta=meta)
    if check:
        check_plausible(motion)
    return motion


def _capture_rate(raw: RawMotion, pos: np.ndarray, scale: float,
                  body: Recognition | None) -> tuple[float, dict]:
    """The rate to read ``raw`` at (:func:`imesh.human.timing.check_timing` on its first
    ``TimingConfig.probe_s`` seconds, ``pos`` in metres, Z up) and its ``meta`` entries."""
    n = min(len(pos), int(TimingConfig().probe_s * raw.fps))
    probe_meta = ({"rig_recognition": body, "unit_scale_m": scale} if body is not None else {})
    probe = MarkerMotion(positions_m=np.array(pos[:n]), fps=raw.fps, names=raw.names,
                         valid=raw.valid[:n], bones=raw.bones, source=raw.path, meta=probe_meta)
    verdict = check_timing(probe)
    if not verdict.corrected:
        return raw.fps, {"fps_reason": verdict.reason}
    log.warning("%s: read at %s", raw.path, verdict.reason)
    return verdict.fps, {"fps_reason": verdict.reason, "header_fps": verdict.header_fps}
