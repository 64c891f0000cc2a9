"""The floor plane of a clip: fitted to the planted feet, and the rotation that levels it.

Some captures are calibrated with the lab's vertical slightly off the floor's normal: the CMU
walks' planted toes rise 16-18 mm per metre along the walk (about 1 degree). A robot retargeted
onto a level floor then meets a floor that tilts under the clip: its soles leave their
footprints by a few centimetres over a walk, the lead-in holds tilted feet, and the whole-body
solve pays with the trunk to keep the ZMP in. Levelling the clip on the plane of its planted
feet removes the tilt before any stage sees it.

The planted samples are the lowest valid marker of each frame while it moves slower than
:data:`PLANTED_SPEED_M_S` horizontally (a stance toe or heel). A plane ``z = c + g . (x, y)``
is fitted to them by least squares, re-fitted twice without samples further than 3 robust
standard deviations (at least 10 mm) from it. Only directions the planted samples span by at
least :data:`MIN_SPAN_M` are fitted (a walk tells the slope along its path, not across it;
standing clips tell none).

A clip is levelled only when the fit is a floor: residual RMS within :data:`MAX_RESIDUAL_M`
(a person stepping onto a box leaves residuals of 0.3-0.4 m and is kept), a tilt between
:data:`MIN_TILT_RAD` (below, the rise over a walk is within the foot markers' own height
changes) and :data:`MAX_TILT_RAD` (beyond, a ramp, not a calibration).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..core.motion import MarkerMotion

#: A planted foot marker's horizontal speed stays below this [m/s].
PLANTED_SPEED_M_S = 0.15
#: A direction must be spanned this far (5th-95th percentile) by planted samples to be fitted.
MIN_SPAN_M = 1.0
#: At least this many planted samples to fit.
MIN_SAMPLES = 50
#: The fitted plane's residual RMS must be within this for the plane to be the floor [m].
MAX_RESIDUAL_M = 0.010
#: Tilts below this are kept (0.25 degree: 13 mm over a 3 m walk) [rad].
MIN_TILT_RAD = np.deg2rad(0.25)
#: Tilts beyond this are a slope, not a calibration error, and are kept (2 degrees) [rad].
MAX_TILT_RAD = np.deg2rad(2.0)
#: The floor (2nd percentile of the frames' lowest marker) is moved to z = 0 when it is farther
#: than this [m].
FLOOR_SHIFT_M = 0.03


@dataclass(frozen=True)
class FloorFit:
    """The floor plane ``z = pivot_z + slope . ((x, y) - pivot_xy)`` of a clip's planted feet.

    Attributes:
        slope: (2,) dz/dx and dz/dy of the plane [m/m] (0 along unfitted directions).
        pivot_m: (3,) a point of the plane: the planted samples' centre.
        residual_rms_m: RMS distance of the kept samples from the plane [m].
        span_m: (2,) the planted samples' 5th-95th percentile extent along their principal
            horizontal directions [m].
        samples: number of planted samples.
        levelled: the plane is taken as the floor and the clip is levelled on it.
        reason: why it is (or is not) levelled, for the log and the motion's ``meta``.
    """

    slope: np.ndarray
    pivot_m: np.ndarray
    residual_rms_m: float
    span_m: np.ndarray
    samples: int
    levelled: bool
    reason: str

    @property
    def tilt_rad(self) -> float:
        """Angle between the plane's normal and +Z [rad]."""
        return float(np.arctan(np.linalg.norm(self.slope)))

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3) the rotation about a horizontal axis that turns the plane's normal to +Z
        (identity when the clip is not levelled); apply as ``R (p - pivot) + pivot``."""
        if not self.levelled:
            return np.eye(3)
        n = np.array([-self.slope[0], -self.slope[1], 1.0])
        n /= np.linalg.norm(n)
        axis = np.cross(n, [0.0, 0.0, 1.0])  # |axis| = sin(tilt)
        s, c = np.linalg.norm(axis), n[2]
        k = axis / s
        kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
        return np.eye(3) + s * kx + (1.0 - c) * (kx @ kx)  # Rodrigues


def planted_samples(positions_m: np.ndarray, valid: np.ndarray, fps: float) -> np.ndarray:
    """(N, 3) the lowest valid marker of each frame while it moves slower than
    :data:`PLANTED_SPEED_M_S` horizontally (central differences; frames without a valid
    lowest marker or neighbours skipped).

    Args:
        positions_m: (T, M, 3) marker positions, Z up [m].
        valid: (T, M) bool.
        fps: frames per second.
    """
    t_count = positions_m.shape[0]
    if t_count < 3:
        return np.zeros((0, 3))
    z = np.where(valid, positions_m[..., 2], np.inf)
    low = np.argmin(z, axis=1)  # (T,)
    t = np.arange(1, t_count - 1)
    j = low[t]
    ok = valid[t, j] & valid[t - 1, j] & valid[t + 1, j]
    t, j = t[ok], j[ok]
    speed = np.linalg.norm(positions_m[t + 1, j, :2] - positions_m[t - 1, j, :2], axis=1)
    speed *= 0.5 * fps
    keep = speed < PLANTED_SPEED_M_S
    return np.asarray(positions_m[t[keep], j[keep]], dtype=float)


def fit_floor(positions_m: np.ndarray, valid: np.ndarray, fps: float) -> FloorFit:
    """Fit the floor plane to the planted feet and decide whether to level the clip on it.

    Args:
        positions_m: (T, M, 3) marker positions, Z up [m].
        valid: (T, M) bool.
        fps: frames per second.

    Returns:
        The fit; ``levelled`` says whether :attr:`FloorFit.rotation` is to be applied.
    """
    return fit_plane(planted_samples(positions_m, valid, fps))


def fit_plane(pts: np.ndarray) -> FloorFit:
    """:func:`fit_floor` on planted samples (N, 3) [m] (of one clip, or of people captured
    together)."""
    n = len(pts)
    if n < MIN_SAMPLES:
        return FloorFit(np.zeros(2), np.zeros(3), float("nan"), np.zeros(2), n, False,
                        f"not levelled: {n} planted foot samples (< {MIN_SAMPLES})")
    centre = pts.mean(axis=0)
    xy = pts[:, :2] - centre[:2]
    _, _, axes = np.linalg.svd(xy, full_matrices=False)  # rows: principal directions
    u = xy @ axes.T
    span = np.percentile(u, 95, axis=0) - np.percentile(u, 5, axis=0)
    fitted = span >= MIN_SPAN_M
    if not fitted.any():
        return FloorFit(np.zeros(2), centre, float(np.std(pts[:, 2])), span, n, False,
                        f"not levelled: planted feet span {span.max():.2f} m "
                        f"(< {MIN_SPAN_M:.1f} m tells no slope)")
    design = np.column_stack([np.ones(n), u[:, fitted]])
    keep = np.ones(n, dtype=bool)
    for _ in range(3):  # least squares, then twice without outliers (a stray low marker)
        coef, *_ = np.linalg.lstsq(design[keep], pts[keep, 2], rcond=None)
        r = pts[:, 2] - design @ coef
        mad = 1.4826 * float(np.median(np.abs(r[keep] - np.median(r[keep]))))
        keep = np.abs(r) <= max(3.0 * mad, 0.010)
        if keep.sum() < MIN_SAMPLES:  # no floor that enough samples agree on
            return FloorFit(np.zeros(2), centre, float(np.std(pts[:, 2])), span, n, False,
                            f"not levelled: fewer than {MIN_SAMPLES} of {n} planted foot "
                            "samples lie on one plane")
    rms = float(np.sqrt(np.mean(r[keep] ** 2)))
    slope = coef[1:] @ axes[fitted]  # back to dz/dx, dz/dy
    pivot = np.array([centre[0], centre[1], coef[0]])
    tilt = float(np.arctan(np.linalg.norm(slope)))
    what = (f"planted feet ({n} samples over {span.max():.2f} m) on a plane tilted "
            f"{np.rad2deg(tilt):.2f} deg, residual {rms * 1e3:.1f} mm")
    if rms > MAX_RESIDUAL_M:
        ok, why = False, f"not levelled: {what} (> {MAX_RESIDUAL_M * 1e3:.0f} mm: not one floor)"
    elif tilt < MIN_TILT_RAD:
        ok, why = False, f"not levelled: {what} (< {np.rad2deg(MIN_TILT_RAD):.2f} deg)"
    elif tilt > MAX_TILT_RAD:
        ok, why = False, f"not levelled: {what} (> {np.rad2deg(MAX_TILT_RAD):.0f} deg: a slope)"
    else:
        ok, why = True, f"levelled: {what}"
    return FloorFit(slope, pivot, rms, span, n, ok, why)


def lowest_markers(positions_m: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(T',) z of each frame's lowest valid marker [m] (frames without one left out)."""
    z = np.where(valid, positions_m[..., 2], np.inf)
    low = z.min(axis=1)
    return low[np.isfinite(low)]


def floor_offset(lowest_z_m: np.ndarray) -> tuple[float, str]:
    """The vertical shift that puts the floor at z = 0, and why: the 2nd percentile of the
    frames' lowest markers when it is farther than :data:`FLOOR_SHIFT_M` from 0, else 0."""
    est = float(np.percentile(lowest_z_m, 2)) if lowest_z_m.size else 0.0
    if abs(est) > FLOOR_SHIFT_M:
        return est, f"lowest markers sit at {est:+.3f} m: shifted to the floor"
    return 0.0, f"lowest markers at {est:+.3f} m: kept"


def level_positions(positions_m: np.ndarray, fit: FloorFit, block: int = 16384) -> None:
    """Turn (T, M, 3) positions in place about the fit's pivot so that its plane is level (a
    block of frames at a time: a 30-minute clip's positions are 200 MB)."""
    if not fit.levelled:
        return
    rot, pivot = fit.rotation, fit.pivot_m
    for a in range(0, len(positions_m), block):
        positions_m[a:a + block] = (positions_m[a:a + block] - pivot) @ rot.T + pivot


def ground_together(motions: Sequence[MarkerMotion]) -> list[MarkerMotion]:
    """People captured together (a pair), read with ``ground="none"``, put on one floor: one
    plane fitted to all their planted feet, the same levelling rotation and the same vertical
    shift for all (each clip grounded alone would put the salsa partners' floors 55 mm apart:
    partner B's lowest markers sit 55 mm up, A's within the 3 cm kept).

    Args:
        motions: the people, in one world (each read with ``ground="none"``).

    Returns:
        The motions levelled and shifted, ``meta`` recording the shared decision
        (``floor_reason``, ``floor_offset_m``, ``floor_tilt_rad``, ``floor_level_reason``,
        and ``floor_level_rotation`` / ``floor_level_pivot_m`` when levelled).
    """
    pts = np.concatenate([planted_samples(m.positions_m, m.valid, m.fps) for m in motions])
    fit = fit_plane(pts)
    moved = []
    for m in motions:
        pos = np.array(m.positions_m, dtype=float)
        level_positions(pos, fit)
        moved.append(pos)
    offset, why = floor_offset(np.concatenate([lowest_markers(p, m.valid)
                                               for p, m in zip(moved, motions, strict=True)]))
    decided = floor_meta(fit, offset, why, " (with the partner)")
    out = []
    for pos, m in zip(moved, motions, strict=True):
        pos[..., 2] -= offset
        meta = {k: v for k, v in m.meta.items()
                if k not in ("floor_level_rotation", "floor_level_pivot_m")}
        out.append(m.with_positions(pos, meta={**meta, **decided}))
    return out


def floor_meta(fit: FloorFit, offset_m: float, reason: str, note: str = "") -> dict:
    """The ``meta`` entries of a floor decision: ``floor_offset_m``, ``floor_reason``,
    ``floor_tilt_rad``, ``floor_level_reason``, and ``floor_level_rotation`` /
    ``floor_level_pivot_m`` when levelled (what :func:`imesh.scene.human_scene` applies to the
    props); ``note`` is appended to both reasons."""
    meta = {"floor_offset_m": offset_m, "floor_reason": reason + note,
            "floor_tilt_rad": fit.tilt_rad if fit.levelled else 0.0,
            "floor_level_reason": fit.reason + note}
    if fit.levelled:
        meta.update(floor_level_rotation=fit.rotation.tolist(),
                    floor_level_pivot_m=fit.pivot_m.tolist())
    return meta
