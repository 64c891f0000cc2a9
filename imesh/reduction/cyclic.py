"""One cyclic motion from a clip of a periodic motion (sec. IV-B: "modified to a cyclic motion by
using FFT and inverse FFT").

1. Period: autocorrelation of the leg link angles (a left-leg signal repeats once per gait cycle),
   refined by a parabola through the peak.
2. Cycles: from one toe-off of the right foot (its toe starting to move forward) to the next;
   each cycle is resampled to n samples, its end-to-start drift removed by a linear ramp, and the
   cycles are averaged.
3. FFT / inverse FFT: the mean cycle keeps harmonics 0..K only (a smooth periodic signal).

Every step is measured (:attr:`CyclicMotion.report`): the drift each cycle had, how far each cycle
is from the cyclic result, and what the low-pass changed.
"""

from __future__ import annotations

import logging
from dataclasses import asdict, dataclass

import numpy as np

from ..errors import InvalidMotionError, OptionError
from .capture import SagittalCapture

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CyclicReport:
    """Measurements of the cyclic processing (the ``cyclic`` part of the ``imesh reduce``
    report, :meth:`as_dict`).

    Attributes:
        period_s: cycle duration, with the time scale applied [s].
        period_autocorrelation_s: the period the autocorrelation found (no time scale) [s].
        cycles: [start, end] fractional frames of each cycle averaged.
        samples: n, samples per cycle.
        harmonics: K, harmonics kept by the FFT low-pass.
        time_scale: period multiplier.
        drift_deg_max: largest end-to-start drift of a link angle over a cycle [deg].
        drift_deg_mean: mean absolute drift [deg].
        cycle_rms_deg: per cycle, RMS link-angle distance of the drift-corrected cycle from the
            cyclic result [deg].
        raw_cycle_rms_deg: the same before the drift correction [deg].
        lowpass_rms_deg: RMS change of the link angles by the FFT low-pass [deg].
        left_toe_off_fraction: left toe-off sample / n.
    """

    period_s: float
    period_autocorrelation_s: float
    cycles: list[list[float]]
    samples: int
    harmonics: int
    time_scale: float
    drift_deg_max: float
    drift_deg_mean: float
    cycle_rms_deg: list[float]
    raw_cycle_rms_deg: list[float]
    lowpass_rms_deg: float
    left_toe_off_fraction: float

    def as_dict(self) -> dict:
        """The JSON-able measurements, keys in field order."""
        return asdict(self)


@dataclass(frozen=True, eq=False)
class CyclicMotion:
    """One cycle of a periodic motion, n samples, sample k at time k * period / n.

    Attributes:
        angles: (n, 7) human link angles [rad] (LINKS order).
        toe_velocity: (n, 2) forward toe velocity, left and right [m/s].
        period_s: cycle duration [s].
        left_toe_off: sample at which the left toe starts to swing (the right one at sample 0).
        report: measurements of the cyclic processing.
    """

    angles: np.ndarray
    toe_velocity: np.ndarray
    period_s: float
    left_toe_off: int
    report: CyclicReport

    @property
    def n(self) -> int:
        return int(self.angles.shape[0])

    @property
    def dt(self) -> float:
        return self.period_s / self.n


def detect_period(signals: np.ndarray, fps: float, min_s: float = 0.6,
                  max_s: float = 2.5) -> float:
    """Period [frames] of (T, k) signals: the highest summed autocorrelation peak between
    ``min_s`` and ``max_s`` seconds, refined by a parabola.

    Raises:
        InvalidMotionError: no peak in the range (the clip is too short or not periodic).
    """
    x = np.asarray(signals, float)
    x = x - x.mean(axis=0)
    T = x.shape[0]
    lo, hi = int(np.floor(min_s * fps)), int(np.ceil(max_s * fps))
    hi = min(hi, T - int(0.3 * fps))
    if hi <= lo + 2:
        raise InvalidMotionError(f"clip of {T / fps:.2f} s is too short to find a period between "
                                 f"{min_s} and {max_s} s")
    ac = np.array([np.sum(x[:-lag] * x[lag:]) / (T - lag) for lag in range(1, hi + 2)])
    ac /= np.sum(x * x) / T
    lags = np.arange(1, hi + 2)
    cand = [i for i in range(1, len(ac) - 1)
            if lo <= lags[i] <= hi and ac[i] >= ac[i - 1] and ac[i] >= ac[i + 1]]
    if not cand:
        raise InvalidMotionError(f"no periodicity found between {min_s} and {max_s} s")
    best = max(ac[k] for k in cand)
    # the shortest lag with a peak nearly as high as the best (multiples of the period peak too)
    i = min(k for k in cand if ac[k] >= 0.8 * best)
    if ac[i] < 0.3:
        raise InvalidMotionError(f"the motion is not periodic (best autocorrelation {ac[i]:.2f} "
                                 f"at {lags[i] / fps:.2f} s)")
    a, b, c = ac[i - 1], ac[i], ac[i + 1]
    den = a - 2 * b + c
    off = 0.5 * (a - c) / den if den != 0 else 0.0
    return float(lags[i] + np.clip(off, -0.5, 0.5))


def rising_crossings(v: np.ndarray, level: float) -> np.ndarray:
    """Fractional sample indices where v crosses ``level`` upwards."""
    v = np.asarray(v, float)
    i = np.flatnonzero((v[:-1] < level) & (v[1:] >= level))
    return i + (level - v[i]) / (v[i + 1] - v[i])


def _sample(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Linear interpolation of rows of (T, k) x at fractional frame times t."""
    T = x.shape[0]
    return np.stack([np.interp(t, np.arange(T), x[:, j]) for j in range(x.shape[1])], axis=1)


def lowpass_harmonics(x: np.ndarray, harmonics: int) -> np.ndarray:
    """Keep DFT harmonics 0..K of each column of a periodic (n, k) signal (FFT / inverse FFT)."""
    X = np.fft.rfft(x, axis=0)
    X[harmonics + 1:] = 0.0
    return np.fft.irfft(X, n=x.shape[0], axis=0)


def make_cyclic(capture: SagittalCapture, n: int | None = None, harmonics: int = 10,
                time_scale: float = 1.0) -> CyclicMotion:
    """The cyclic motion of a walking clip (see the module docstring).

    Args:
        capture: the clip in the sagittal plane.
        n: samples per cycle (default: the clip's frames per cycle).
        harmonics: K, harmonics kept by the FFT low-pass.
        time_scale: multiply the period by this (e.g. sqrt of the robot/human size ratio for
            dynamic similarity); 1 keeps the human timing.

    Raises:
        InvalidMotionError: no full gait cycle in the clip.
    """
    if harmonics < 1:
        raise OptionError("harmonics", harmonics, "an integer >= 1")
    fps = capture.fps
    phi = capture.angles
    try:
        period = detect_period(phi[:, [1, 2, 4, 5]], fps)
    except InvalidMotionError as exc:
        raise InvalidMotionError(f"{capture.source}: {exc} (a walking cycle is needed)"
                                 ) from None
    vel = np.stack([np.gradient(capture.markers[f"toe_{s}"][:, 0]) * fps for s in "lr"], axis=1)
    level = 0.4 * np.percentile(vel, 95, axis=0)
    offs = [rising_crossings(vel[:, k], level[k]) for k in range(2)]
    starts = offs[1]
    cycles = [(a, b) for a, b in zip(starts[:-1], starts[1:], strict=True)
              if abs((b - a) - period) < 0.2 * period]
    if not cycles:
        # one toe-off and the autocorrelation period
        cycles = [(a, a + period) for a in starts if a + period <= phi.shape[0] - 1]
    if not cycles:
        raise InvalidMotionError(f"{capture.source}: no complete gait cycle (period "
                                 f"{period / fps:.2f} s, right toe-offs at frames "
                                 f"{np.round(starts, 1).tolist()})")
    n_out = int(round(period)) if n is None else int(n)
    if n_out < 16:
        raise OptionError("samples per cycle", n_out, "at least 16")
    k = np.arange(n_out) / n_out
    sig = np.concatenate([phi, vel], axis=1)
    resampled, drifts = [], []
    for a, b in cycles:
        xs = _sample(sig, a + (b - a) * k)
        end = _sample(sig, np.array([b]))[0]
        drift = end - xs[0]
        drift[7:] = 0.0
        drifts.append(drift)
        resampled.append(xs - drift[None, :] * k[:, None])
    mean = np.mean(resampled, axis=0)
    smooth = lowpass_harmonics(mean, harmonics)
    angles, toe_v = smooth[:, :7], smooth[:, 7:]
    # left toe-off inside the cycle
    lt = rising_crossings(np.concatenate([toe_v[:, 0], toe_v[:1, 0]]), level[0])
    lt = lt[(lt > 0.2 * n_out) & (lt < 0.8 * n_out)]
    if not lt.size:
        raise InvalidMotionError(f"{capture.source}: no left toe-off in the mean cycle; "
                                 "is this a walk?")
    left_off = int(round(lt[0]))
    period_s = float(np.mean([b - a for a, b in cycles]) / fps) * time_scale
    deg = np.degrees
    per_cycle = [float(deg(np.sqrt(np.mean((r[:, :7] - angles) ** 2)))) for r in resampled]
    raw_rms = [float(deg(np.sqrt(np.mean((_sample(sig, a + (b - a) * k)[:, :7] - angles) ** 2))))
               for a, b in cycles]
    report = CyclicReport(
        period_s=period_s,
        period_autocorrelation_s=period / fps,
        cycles=[[float(a), float(b)] for a, b in cycles],
        samples=n_out,
        harmonics=harmonics,
        time_scale=time_scale,
        drift_deg_max=float(deg(np.max(np.abs(np.array(drifts)[:, :7])))),
        drift_deg_mean=float(deg(np.mean(np.abs(np.array(drifts)[:, :7])))),
        cycle_rms_deg=per_cycle,
        raw_cycle_rms_deg=raw_rms,
        lowpass_rms_deg=float(deg(np.sqrt(np.mean((mean[:, :7] - angles) ** 2)))),
        left_toe_off_fraction=left_off / n_out,
    )
    log.info("%s: period %.3f s from %d cycle(s), drift max %.1f deg, low-pass change %.2f deg",
             capture.source, period_s, len(cycles), report.drift_deg_max,
             report.lowpass_rms_deg)
    return CyclicMotion(angles=angles, toe_velocity=toe_v, period_s=period_s,
                        left_toe_off=left_off, report=report)
