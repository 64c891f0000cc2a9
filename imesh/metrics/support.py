"""Support phases of a robot motion from its own soles.

A foot is in support while the lowest corner of its sole is within ``SupportDetection.height_m``
of the ground (z = 0) and its sole centre is slow, with hysteresis and a minimum phase duration
(as :func:`imesh.contacts.phases.detect_contacts` does for markers). With ``slide_s`` set (the
evaluator's :data:`EVALUATOR_SUPPORT`), a sole that lies flat on the ground (every corner
within ``height_m``) for at least ``slide_s`` is in support however fast it moves: it slides,
and it carries the body as a planted sole does (the ZMP is judged against it; a swing sole
skims the ground that low and that long only where it drags). No
source markers are needed, so motions from other retargeting tools are scored on the same
terms.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..contacts.phases import SIDES, Contacts, PhaseFilter, runs
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
        slide_s: a sole flat on the ground (every corner within ``height_m``) this long is in
            support whatever its speed: a slide [s]; None: only slow soles are (the solve's
            torque rows and the DART check's reference keep that, as before issue 31).
    """

    height_m: float = 0.01
    speed_mps: float = 0.5
    phases: PhaseFilter = field(default_factory=lambda: PhaseFilter(min_phase_s=0.05))
    slide_s: float | None = None

    def __post_init__(self) -> None:
        require_finite(self, ("height_m", "speed_mps"), positive=True)
        if self.slide_s is not None:
            require_finite(self, ("slide_s",), positive=True)


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
        if config.slide_s is None:
            continue
        slide = max(1, int(round(config.slide_s * soles.fps)))
        flat = np.asarray((soles.corners[side][..., 2] < config.height_m).all(axis=1))
        for a, b in runs(flat):
            if b - a >= slide:
                support[a:b, k] = True
    return Contacts(support=support, fps=soles.fps)


def motion_support(soles: SoleTracks, contact_modes: np.ndarray | None = None,
                   config: SupportDetection | None = None) -> Contacts:
    """The support phases a robot motion is judged by: its planned ones when it carries them
    (``RobotMotion.contact_modes``, written by the whole-body solve), else detected from its
    soles (:func:`detect_support`, e.g. for another tool's output).

    The plan is the better judge where it is known: a swing sole it keeps 12-20 mm up for a
    few frames before a landing is not support, however flat and slow it is there, and a slide
    it plans is one (the detection reads both from heights and speeds alone).

    Args:
        soles: :func:`~imesh.metrics.soles.sole_tracks` of the motion.
        contact_modes: (T, 2) int [left, right] planned contact modes, or None.
        config: thresholds of the detection (used without ``contact_modes``).
    """
    if contact_modes is None:
        return detect_support(soles, config)
    return Contacts.from_modes(contact_modes, soles.fps)


#: The evaluator's support detection (``imesh evaluate``, the retarget gates): flat sliding
#: soles carry the body (issue 31: the zombie walk's planned slides at 0.5-1.0 m/s).
EVALUATOR_SUPPORT = SupportDetection(slide_s=0.2)


def planted_feet(soles: SoleTracks, config: SupportDetection | None = None) -> np.ndarray:
    """(T, 2) bool feet that are *kinematically* planted whatever their height: slow and the
    lower foot (or within ``height_m`` of it). Used to tell a robot floating above the ground
    from a robot in a flight phase."""
    config = config or SupportDetection()
    lows = np.stack([soles.lowest(s) for s in SIDES], axis=1)
    speeds = np.stack([soles.speed(s) for s in SIDES], axis=1)
    lowest = lows.min(axis=1, keepdims=True)
    return (speeds < config.speed_mps) & (lows < lowest + config.height_m)
