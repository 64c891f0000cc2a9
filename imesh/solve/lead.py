"""Standing lead-in and lead-out: settled double support before and after the clip.

A controller has to start from rest and stop at rest, but mocap clips start and end in motion
(the CMU walk starts in single support with the CoM outside the stance sole). The whole-body
solve therefore gets ``n_in`` frames before the clip and ``n_out`` after it in which both feet
are in support: a foot in support at the clip's first (last) frame keeps that phase's footprint,
a foot in the air is put down under where it is (level, same heading) and swings over the
lead's last (first) ``step_frames`` into (out of) the clip. The initializer and the marker
targets hold the first (last) frame; the jump from rest into the clip's velocity is covered by
the elastic acceleration rows of the solve, which then moves the CoM over the support and the
swing foot into its first step with the ZMP inside the support polygon.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class Lead:
    """A clip extended by standing frames.

    Attributes:
        q: (n_in + T + n_out, nq) initializer.
        markers: (n_in + T + n_out, M, 3) marker targets [m].
        support: (n_in + T + n_out, 2) bool support, both feet in the added frames.
        n_in, n_out: added frames before and after the clip.
    """

    q: np.ndarray
    markers: np.ndarray
    support: np.ndarray
    n_in: int
    n_out: int


def add_lead(q: np.ndarray, markers: np.ndarray, support: np.ndarray, n_in: int,
             n_out: int, step_frames: int = 0, land_frames: int = 0) -> Lead:
    """Extend a clip by ``n_in`` standing frames before it and ``n_out`` after it.

    A foot in the air at the clip's first frame stands during the lead-in and swings over its
    last ``step_frames`` frames to where the clip has it (its targets are the first frame's);
    a foot in the air at the last frame swings over the lead-out's first ``step_frames``
    frames before it stands. Without this, the sole would have to leave the ground in one
    frame (the CMU wave starts with the right foot lifted and pitched 54 degrees).

    Args:
        q: (T, nq) initializer of the clip.
        markers: (T, M, 3) marker targets [m].
        support: (T, 2) bool planned support.
        n_in, n_out: frames to add (>= 0).
        step_frames: frames of those swings (at most half the lead).
        land_frames: a foot in the air at the clip's first frame that lands within this many
            frames (the end of a swing: the CMU walk starts 2 frames before a heel strike)
            stands through instead: its support runs from the lead-in into the clip's landing.
            Lifted in the lead-in, the robot would have to start walking from rest on its
            rear toe for the swing it does not take (0.5 s with the CoM 15 cm in front of the
            stance sole on the G1 walk). Alike for a foot that lifts within the clip's last
            ``land_frames`` frames.
    """
    def pad(a: np.ndarray) -> np.ndarray:
        return np.concatenate([np.repeat(a[:1], n_in, axis=0), a,
                               np.repeat(a[-1:], n_out, axis=0)])

    sup = pad(np.asarray(support, dtype=bool))
    sup[:n_in] = True
    sup[len(sup) - n_out:] = True
    T = len(support)
    for k in range(sup.shape[1]):
        down = np.flatnonzero(support[:, k])
        if n_in and not support[0, k]:
            if len(down) and down[0] <= land_frames:
                sup[n_in:n_in + down[0], k] = True
            else:
                sup[n_in - min(step_frames, n_in // 2):n_in, k] = False
        if n_out and not support[-1, k]:
            if len(down) and T - 1 - down[-1] <= land_frames:
                sup[n_in + down[-1]:n_in + T, k] = True
            else:
                sup[n_in + T:n_in + T + min(step_frames, n_out // 2), k] = False
    return Lead(q=pad(q), markers=pad(markers), support=sup, n_in=n_in, n_out=n_out)
