"""Contact states: swing/support phases of each foot, double support and flight phases.

Nakaoka & Komura 2012 sec. V-A: a foot is in support while its toe (and ankle) markers are low
and slow. Detection uses hysteresis (stricter thresholds to enter a support phase than to stay
in it) and a minimum phase duration, so marker noise does not chatter the states.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from ..core.checks import require_finite
from ..core.motion import MarkerMotion
from ..errors import OptionError

log = logging.getLogger(__name__)

SIDES = ("left", "right")
FOOT_MARKERS = {"left": ("toe_l", "ankle_l"), "right": ("toe_r", "ankle_r")}


@dataclass(frozen=True)
class PhaseFilter:
    """How a foot's thresholded support is kept from chattering: hysteresis and a minimum phase
    duration (shared by the marker detection here and the sole detection of
    :mod:`imesh.metrics.support`).

    Attributes:
        hysteresis: to leave support the height/speed must exceed the thresholds times this.
        min_phase_s: support and swing phases shorter than this are merged into their
            neighbours [s].
    """

    hysteresis: float = 1.5
    min_phase_s: float = 0.08

    def __post_init__(self) -> None:
        require_finite(self, ("min_phase_s",), positive=True)
        if not self.hysteresis >= 1.0:
            raise OptionError("hysteresis", self.hysteresis, "a number >= 1")

    def support(self, height: np.ndarray, speed: np.ndarray, height_max: float,
                speed_max: float, fps: float) -> np.ndarray:
        """(T,) bool support of one foot.

        Args:
            height: (T,) height of the foot above the ground (or its resting height) [m].
            speed: (T,) speed of the foot [m/s].
            height_max: the foot enters support below this height [m] ...
            speed_max: ... and this speed [m/s]; it stays while both are below ``hysteresis``
                times these.
            fps: frame rate [1/s].

        Returns:
            (T,) bool support mask with phases shorter than ``min_phase_s`` merged.
        """
        enter = (height < height_max) & (speed < speed_max)
        stay = (height < height_max * self.hysteresis) & (speed < speed_max * self.hysteresis)
        return drop_short(hysteresis(enter, stay), max(1, int(round(self.min_phase_s * fps))))


@dataclass(frozen=True)
class ContactConfig:
    """Thresholds of the contact detection (relative to the body height where it helps).

    Attributes:
        height_fraction: a foot marker is low when it is within this fraction of the body
            height above its own resting height (its 5th percentile over the clip).
        speed_fraction: a foot is slow when its toe moves slower than this many body heights per
            second (0.5 -> 0.7 m/s for a 1.4 m joint-extent height).
        phases: hysteresis and minimum phase duration.
    """

    height_fraction: float = 0.04
    speed_fraction: float = 0.5
    phases: PhaseFilter = field(default_factory=PhaseFilter)

    def __post_init__(self) -> None:
        require_finite(self, ("height_fraction", "speed_fraction"), positive=True)


@dataclass(frozen=True, eq=False)
class Contacts:
    """Support timeline of both feet.

    Attributes:
        support: (T, 2) bool, [left, right] foot in support.
        fps: frame rate [1/s].
    """

    support: np.ndarray
    fps: float

    @property
    def double_support(self) -> np.ndarray:
        return np.asarray(self.support.all(axis=1))

    @property
    def flight(self) -> np.ndarray:
        """(T,) bool, no foot on the ground."""
        return ~np.asarray(self.support.any(axis=1))

    def phases(self, side: str) -> list[tuple[int, int]]:
        """Support phases [start, stop) of one foot."""
        return runs(self.support[:, SIDES.index(side)])

    def flight_phases(self) -> list[tuple[int, int]]:
        return runs(self.flight)

    def footfalls(self) -> int:
        """Number of support phases that start after the first frame (touch-downs)."""
        return sum(1 for side in SIDES for start, _ in self.phases(side) if start > 0)

    def summary(self) -> dict:
        return {
            "footfalls": self.footfalls(),
            "support_phases": {side: self.phases(side) for side in SIDES},
            "flight_phases": self.flight_phases(),
            "double_support_fraction": float(self.double_support.mean()),
        }


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) of the True runs of a boolean vector."""
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    edges = np.flatnonzero(np.diff(m.astype(np.int8)))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def hysteresis(enter: np.ndarray, stay: np.ndarray) -> np.ndarray:
    """State that switches on where ``enter`` and stays on while ``stay`` (vectorized).

    On at t iff some s <= t has enter[s] and stay holds on all of [s, t].
    """
    t = np.arange(len(enter))
    last_enter = np.maximum.accumulate(np.where(enter, t, -1))
    last_break = np.maximum.accumulate(np.where(~stay, t, -1))
    return (last_enter >= 0) & (last_enter > last_break)


def drop_short(mask: np.ndarray, min_frames: int) -> np.ndarray:
    """Merge runs (of either value) shorter than min_frames into their neighbours.

    A True run (support) that touches the first or last frame is kept whatever its length: the
    recording cut it, its real duration is unknown (a heel strike in the clip's last frames is
    a footfall).
    """
    out = mask.copy()
    n = len(out)
    for value in (False, True):  # fill short gaps first, then drop short blips
        for a, b in runs(out == value):
            cut = value and (a == 0 or b == n)
            if b - a < min_frames and b - a < n and not cut:
                out[a:b] = not value
    return out


def detect_contacts(motion: MarkerMotion, config: ContactConfig | None = None) -> Contacts:
    """Swing/support phases of both feet from toe and ankle markers.

    Args:
        motion: a motion with markers toe_l, ankle_l, toe_r, ankle_r (standard or arranged;
            names may carry a performer prefix only for single-performer motions).
        config: thresholds.

    Returns:
        Contacts with the (T, 2) support mask.
    """
    config = config or ContactConfig()
    height = motion.height_m
    dt = 1.0 / motion.fps
    support = np.zeros((motion.n_frames, 2), dtype=bool)
    for k, side in enumerate(SIDES):
        idx = motion.indices(FOOT_MARKERS[side])
        p = motion.positions_m[:, idx]  # (T, 2, 3)
        rest = np.percentile(p[..., 2], 5, axis=0)  # resting height of toe and ankle
        lifts = p[..., 2] - rest  # (T, 2) toe and ankle above their rest
        lower = np.argmin(lifts, axis=1)  # the marker nearer the ground carries the foot:
        lift = lifts[np.arange(len(p)), lower]  # the heel at heel strike, the toe at toe-off
        speeds = np.linalg.norm(np.gradient(p, dt, axis=0), axis=2)
        speed = speeds[np.arange(len(p)), lower]
        support[:, k] = config.phases.support(lift, speed, config.height_fraction * height,
                                              config.speed_fraction * height, motion.fps)
    contacts = Contacts(support=support, fps=motion.fps)
    log.info("%s: %d footfalls, %d flight phases", motion.source, contacts.footfalls(),
             len(contacts.flight_phases()))
    return contacts
