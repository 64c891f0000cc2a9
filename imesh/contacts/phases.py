"""Contact states: swing/support phases of each foot, slides, pivots and flight phases.

Nakaoka & Komura 2012 sec. V-A: a foot is in support while its toe (and ankle) markers are low
and slow. Detection uses hysteresis (stricter thresholds to enter a support phase than to stay
in it) and a minimum phase duration, so marker noise does not chatter the states.

Low and slow is a *planted* foot. Where no foot is planted, the clip is not yet in flight
(:class:`FlightConfig`):

- a foot at ground height (toe or ankle within ``ground_fraction`` of the body height of its
  own floor, the marker's 5th percentile over the clip) is on the ground whether or not it
  moves: a moving contact is a **slide**, or a **pivot** when the foot turns faster than
  ``pivot_rad_s`` about its vertical (a spin on the ball of the foot);
- frames with no foot at ground height are **flight** only where the body falls as physics has
  it: a parabola fitted to the height of the trunk's centroid (pelvis, hips, spine, chest,
  neck) over the phase bends down by at least ``ballistic_fraction`` of g. Otherwise a foot
  carries the body whose markers read high (a dancer on the ball of the foot, a marker set off
  the skin): the lower foot is in contact, held still (it is off the floor in the clip, so
  its motion there tells no slide: the salsa's hop, partner A's hands in its partner's).

Within a planted phase a foot whose toe travels more than ``slide_m`` at more than
``slide_speed_fraction`` body heights per second (for at least ``PhaseFilter.min_phase_s``) also
slides (a moonwalk, a stylized walk's dragged foot).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from ..core.checks import require_finite
from ..core.motion import MarkerMotion
from ..errors import OptionError

#: Gravity [m/s^2].
GRAVITY = 9.81

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
class FlightConfig:
    """How frames without a planted foot are told apart: slide, pivot or flight (see the module
    docstring).

    Attributes:
        ground_fraction: a foot marker within this fraction of the body height of its floor
            (its 5th percentile over the clip) is on the ground, moving or not ...
        rise_fraction: ... unless it rises or falls faster than this many body heights per
            second (a runner's toe just after toe-off, a heel just before touch-down).
        ballistic_fraction: frames with no foot on the ground are flight only when the markers'
            centroid falls with at least this fraction of g over them (the clip's scale makes
            a real flight fall at its scale times g: 0.6-0.8 g at robot size).
        push_fraction: the first and last frames of such a phase in which the trunk's centroid
            still accelerates upward by more than this fraction of g are carried by the ground
            (the push of a take-off, the catch of a landing: a low-passed foot leaves its
            floor a frame early, and only the ground can push the trunk up).
        pivot_rad_s: a moving contact whose foot turns faster than this about the vertical is
            a pivot, otherwise a slide [rad/s].
        slide_speed_fraction: a planted foot whose toe moves faster than this many body heights
            per second ...
        slide_s: ... for at least this long [s] ...
        slide_m: ... and is carried more than this is a slide [m] (a heel strike or toe-off
            rolls the markers a few centimetres in a tenth of a second: no slide).
    """

    ground_fraction: float = 0.04
    rise_fraction: float = 0.25
    ballistic_fraction: float = 0.5
    push_fraction: float = 0.25
    pivot_rad_s: float = 1.5
    slide_speed_fraction: float = 0.1
    slide_s: float = 0.2
    slide_m: float = 0.1

    def __post_init__(self) -> None:
        require_finite(self, ("ground_fraction", "rise_fraction", "ballistic_fraction",
                              "push_fraction", "pivot_rad_s", "slide_speed_fraction",
                              "slide_s", "slide_m"),
                       positive=True)


@dataclass(frozen=True)
class ContactConfig:
    """Thresholds of the contact detection (relative to the body height where it helps).

    Attributes:
        height_fraction: a foot marker is low when it is within this fraction of the body
            height above its own resting height (its 5th percentile over the clip).
        speed_fraction: a foot is slow when its toe moves slower than this many body heights per
            second (0.5 -> 0.7 m/s for a 1.4 m joint-extent height).
        phases: hysteresis and minimum phase duration.
        flight: how slides, pivots and flight are told apart where no foot is planted.
    """

    height_fraction: float = 0.04
    speed_fraction: float = 0.5
    phases: PhaseFilter = field(default_factory=PhaseFilter)
    flight: FlightConfig = field(default_factory=FlightConfig)

    def __post_init__(self) -> None:
        require_finite(self, ("height_fraction", "speed_fraction"), positive=True)


#: Contact modes of a foot in a frame (:attr:`Contacts.modes`).
SWING, STANCE, SLIDE, PIVOT = 0, 1, 2, 3
MODE_NAMES = ("swing", "stance", "slide", "pivot")


@dataclass(frozen=True, eq=False)
class Contacts:
    """Support timeline of both feet.

    Attributes:
        support: (T, 2) bool, [left, right] foot on the ground (planted, sliding or pivoting).
        fps: frame rate [1/s].
        sliding: (T, 2) bool support frames in which the foot moves on the ground (a slide or
            a pivot); None: none.
        pivoting: (T, 2) bool the sliding frames in which the foot turns about a point; None:
            none.
        inferred: (T, 2) bool support frames in which the foot is off the floor in the clip
            but carries the body (no foot at ground height, no free fall): the robot's foot
            holds still where it last stood (:func:`imesh.solve.sqp.plan_whole_body`); None:
            none.
    """

    support: np.ndarray
    fps: float
    sliding: np.ndarray | None = None
    pivoting: np.ndarray | None = None
    inferred: np.ndarray | None = None

    def within(self, support: np.ndarray) -> Contacts:
        """These contacts on a (T, 2) bool ``support`` that is a subset of theirs (the sliding,
        pivoting and inferred frames kept where it holds)."""
        def keep(mask):
            return None if mask is None else mask & support

        return Contacts(support=support, fps=self.fps, sliding=keep(self.sliding),
                        pivoting=keep(self.pivoting), inferred=keep(self.inferred))

    @property
    def modes(self) -> np.ndarray:
        """(T, 2) int8 per foot and frame: SWING, STANCE, SLIDE or PIVOT."""
        out = np.where(self.support, STANCE, SWING).astype(np.int8)
        if self.sliding is not None:
            out[self.sliding & self.support] = SLIDE
        if self.pivoting is not None:
            out[self.pivoting & self.support] = PIVOT
        return out

    @classmethod
    def from_modes(cls, modes: np.ndarray, fps: float) -> Contacts:
        """The timeline of (T, 2) per-foot :attr:`modes` (e.g. a motion's stored
        ``RobotMotion.contact_modes``); ``Contacts.from_modes(c.modes, c.fps)`` equals ``c``."""
        modes = np.asarray(modes)
        return cls(support=modes != SWING, fps=float(fps),
                   sliding=(modes == SLIDE) | (modes == PIVOT), pivoting=modes == PIVOT)

    @property
    def moving(self) -> np.ndarray:
        """(T, 2) bool support frames in which the foot slides or pivots."""
        if self.sliding is None:
            return np.zeros_like(np.asarray(self.support, dtype=bool))
        return np.asarray(self.sliding, dtype=bool) & self.support

    def timeline(self, side: str) -> list[tuple[str, int, int]]:
        """(mode name, start, stop) runs of one foot's modes, in order."""
        m = self.modes[:, SIDES.index(side)]
        edges = np.flatnonzero(np.diff(m)) + 1
        starts = np.r_[0, edges]
        stops = np.r_[edges, len(m)]
        return [(MODE_NAMES[m[a]], int(a), int(b)) for a, b in zip(starts, stops, strict=True)]

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
        moving = self.moving
        piv = (np.zeros_like(moving) if self.pivoting is None
               else np.asarray(self.pivoting, dtype=bool) & moving)
        return {
            "footfalls": self.footfalls(),
            "support_phases": {side: self.phases(side) for side in SIDES},
            "flight_phases": self.flight_phases(),
            "slide_phases": {side: runs(moving[:, k] & ~piv[:, k])
                             for k, side in enumerate(SIDES)},
            "pivot_phases": {side: runs(piv[:, k]) for k, side in enumerate(SIDES)},
            "timeline": {side: self.timeline(side) for side in SIDES},
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


def _foot_tracks(motion: MarkerMotion) -> tuple[np.ndarray, ...]:
    """Per foot the lift of its lower marker above that marker's floor, that marker's speed,
    its velocity and the foot's yaw rate.

    Returns:
        (lift (T, 2) [m], speed (T, 2) [m/s], velocity (T, 2, 3) [m/s], yaw_rate (T, 2)
        [rad/s], 0 where the foot points more than 60 deg up or down), columns [left, right].
    """
    dt = 1.0 / motion.fps
    T = motion.n_frames
    lift, speed = np.zeros((T, 2)), np.zeros((T, 2))
    vel, yaw_rate = np.zeros((T, 2, 3)), np.zeros((T, 2))
    rows = np.arange(T)
    for k, side in enumerate(SIDES):
        p = motion.positions_m[:, motion.indices(FOOT_MARKERS[side])]  # (T, 2, 3) toe, ankle
        floor = np.percentile(p[..., 2], 5, axis=0)  # the clip's own floor of each marker
        lifts = p[..., 2] - floor
        lower = np.argmin(lifts, axis=1)  # the marker nearer the ground carries the foot:
        lift[:, k] = lifts[rows, lower]  # the heel at heel strike, the toe at toe-off
        v = np.gradient(p, dt, axis=0)
        speed[:, k] = np.linalg.norm(v, axis=2)[rows, lower]
        vel[:, k] = v[rows, lower]
        d = p[:, 1] - p[:, 0]
        rate = np.gradient(np.unwrap(np.arctan2(d[:, 1], d[:, 0])), dt)
        level = np.linalg.norm(d[:, :2], axis=1) > 0.5 * np.linalg.norm(d, axis=1)
        yaw_rate[:, k] = np.where(level, rate, 0.0)
    return lift, speed, vel, yaw_rate


#: The trunk's markers: the body's heaviest part, whose centroid stands in for the CoM when
#: telling a flight by its fall (the feet and hands of a leap move on their own).
TRUNK_MARKERS = ("pelvis", "hip_l", "hip_r", "spine", "chest", "neck")


def _trunk_height(motion: MarkerMotion) -> np.ndarray:
    """(T,) height of the trunk's centroid [m] (all markers' if the motion names no trunk)."""
    trunk = [i for i, n in enumerate(motion.names) if n in TRUNK_MARKERS]
    return motion.positions_m[:, trunk or slice(None)].mean(axis=1)[:, 2]


def _pushed_ends(accel_z: np.ndarray, start: int, stop: int, push: float) -> tuple[int, int]:
    """The frames [start, stop) less their leading and trailing runs in which the trunk
    accelerates upward by more than ``push`` [m/s^2] (``accel_z``: (T,) its vertical
    acceleration): the ground still pushes there."""
    a, b = start, stop
    while a < b and accel_z[a] > push:
        a += 1
    while b > a and accel_z[b - 1] > push:
        b -= 1
    return a, b


def _falls_freely(z: np.ndarray, fps: float, start: int, stop: int, fraction: float) -> bool:
    """Whether the trunk's centroid height ``z`` (T,) [m] falls with at least ``fraction`` of g
    over the frames [start, stop) (one more frame either side for a phase shorter than 4
    frames): the curvature of a least-squares parabola through it."""
    a, b = start, stop
    if b - a < 4:
        a, b = max(start - 1, 0), min(stop + 1, len(z))
    if b - a < 3:
        return False  # one or two frames: nothing to tell a fall by
    t = np.arange(b - a) / fps
    accel = 2.0 * np.polyfit(t, z[a:b], 2)[0]
    return bool(accel <= -fraction * GRAVITY)


def detect_contacts(motion: MarkerMotion, config: ContactConfig | None = None) -> Contacts:
    """Stance, slide, pivot and flight of both feet from toe and ankle markers.

    Args:
        motion: a motion with markers toe_l, ankle_l, toe_r, ankle_r (standard or arranged;
            names may carry a performer prefix only for single-performer motions).
        config: thresholds.

    Returns:
        Contacts with the (T, 2) support mask (planted, sliding or pivoting) and the sliding
        and pivoting frames.
    """
    config = config or ContactConfig()
    fc = config.flight
    height = motion.height_m
    fps = motion.fps
    lift, speed, vel, yaw_rate = _foot_tracks(motion)
    h_max = config.height_fraction * height
    planted = np.stack([config.phases.support(lift[:, k], speed[:, k], h_max,
                                              config.speed_fraction * height, fps)
                        for k in range(2)], axis=1)
    # a foot at ground height is on the ground whether or not it moves along it (its vertical
    # speed only: a toe leaving the ground rises)
    grounded = np.stack([config.phases.support(lift[:, k], np.abs(vel[:, k, 2]),
                                               fc.ground_fraction * height,
                                               fc.rise_fraction * height, fps)
                         for k in range(2)], axis=1)
    unplanted = np.logical_not(planted.any(axis=1))
    support = planted | (grounded & unplanted[:, None])
    # a foot that leaves its support for at most slide_s without ever leaving the ground
    # slides through (a shuffle: the zombie walk's dragged feet); a step rises above it or
    # lasts longer (a walk's swing at 30 fps: 12 frames)
    shuffled = np.zeros_like(support)
    gap_max = max(1, int(round(fc.slide_s * fps)))
    for k in range(2):
        for a, b in runs(np.logical_not(support[:, k])):
            if 0 < a and b < len(support) and b - a <= gap_max and grounded[a:b, k].all():
                shuffled[a:b, k] = True
    support |= shuffled
    # frames with no foot on the ground: flight only where the body falls freely, and not in
    # the frames at its ends where the ground still pushes the trunk up (those keep the feet
    # on the ground next to them)
    z = _trunk_height(motion)
    accel_z = np.gradient(np.gradient(z, 1.0 / fps), 1.0 / fps)
    carried = np.zeros_like(support)  # support inferred where no foot is at ground height
    for start, stop in runs(np.logical_not(support.any(axis=1))):
        a, b = _pushed_ends(accel_z, start, stop, fc.push_fraction * GRAVITY)
        before = support[start - 1] if start > 0 else None
        after = support[stop] if stop < len(support) else None
        if b > a and _falls_freely(z, fps, a, b, fc.ballistic_fraction) and (
                before is not None or after is not None or (a, b) == (start, stop)):
            support[start:a] = before if before is not None else after
            support[b:stop] = after if after is not None else before
        else:
            k = int(np.argmin(lift[start:stop].mean(axis=0)))  # the lower foot carries it
            support[start:stop, k] = True
            carried[start:stop, k] = True
    support = np.stack([drop_short(support[:, k], 1) for k in range(2)], axis=1)
    # moving contacts: off the planted frames where the foot moves or turns, and within
    # planted phases where the toe travels
    # planted and not ground-height frames, held still: a foot inferred to carry a body that
    # does not fall freely is off the floor in the clip and does not slide there (the salsa's
    # hop, its partner holding its hands: the right toe 8-20 cm up moves at 4-9 m/s)
    vel_xy = vel[..., :2]
    fast = (support & ~carried
            & (np.linalg.norm(vel_xy, axis=2) > fc.slide_speed_fraction * height))
    moving = (support & ~planted & ~carried
              & (fast | (np.abs(yaw_rate) > fc.pivot_rad_s) | shuffled))
    min_frames = max(1, int(round(fc.slide_s * fps)))
    for k in range(2):
        for a, b in runs(fast[:, k]):
            # the farthest the toe gets from where the run starts (a slide may turn back)
            travel = np.linalg.norm(np.cumsum(vel_xy[a:b, k], axis=0), axis=1).max() / fps
            if b - a >= min_frames and travel > fc.slide_m:
                moving[a:b, k] = True
    pivoting = moving & (np.abs(yaw_rate) > fc.pivot_rad_s)
    contacts = Contacts(support=support, fps=fps, sliding=moving, pivoting=pivoting,
                        inferred=carried & support)
    log.info("%s: %d footfalls, %d flight phases, %d slide and %d pivot frames", motion.source,
             contacts.footfalls(), len(contacts.flight_phases()),
             int((moving & ~pivoting).sum()), int(pivoting.sum()))
    return contacts
