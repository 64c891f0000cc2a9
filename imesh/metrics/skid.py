"""How support soles move while they should stand still: foot skid (horizontal slide per
frame) and sole deviation (distance from the footprint, tilt from the ground)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contacts.phases import SIDES, runs
from .soles import SoleTracks

#: Frame rate the foot skid is reported at (DESIGN.md: mm per frame at 30 fps).
SKID_FPS = 30.0
#: A support frame skids when its sole centre moves more than this per 30-fps frame [mm].
SKID_THRESHOLD_MM = 10.0


@dataclass(frozen=True)
class SkidReport:
    """Horizontal sole motion during support.

    Attributes:
        mean_mm_per_frame: mean horizontal motion of a support sole centre per frame [mm],
            scaled to 30 fps (NaN without support frames).
        fraction_over_10mm: fraction of support samples moving more than 10 mm per 30-fps frame.
        max_mm_per_frame: largest such motion [mm per 30-fps frame].
        samples: number of (foot, frame) samples (frames where the foot is in support at both
            the frame and the previous one).
    """

    mean_mm_per_frame: float
    fraction_over_10mm: float
    max_mm_per_frame: float
    samples: int


def near_slides(sliding: np.ndarray) -> np.ndarray:
    """(T, ...) bool the frames of planned slides (``sliding`` (T, ...)) and the frames next to
    them: the skid of frame t is the motion from t - 1, so a slide's first and last steps
    count with it."""
    sliding = np.asarray(sliding, dtype=bool)
    near = sliding.copy()
    near[1:] |= sliding[:-1]
    near[:-1] |= sliding[1:]
    return near


def foot_skid(soles: SoleTracks, support: np.ndarray) -> SkidReport:
    """Foot skid of the support feet (DESIGN.md ``foot_skid_mm_per_frame``)."""
    values = []
    for k, side in enumerate(SIDES):
        both = support[1:, k] & support[:-1, k]
        step = np.linalg.norm(np.diff(soles.centers[side][:, :2], axis=0), axis=1)
        values.append(step[both] * 1e3 * soles.fps / SKID_FPS)
    d = np.concatenate(values) if values else np.zeros(0)
    if d.size == 0:
        return SkidReport(float("nan"), float("nan"), float("nan"), 0)
    return SkidReport(mean_mm_per_frame=float(d.mean()),
                      fraction_over_10mm=float(np.mean(d > SKID_THRESHOLD_MM)),
                      max_mm_per_frame=float(d.max()), samples=int(d.size))


@dataclass(frozen=True)
class SoleDeviation:
    """How far supporting soles leave their footprints.

    Attributes:
        deviation_mm: largest distance of a support sole centre from its footprint (the median
            centre of its support phase, on z = 0) [mm].
        tilt_deg: largest angle between a supporting sole's normal and the vertical [deg].
        samples: (foot, frame) support samples.
    """

    deviation_mm: float
    tilt_deg: float
    samples: int


def sole_deviation(soles: SoleTracks, support: np.ndarray) -> SoleDeviation:
    """Sole deviation and tilt over the support phases (DESIGN.md ``sole_deviation_mm``,
    ``sole_tilt_deg``)."""
    dev, tilt, n = 0.0, 0.0, 0
    for k, side in enumerate(SIDES):
        c = soles.corners[side]
        normal = np.cross(c[:, 1] - c[:, 0], c[:, 3] - c[:, 0])
        cos = np.abs(normal[:, 2]) / np.maximum(np.linalg.norm(normal, axis=1), 1e-12)
        angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
        for a, b in runs(support[:, k]):
            centre = soles.centers[side][a:b]
            foot = np.r_[np.median(centre[:, :2], axis=0), 0.0]
            dev = max(dev, float(np.linalg.norm(centre - foot, axis=1).max()))
            tilt = max(tilt, float(angle[a:b].max()))
            n += b - a
    return SoleDeviation(deviation_mm=1e3 * dev, tilt_deg=tilt, samples=n)
