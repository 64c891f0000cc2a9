"""The multibody ZMP of a robot motion against its support polygon and the desired ZMP."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..contacts.phases import SIDES, runs
from .derivatives import motion_derivatives
from .flight import GRAVITY
from .polygon import distance_to_polygon, inside_polygon, polygon_centroid, support_polygons
from .soles import SoleTracks


def desired_zmp(soles: SoleTracks, support: np.ndarray, transition_s: float = 0.1
                ) -> np.ndarray:
    """(T, 2) float [m] desired ZMP: the sole centre in single support, the centre of the convex
    hull of both soles in double support, smooth between phases; flight frames are
    interpolated from their neighbours. All NaN when no frame has support.

    The transitions happen inside the double-support phases, so the desired ZMP never leaves
    the support polygon: over the first ``transition_s`` of a double-support phase it moves
    (smoothstep) from the previous single-support sole centre to the hull centre, over the
    last ``transition_s`` to the next single-support sole centre (for a phase shorter than
    ``2 transition_s``: half of it each). Every value is a convex combination of points of the
    polygon.
    """
    T = soles.n_frames
    raw = np.full((T, 2), np.nan)
    polys = support_polygons(soles, support)
    n_support = support.sum(axis=1)
    single = n_support == 1
    side = np.argmax(support, axis=1)
    for k, s in enumerate(SIDES):
        sel = single & (side == k)
        raw[sel] = soles.centers[s][sel, :2]
    width = max(1, int(round(transition_s * soles.fps)))
    for a, b in runs(n_support == 2):
        centres = []
        for frame in range(a, b):
            poly = polys[frame]
            assert poly is not None  # double support: both soles' corners
            centres.append(polygon_centroid(poly))
        centre = np.array(centres)
        t = np.arange(a, b)
        w = max(1.0, min(width, (b - a) / 2.0))
        d = centre
        if a > 0 and single[a - 1]:
            u = np.clip((t - a + 0.5) / w, 0.0, 1.0)[:, None]
            d = raw[a - 1] + u * u * (3 - 2 * u) * (d - raw[a - 1])
        if b < T and single[b]:
            u = np.clip((b - t - 0.5) / w, 0.0, 1.0)[:, None]
            d = raw[b] + u * u * (3 - 2 * u) * (d - raw[b])
        raw[a:b] = d
    ok = ~np.isnan(raw[:, 0])
    if not ok.any():
        return raw
    idx = np.arange(T)
    return np.stack([np.interp(idx, idx[ok], raw[ok, k]) for k in range(2)], axis=1)


def multibody_zmp(com: np.ndarray, dh: np.ndarray, mass: float) -> np.ndarray:
    """(T, 2) [m] the multibody ZMP on z = 0 from the CoM (T, 3) and the centroidal momentum's
    rate ``dh`` (T, 6) (DESIGN.md: ``p_x = c_x - (c_z c_x'' + Ld_y / m) / (c_z'' + g)``)."""
    acc, ld = dh[:, :3] / mass, dh[:, 3:]
    dn = acc[:, 2] + GRAVITY
    return np.stack([com[:, 0] - (com[:, 2] * acc[:, 0] + ld[:, 1] / mass) / dn,
                     com[:, 1] - (com[:, 2] * acc[:, 1] - ld[:, 0] / mass) / dn], axis=1)


def zmp_trajectory(robot, q: np.ndarray, fps: float, ground_z: float = 0.0) -> np.ndarray:
    """(T, 2) float [m] multibody ZMP of every frame of a trajectory ``q`` (T, nq) sampled at
    ``fps`` on the plane z = ``ground_z`` (:func:`multibody_zmp`, the momentum's rates by
    differences of the samples: :meth:`imesh.robot.Robot.centroidal_trajectory`)."""
    v, _ = motion_derivatives(q, fps)
    com, dh, _ = robot.centroidal_trajectory(q, v, fps)
    return multibody_zmp(com - np.array([0.0, 0.0, ground_z]), dh, robot.mass)


@dataclass(frozen=True, eq=False)
class ZmpReport:
    """Multibody ZMP of a motion against its support.

    Attributes:
        zmp_m: (T, 2) float [m] multibody ZMP.
        desired_m: (T, 2) float [m] desired ZMP (NaN when the motion has no support frame).
        inside: (T,) bool ZMP inside the support polygon (False in flight).
        support_frames: (T,) bool frames with at least one foot in support.
        inside_fraction: fraction of support frames whose ZMP is inside (NaN if none).
        error_mm: RMS distance [mm] between ZMP and desired ZMP over support frames.
        max_outside_mm: largest distance [mm] of an outside ZMP from its support polygon.
        polygons: per frame the (K, 2) support polygon (None in flight).
    """

    zmp_m: np.ndarray
    desired_m: np.ndarray
    inside: np.ndarray
    support_frames: np.ndarray
    inside_fraction: float
    error_mm: float
    max_outside_mm: float
    polygons: list = field(default_factory=list)



def zmp_report(zmp: np.ndarray, soles: SoleTracks, support: np.ndarray,
               transition_s: float = 0.1) -> ZmpReport:
    """Compare a ZMP trajectory with the support polygons and the desired ZMP.

    Args:
        zmp: (T, 2) float [m] ZMP.
        soles: the motion's soles.
        support: (T, 2) bool feet in support.
        transition_s: blending time of the desired ZMP between phases [s].
    """
    polys = support_polygons(soles, support)
    T = len(zmp)
    inside = np.zeros(T, dtype=bool)
    worst = 0.0
    for t, poly in enumerate(polys):
        if poly is None:
            continue
        inside[t] = inside_polygon(zmp[t], poly)
        if not inside[t]:
            worst = max(worst, distance_to_polygon(zmp[t], poly))
    sup = np.asarray(support.any(axis=1))
    desired = desired_zmp(soles, support, transition_s)
    if sup.any():
        err = np.linalg.norm(zmp[sup] - desired[sup], axis=1)
        error_mm = float(1e3 * np.sqrt(np.mean(err ** 2)))
        fraction = float(inside[sup].mean())
    else:
        error_mm = fraction = float("nan")
    return ZmpReport(zmp_m=zmp, desired_m=desired, inside=inside, support_frames=sup,
                     inside_fraction=fraction, error_mm=error_mm, max_outside_mm=1e3 * worst,
                     polygons=polys)


def zmp_jitter_mm(com: np.ndarray, fps: float, frames: np.ndarray | None = None) -> float:
    """RMS [mm] of the ZMP's swing from frame to frame that the evaluator's central
    differences average away: ``z_c / g |a3 - a_cd|`` of the CoM's horizontal acceleration,
    ``a3 = (c_{t+1} - 2 c_t + c_{t-1}) / h^2`` (what a robot playing the frames goes through)
    against ``a_cd`` (central differences twice, ``(c_{t+2} - 2 c_t + c_{t-2}) / 4h^2``, which
    the ZMP uses: their difference is a fourth difference and a zig-zag ``+-A`` of the CoM is
    ``4 A / h^2`` of it). 0 for a smooth motion; NaN below 5 frames.

    Args:
        com: (T, 3) float CoM [m]; fps: frame rate [1/s]; frames: (T,) bool frames to count
            (None: all), of which the first and last two never count.
    """
    c = np.asarray(com, dtype=float)
    T = len(c)
    if T < 5:
        return float("nan")
    h2 = fps * fps
    a3 = (c[2:, :2] - 2.0 * c[1:-1, :2] + c[:-2, :2]) * h2  # frames 1..T-2
    a_cd = (c[4:, :2] - 2.0 * c[2:-2, :2] + c[:-4, :2]) * h2 / 4.0  # frames 2..T-3
    diff = np.linalg.norm(a3[1:-1] - a_cd, axis=1) * np.mean(c[:, 2]) / 9.81
    use = np.ones(T - 4, dtype=bool) if frames is None else np.asarray(frames)[2:-2]
    if not use.any():
        return float("nan")
    return float(1e3 * np.sqrt(np.mean(diff[use] ** 2)))
