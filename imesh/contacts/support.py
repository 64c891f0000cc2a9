"""Support-foot constraints for the morph (Nakaoka & Komura 2012, sec. V-B).

During a support phase the foot markers (toe and ankle) get positional targets:

- vertical (hard): the height of the matching robot key point when the robot stands flat (its
  sole at z = 0), reached gradually over the morph steps (hard targets are interpolated from the
  source to these values, sec. V-B);
- horizontal (soft, large weight): a fixed footprint, so the support foot does not skate. The
  footprint is the median of the source toe over the phase, with the toe-ankle vector shortened
  or lengthened to the robot's foot so the targets agree with the bone. A source foot that
  really slides (its toe travels more than ``slide_threshold_m`` over the middle half of the
  phase; the first and last quarters are heel strike and toe-off, where a rolling human foot
  moves its markers although it does not slide) keeps its horizontal motion. Soft, because in
  double support the robot's legs (other proportions, other hip width) cannot always reach two
  pinned human footprints exactly, and a hard constraint there would make the morph infeasible;
  the weight keeps the slip sub-millimetre.

A robot foot is flat and rigid, a human foot rolls: the human toe is still descending when the
detector declares support (heel strike) and the heel rises long before the toe leaves (toe-off).
Switching the targets on and off in one frame would ask the morph for a step in the foot markers,
which the robot can only follow with joint accelerations of several hundred rad/s^2. So the
targets are blended in over ``FootRampConfig.duration_s`` before a phase and out over as long
after it: ``target = (1 - s) source + s pinned`` with a smoothstep s from 0 to 1.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.checks import require_finite
from ..core.motion import MarkerMotion
from ..errors import OptionError
from .phases import FOOT_MARKERS, SIDES, Contacts, runs


@dataclass(frozen=True)
class FlatFootConfig:
    """Which part of a support phase the robot's foot is held flat.

    Attributes:
        pitch_deg: the robot's foot is held flat only while the source foot's pitch (the toe ->
            ankle vector against the horizontal) is within this of its value in the middle of
            the support phase: a human heel that rises (toe-off) or a toe still coming down
            (heel strike) hand the robot foot to the ramps, which pivot it about the toe,
            instead of pinning a flat foot against a vertical human foot [deg].
        stand_s: a support phase longer than this is a standing foot, held flat from end to
            end [s]: a robot cannot stand on its toes, and lifting the foot instead (keeping
            only the flat part) leaves the robot on one foot where the person stands on two
            (CMU wave: the right foot rests on its toes for a second; flat part only: key
            points 190 mm RMS on G1 after the whole-body solve, whole phase: 73 mm).
        double_support: the foot is also held flat through the source's double support at
            either end of its phase (and from there to its flat part): the weight passes from
            one foot to the other in double support, which a human spends on a heel and a
            toe (neither foot flat). Cut to the flat parts, the CMU walk's 3-4 frames of
            double support became 0-2 at 30 fps, and a controller had one frame to move the
            robot's weight from the rear sole to the front one.
    """

    pitch_deg: float = 20.0
    stand_s: float = 1.5
    double_support: bool = True

    def __post_init__(self) -> None:
        if not (np.isfinite(self.pitch_deg) and 0 < self.pitch_deg <= 90):
            raise OptionError("pitch_deg", self.pitch_deg, "a number in (0, 90]")
        require_finite(self, ("stand_s",), positive=True)


@dataclass(frozen=True)
class FootRampConfig:
    """The blends of the support-foot targets in before and out after each flat phase.

    Attributes:
        duration_s: blend the targets in over this time before each phase and out after it
            [s].
        max_pitch_deg: largest foot pitch the ramps ask for [deg] (a foot near vertical makes
            the hard heights and the foot bone nearly dependent: the morph's constraint solve
            stalls; seen on HRP-4C with the CMU veer at 88 deg, and on its walk at 85; 50 made
            the targets kink where the cap bites and the fit chatter at toe-off).
    """

    duration_s: float = 0.12
    max_pitch_deg: float = 80.0

    def __post_init__(self) -> None:
        require_finite(self, ("duration_s",), positive=False)


@dataclass(frozen=True)
class SupportConfig:
    """Support-foot targets of the morph.

    Attributes:
        horizontal: also pin the support foot horizontally (no skating).
        slide_threshold_m: a source toe travelling more than this over the middle half of a
            support phase is sliding for real and keeps its horizontal motion [m].
        horizontal_weight: weight of the soft horizontal targets (the Laplacian rows weigh ~1).
        flat: the part of each support phase where the robot's foot is flat.
        ramp: the blends in and out of the targets around it.
    """

    horizontal: bool = True
    slide_threshold_m: float = 0.05
    horizontal_weight: float = 1e3
    flat: FlatFootConfig = field(default_factory=FlatFootConfig)
    ramp: FootRampConfig = field(default_factory=FootRampConfig)

    def __post_init__(self) -> None:
        require_finite(self, ("slide_threshold_m", "horizontal_weight"), positive=True)


def middle_half(start: int, stop: int) -> tuple[int, int]:
    """[q1, q3) the middle half of a phase [start, stop) (at least one frame)."""
    return start + (stop - start) // 4, start + (3 * (stop - start)) // 4 + 1


def phase_blend(n_frames: int, phases: list[tuple[int, int]], ramp: int
           ) -> tuple[np.ndarray, np.ndarray]:
    """(T,) blend factor s in [0, 1] and (T,) index of the phase it belongs to (-1: none).

    s = 1 inside a phase, a smoothstep ``3u^2 - 2u^3`` over ``ramp`` frames before and after it;
    where the ramps of two phases overlap, the nearer phase (larger s) wins.
    """
    s = np.zeros(n_frames)
    owner = np.full(n_frames, -1, dtype=np.int64)
    t = np.arange(n_frames)
    for k, (start, stop) in enumerate(phases):
        if ramp > 0:
            before = (start - t) / (ramp + 1.0)  # 0 at start, 1 at the ramp's far end
            after = (t - (stop - 1)) / (ramp + 1.0)
            u = np.clip(1.0 - np.maximum(before, after), 0.0, 1.0)
            val = u * u * (3.0 - 2.0 * u)
        else:
            val = np.zeros(n_frames)
        val[start:stop] = 1.0
        better = val > s
        s = np.where(better, val, s)
        owner = np.where(better, k, owner)
    return s, owner


def flat_support(motion: MarkerMotion, contacts: Contacts,
                 config: SupportConfig | None = None) -> Contacts:
    """The part of each support phase in which the source foot is flat (the robot's support).

    A frame of a support phase is flat when the foot's pitch, ``atan2(z_ankle - z_toe,
    |xy_ankle - xy_toe|)``, is within ``config.flat.pitch_deg`` of its median over the middle
    half of the phase. Each phase keeps its longest flat run, so the number of footfalls is the
    source's; a phase without one (a toe walk) keeps its middle half. Frames in which the
    source stands but neither foot is flat keep the source's support (no flight the source
    does not have).

    Args:
        motion: the source with toe_* and ankle_* markers.
        contacts: support phases of the source (:func:`imesh.contacts.phases.detect_contacts`).
        config: SupportConfig.

    Returns:
        Contacts whose support mask is a subset of ``contacts.support`` (its sliding and
        pivoting frames those of ``contacts`` within it).
    """
    config = config or SupportConfig()
    pos = motion.positions_m
    flat = np.zeros_like(contacts.support)
    for k, side in enumerate(SIDES):
        toe, ankle = (motion.index(m) for m in FOOT_MARKERS[side])
        d = pos[:, ankle] - pos[:, toe]
        pitch = np.degrees(np.arctan2(d[:, 2], np.linalg.norm(d[:, :2], axis=1)))
        for start, stop in contacts.phases(side):
            if stop - start > config.flat.stand_s * motion.fps:
                flat[start:stop, k] = True
                continue
            q1, q3 = middle_half(start, stop)
            ref = np.median(pitch[q1:q3])
            ok = np.abs(pitch[start:stop] - ref) <= config.flat.pitch_deg
            a, b = max(((a + start, b + start) for a, b in runs(ok)),
                       key=lambda r: r[1] - r[0], default=(q1, q3))
            if config.flat.double_support:
                other = contacts.support[:, 1 - k]
                a = start if other[start] else a  # lands while the other foot still stands
                b = stop if other[stop - 1] else b  # leaves after the other foot landed
            flat[a:b, k] = True
    # the human stands on a toe or a heel only (no flat part in either foot): the robot stands
    # flat there, where a cut would make a flight the human never had
    bare = contacts.support.any(axis=1) & ~flat.any(axis=1)
    flat[bare] = contacts.support[bare]
    return contacts.within(flat)


def support_blend(contacts: Contacts, ramp_s: float) -> np.ndarray:
    """(T, 2) float [left, right] in [0, 1]: 1 in support, the smoothstep ramps of
    :class:`SupportConfig` around it, 0 in swing (how strongly each foot is held flat)."""
    ramp = int(round(ramp_s * contacts.fps))
    n = len(contacts.support)
    return np.stack([phase_blend(n, contacts.phases(side), ramp)[0] for side in SIDES], axis=1)


def support_foot_targets(motion: MarkerMotion, contacts: Contacts,
                         foot_heights_m: dict[str, float], foot_lengths_m: dict[str, float],
                         config: SupportConfig | None = None
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positional targets for the support feet.

    Args:
        motion: the (arranged, scaled) source motion with toe_* and ankle_* markers.
        contacts: support phases.
        foot_heights_m: marker name (toe_l, ankle_l, ...) -> height of its robot key point above
            the floor when the robot stands flat [m].
        foot_lengths_m: side -> robot toe-ankle distance [m].
        config: SupportConfig.

    Returns:
        (hard (T, M, 3) vertical targets, soft (T, M, 3) horizontal targets, soft weights
        (T, M)); NaN where free.
    """
    config = config or SupportConfig()
    pos = motion.positions_m
    targets = np.full(pos.shape, np.nan)
    soft = np.full(pos.shape, np.nan)
    weights = np.zeros(pos.shape[:2])
    ramp = int(round(config.ramp.duration_s * motion.fps))
    for side in SIDES:
        toe_name, ankle_name = FOOT_MARKERS[side]
        toe, ankle = motion.index(toe_name), motion.index(ankle_name)
        h_toe, h_ankle = foot_heights_m[toe_name], foot_heights_m[ankle_name]
        length = foot_lengths_m[side]
        horizontal_len = np.sqrt(max(length ** 2 - (h_toe - h_ankle) ** 2, 0.0))
        phases = contacts.phases(side)
        if not phases:
            continue
        s, owner = phase_blend(motion.n_frames, phases, ramp)
        on = np.flatnonzero(owner >= 0)
        # the pinned foot of every phase: toe position and the unit toe -> ankle vector of a
        # flat robot foot; horizontally the phase's footprint, or the source where it slides
        src_toe, src_ankle = pos[on, toe], pos[on, ankle]
        back_src = src_ankle[:, :2] - src_toe[:, :2]
        pin_toe = np.empty((len(on), 3))
        pin_toe[:, 2] = h_toe
        pin_toe[:, :2] = src_toe[:, :2]
        pin_back = back_src.copy()
        pinned = np.zeros(len(on), dtype=bool)
        if config.horizontal:
            for k, (start, stop) in enumerate(phases):
                q1, q3 = middle_half(start, stop)
                middle = pos[q1:q3, toe, :2]
                if (np.linalg.norm(middle - middle[0], axis=1).max() > config.slide_threshold_m
                        or contacts.moving[start:stop, SIDES.index(side)].any()):
                    continue  # the source foot really slides (or pivots)
                mine = owner[on] == k
                pin_toe[mine, :2] = np.median(pos[start:stop, toe, :2], axis=0)
                pin_back[mine] = np.median(pos[start:stop, ankle, :2] - pos[start:stop, toe, :2],
                                           axis=0)
                pinned |= mine
        norm = np.linalg.norm(pin_back, axis=1, keepdims=True)
        pin_back = np.where(norm > 1e-9, pin_back / np.maximum(norm, 1e-12), [-1.0, 0.0])
        pin_u = np.concatenate([horizontal_len * pin_back,
                                np.full((len(on), 1), h_ankle - h_toe)], axis=1) / length
        src_u = src_ankle - src_toe
        src_u /= np.maximum(np.linalg.norm(src_u, axis=1, keepdims=True), 1e-9)
        # Blend the foot as a rigid body of the robot's length (toe position and direction),
        # not marker by marker: a human heel 15 cm above the toe at toe-off, blended with the
        # robot's flat foot, would ask for a toe-ankle distance the robot's foot bone cannot
        # have, and the morph would turn the foot over to meet both hard constraints.
        sb = s[on, None]
        toe_t = (1.0 - sb) * src_toe + sb * pin_toe
        u = (1.0 - sb) * src_u + sb * pin_u
        u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-9)
        # a foot near vertical (the human's at toe-off) makes the toe-ankle bone and the two
        # hard heights nearly dependent: cap the ramp's foot pitch
        zmax = np.sin(np.radians(config.ramp.max_pitch_deg))
        uz = np.clip(u[:, 2], -zmax, zmax)
        horiz = u[:, :2]
        hn = np.linalg.norm(horiz, axis=1, keepdims=True)
        horiz = np.where(hn > 1e-9, horiz / np.maximum(hn, 1e-12), pin_back)
        u = np.concatenate([horiz * np.sqrt(1.0 - uz * uz)[:, None], uz[:, None]], axis=1)
        ankle_t = toe_t + length * u
        targets[on, toe, 2] = toe_t[:, 2]
        targets[on, ankle, 2] = ankle_t[:, 2]
        if pinned.any():
            rows = on[pinned]
            soft[rows, toe, :2] = toe_t[pinned, :2]
            soft[rows, ankle, :2] = ankle_t[pinned, :2]
            weights[rows, toe] = weights[rows, ankle] = config.horizontal_weight
    return targets, soft, weights
