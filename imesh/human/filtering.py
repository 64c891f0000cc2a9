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
    nyquist = fps / 2
    if not (np.isfinite(cutoff_hz) and 0 < cutoff_hz < nyquist):
        raise OptionError("low-pass cut-off", cutoff_hz, f"a frequency in (0, {nyquist:g}) Hz")
    b, a = butter_lowpass(order, cutoff_hz / nyquist)
    if len(x) <= 3 * len(a):
        return None
    return filtfilt(b, a, x)


def butter_lowpass(order: int, wn: float) -> tuple[np.ndarray, np.ndarray]:
    """Digital Butterworth low-pass ``(b, a)`` (``a[0] = 1``), as ``scipy.signal.butter(order,
    wn)``: the analog prototype's poles ``-exp(i pi (2k - N + 1) / 2N)`` scaled to the
    pre-warped cut-off ``4 tan(pi wn / 2)`` and mapped by the bilinear transform (fs = 2), the
    N zeros at z = -1, unit gain at DC.

    Args:
        order: filter order N.
        wn: cut-off as a fraction of the Nyquist frequency, in (0, 1).
    """
    poles = -np.exp(1j * np.pi * np.arange(-order + 1, order, 2) / (2 * order))
    warped = 4.0 * np.tan(np.pi * wn / 2.0)
    p = (4.0 + warped * poles) / (4.0 - warped * poles)
    k = np.real(warped ** order / np.prod(4.0 - warped * poles))
    b = k * np.real(np.poly(-np.ones(order)))
    a = np.real(np.poly(p))
    return b, a


def filtfilt(b: np.ndarray, a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Zero-phase filtering along axis 0, as ``scipy.signal.filtfilt(b, a, x, axis=0)``: the
    signal extended at both ends by ``3 len(a)`` samples of its odd reflection, filtered
    forwards from the steady state of its first sample, then backwards likewise.

    Each pass solves the filter's difference equation ``sum_k a_k y_(n-k) = sum_k b_k x_(n-k)
    + c_n`` (``c``: the initial state, non-zero in the first N samples) for all samples at
    once, a lower-triangular banded system (LAPACK ``dtbtrs``), instead of a loop over them.
    """
    pad = 3 * len(a)
    x = np.asarray(x, dtype=np.float64)
    ext = np.concatenate([2.0 * x[:1] - x[pad:0:-1], x,
                          2.0 * x[-1:] - x[-2:-pad - 2:-1]])
    zi = _steady_state(b, a)
    y = _lfilter(b, a, ext, zi)
    y = _lfilter(b, a, y[::-1], zi)[::-1]
    return y[pad:len(y) - pad]


def _steady_state(b: np.ndarray, a: np.ndarray) -> np.ndarray:
    """(N,) the transposed direct form's state after a unit step input has settled (as
    ``scipy.signal.lfilter_zi``): ``(I - A) z = B`` with ``A`` the companion matrix of ``a``
    and ``B = b[1:] - a[1:] b[0]``."""
    n = len(a) - 1
    companion = np.zeros((n, n))
    companion[0] = -a[1:]
    companion[np.arange(1, n), np.arange(n - 1)] = 1.0
    return np.linalg.solve(np.eye(n) - companion.T, b[1:] - a[1:] * b[0])


def _lfilter(b: np.ndarray, a: np.ndarray, x: np.ndarray, zi: np.ndarray) -> np.ndarray:
    """``scipy.signal.lfilter(b, a, x, axis=0, zi=zi * x[0])[0]`` for ``a[0] = 1``."""
    from scipy.linalg.lapack import dtbtrs

    n, T = len(a) - 1, len(x)
    flat = x.reshape(T, -1)
    rhs = b[0] * flat
    for k in range(1, n + 1):  # the FIR part, one shifted copy per coefficient
        rhs[k:] += b[k] * flat[:-k]
    rhs[:n] += zi[:, None] * flat[0]
    band = np.zeros((n + 1, T))  # LAPACK's lower band storage: band[i, j] = A[j + i, j]
    band[:] = a[:, None]
    y, info = dtbtrs(band, rhs, uplo="L")
    if info != 0:  # a0 = 1 on the diagonal: never singular
        raise FloatingPointError(f"dtbtrs failed with info {info}")
    return y.reshape(x.shape)


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
