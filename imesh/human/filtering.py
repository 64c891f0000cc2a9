"""Zero-phase low-pass filtering of marker trajectories.

Motion-capture joint trajectories carry millimetre jitter that is invisible in positions but
dominates second differences at 100+ fps (a 1 mm jitter is ~14 m/s^2 at 120 fps), and joint
acceleration limits then bind on every frame. The pipeline filters the human markers once,
before the arrangement, with a Butterworth filter run forwards and backwards (no phase lag).
"""

from __future__ import annotations

import logging

import numpy as np

from ..core.motion import MarkerMotion
from ..errors import OptionError

log = logging.getLogger(__name__)


def lowpass_array(x: np.ndarray, fps: float, cutoff_hz: float, order: int = 4
                  ) -> np.ndarray | None:
    """Zero-phase Butterworth low-pass of an array along axis 0 (time).

    Args:
        x: (T, ...) samples at ``fps``.
        fps: sampling rate [1/s].
        cutoff_hz: cut-off frequency [Hz], below fps / 2.
        order: filter order (doubled by the forward-backward pass).

    Returns:
        The filtered array, or None when T is too short for the filter's padding.
    """
    # scipy.signal (and the scipy.stats it imports) costs 0.5 s of CPU: imported when a clip is
    # filtered, after the command line has drawn its progress bar, not when imesh is imported
    from scipy.signal import butter, filtfilt

    nyquist = fps / 2
    if not (np.isfinite(cutoff_hz) and 0 < cutoff_hz < nyquist):
        raise OptionError("low-pass cut-off", cutoff_hz, f"a frequency in (0, {nyquist:g}) Hz")
    b, a = butter(order, cutoff_hz / nyquist)
    if len(x) <= 3 * max(len(a), len(b)):
        return None
    return filtfilt(b, a, x, axis=0)


def lowpass(motion: MarkerMotion, cutoff_hz: float, order: int = 4) -> MarkerMotion:
    """Zero-phase Butterworth low-pass of every marker coordinate (all at once).

    Args:
        motion: a complete motion (fill gaps first).
        cutoff_hz: cut-off frequency [Hz]; must be below the Nyquist frequency fps / 2.
        order: filter order (the effective order is doubled by the forward-backward pass).

    Returns:
        The filtered motion (same names, bones, fps); clips too short for the filter's padding
        are returned unchanged (logged).
    """
    filtered = lowpass_array(motion.positions_m, motion.fps, cutoff_hz, order)
    if filtered is None:
        log.info("%s: %d frames are too few to low-pass at order %d; not filtered",
                 motion.source, motion.n_frames, order)
        return motion
    log.info("%s: low-passed at %.1f Hz (largest change %.1f mm)", motion.source, cutoff_hz,
             1e3 * float(np.abs(filtered - motion.positions_m).max()))
    return motion.with_positions(filtered, meta={**motion.meta, "lowpass_hz": cutoff_hz})
