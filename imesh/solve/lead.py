"""Standing lead-in and lead-out: settled double support before and after the clip.

A controller has to start from rest and stop at rest, but mocap clips start and end in motion
(the CMU walk starts in single support with the CoM outside the stance sole). The whole-body
solve therefore gets ``n_in`` frames before the clip and ``n_out`` after it in which both feet
are in support: a foot in support at the clip's first (last) frame keeps that phase's footprint,
a foot in the air is put down under where it is. The initializer and the marker targets hold
the first (last) frame; the solve then moves the CoM over the support and the swing foot into
its first step within the joint limits and with the ZMP inside the support polygon.
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
             n_out: int) -> Lead:
    """Extend a clip by ``n_in`` standing frames before it and ``n_out`` after it.

    Args:
        q: (T, nq) initializer of the clip.
        markers: (T, M, 3) marker targets [m].
        support: (T, 2) bool planned support.
        n_in, n_out: frames to add (>= 0).
    """
    def pad(a: np.ndarray) -> np.ndarray:
        return np.concatenate([np.repeat(a[:1], n_in, axis=0), a,
                               np.repeat(a[-1:], n_out, axis=0)])

    sup = pad(np.asarray(support, dtype=bool))
    sup[:n_in] = True
    sup[len(sup) - n_out:] = True
    return Lead(q=pad(q), markers=pad(markers), support=sup, n_in=n_in, n_out=n_out)
