"""Gap filling: complete marker trajectories for the solvers, which need every sample."""

from __future__ import annotations

import logging

import numpy as np

from ..core.motion import MarkerMotion
from ..errors import MissingMarkerError

log = logging.getLogger(__name__)


def fill_gaps(motion: MarkerMotion) -> MarkerMotion:
    """Fill missing samples by linear interpolation in time; ends hold the nearest sample.

    The filled samples stay recorded: ``meta['filled_fraction']`` and ``meta['filled_mask']``
    (T, M) say which samples were not measured.

    Raises:
        MissingMarkerError: a marker is missing in every frame (nothing to interpolate).
    """
    if motion.valid.all():
        return motion
    never = [motion.names[j] for j in np.flatnonzero(~motion.valid.any(axis=0))]
    if never:
        raise MissingMarkerError(
            f"{motion.source}: cannot fill markers missing in all {motion.n_frames} frames",
            missing=never, available=[n for n in motion.names if n not in never],
        )
    t = np.arange(motion.n_frames, dtype=float)
    pos = motion.positions_m.copy()
    # One np.interp per marker column (a few dozen calls): not a per-frame loop.
    for j in np.flatnonzero(~motion.valid.all(axis=0)):
        ok = motion.valid[:, j]
        for k in range(3):
            pos[:, j, k] = np.interp(t, t[ok], motion.positions_m[ok, j, k])
    filled = ~motion.valid
    log.info("%s: filled %.1f %% missing samples by interpolation", motion.source,
             100 * filled.mean())
    meta = dict(motion.meta)
    meta["filled_fraction"] = float(filled.mean())
    meta["filled_mask"] = filled
    return motion.with_positions(pos, meta=meta)
