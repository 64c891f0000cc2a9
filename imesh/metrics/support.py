"""Support phases of a robot motion from its own soles.

A foot is in support while the lowest corner of its sole is within ``SupportDetection.height_m``
of the ground (z = 0) and its sole centre is slow, with hysteresis and a minimum phase duration
(as :func:`imesh.contacts.phases.detect_contacts` does for markers). No source markers are
needed, so motions from other retargeting tools are scored on the same terms.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..contacts.phases import SIDES, Contacts, PhaseFilter
from ..core.checks import require_finite
from .soles import SoleTracks


@dataclass(frozen=True)
class SupportDetection:
    """Thresholds of the sole-based support detection of a robot motion.

    Attributes:
        height_m: a foot can enter support when the lowest corner of its sole is within this
            height of the ground [m].
        speed_mps: ... and its sole centre moves slower than this [m/s].
        phases: hysteresis and minimum phase duration (0.05 s here, 0.08 s for markers).
    """

    height_m: float = 0.01
    speed_mps: float = 0.5
    phases: PhaseFilter = field(default_factory=lambda: PhaseFilter(min_phase_s=0.05))

    def __post_init__(self) -> None:
        require_finite(self, ("height_m", "speed_mps"), positive=True)


def detect_support(soles: SoleTracks, config: SupportDetection | None = None) -> Contacts:
    """Support phases of both feet of a robot motion from its soles.

    Args:
        soles: :func:`~imesh.metrics.soles.sole_tracks` of the motion.
        config: thresholds.

    Returns:
        Contacts with the (T, 2) [left, right] support mask.
    """
    config = config or SupportDetection()
    T = soles.n_frames
    support = np.zeros((T, 2), dtype=bool)
    for k, side in enumerate(SIDES):
        support[:, k] = config.phases.support(soles.lowest(side), soles.speed(side),
                                              config.height_m, config.speed_mps, soles.fps)
    return Contacts(support=support, fps=soles.fps)


def planted_feet(soles: SoleTracks, config: SupportDetection | None = None) -> np.ndarray:
    """(T, 2) bool feet that are *kinematically* planted whatever their height: slow and the
    lower foot (or within ``height_m`` of it). Used to tell a robot floating above the ground
    from a robot in a flight phase."""
    config = config or SupportDetection()
    lows = np.stack([soles.lowest(s) for s in SIDES], axis=1)
    speeds = np.stack([soles.speed(s) for s in SIDES], axis=1)
    lowest = lows.min(axis=1, keepdims=True)
    return (speeds < config.speed_mps) & (lows < lowest + config.height_m)
