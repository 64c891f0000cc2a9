"""Differentiation of cyclic trajectories by circulant filter matrices (eqs 14-22).

A cyclic trajectory ``Theta`` (m x n: m signals, n samples over one period) is differentiated by
right-multiplication with an n x n circulant matrix built from the impulse response of a
differentiator with a first-order low-pass, ``G_sf(s) = s f / (s + f)`` (eq. 15), made zero-phase
by a backward pass of the low-pass ``G_f(s) = f / (s + f)`` (Gustafsson's forward-backward
filtering):

    Theta_dot  = Theta F1,  F1 = F_sf R F_f R                      (eq. 21)
    Theta_ddot = Theta F2,  F2 = F_sf F_sf R F_f F_f R = F1 F1      (eq. 22)

``F_sf`` (eq. 17) has first row ``g_1 .. g_n``, the impulse response of G_sf sampled at the frame
period and wrapped onto one period (the response of a cyclic signal is the cyclic convolution);
``R`` (eq. 20) reverses time. The continuous filters are discretized with the bilinear (Tustin)
transform; the wrapped impulse response is the inverse DFT of the discrete frequency response at
the n DFT frequencies, which is exact for these stable IIR filters.

The resulting differentiator has zero phase and gain ``w f^2 / (f^2 + w^2)`` (w the bilinear
frequency ``2/dt tan(w dt/2)``): within 1 % of the true derivative for w < 0.1 f.
"""

from __future__ import annotations

import numpy as np

from ..errors import OptionError


def _freq_response(kind: str, n: int, dt: float, cutoff_rad_s: float) -> np.ndarray:
    """Discrete (bilinear) frequency response at the n DFT frequencies."""
    zinv = np.exp(-2j * np.pi * np.arange(n) / n)
    num_s = (2.0 / dt) * (1.0 - zinv)           # s * (1 + z^-1)
    den = num_s + cutoff_rad_s * (1.0 + zinv)   # (s + f) * (1 + z^-1)
    if kind == "sf":
        return cutoff_rad_s * num_s / den
    if kind == "f":
        return cutoff_rad_s * (1.0 + zinv) / den
    raise OptionError("filter kind", kind, ["sf", "f"])


def impulse_response(kind: str, n: int, dt: float, cutoff_hz: float) -> np.ndarray:
    """(n,) impulse response g_1..g_n of G_sf ("sf") or G_f ("f"), wrapped onto n samples."""
    if n < 4:
        raise OptionError("cycle length (frames)", n, "at least 4 frames")
    if not (dt > 0 and cutoff_hz > 0):
        raise OptionError("dt / cut-off", (dt, cutoff_hz), "positive numbers")
    return np.real(np.fft.ifft(_freq_response(kind, n, dt, 2 * np.pi * cutoff_hz)))


def circulant(g: np.ndarray) -> np.ndarray:
    """(n, n) F with F[k, j] = g[(j - k) mod n] (eq. 17: first row g, each row shifted right)."""
    n = len(g)
    idx = (np.arange(n)[None, :] - np.arange(n)[:, None]) % n
    return np.asarray(g)[idx]


def reversal(n: int) -> np.ndarray:
    """(n, n) time reversal R (eq. 20): ones on the anti-diagonal."""
    return np.eye(n)[::-1]


def derivative_matrices(n: int, dt: float, cutoff_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """F1 and F2 (eqs 21-22) for a cyclic trajectory of n samples at period dt.

    Args:
        n: samples per cycle.
        dt: sample period [s].
        cutoff_hz: cut-off f of the low-pass [Hz].

    Returns:
        F1, F2: (n, n); ``Theta @ F1`` and ``Theta @ F2`` are the first and second derivatives
        of the rows of ``Theta`` (m, n).
    """
    F_sf = circulant(impulse_response("sf", n, dt, cutoff_hz))
    F_f = circulant(impulse_response("f", n, dt, cutoff_hz))
    R = reversal(n)
    F1 = F_sf @ R @ F_f @ R
    F2 = F_sf @ F_sf @ R @ F_f @ F_f @ R
    return F1, F2


def derivative_gain(freq_hz: np.ndarray, dt: float, cutoff_hz: float) -> np.ndarray:
    """Gain of F1 relative to the exact derivative at ``freq_hz`` (1 = exact)."""
    w = 2 * np.pi * np.asarray(freq_hz, float)
    wb = (2.0 / dt) * np.tan(w * dt / 2.0)
    f = 2 * np.pi * cutoff_hz
    return wb * f ** 2 / (f ** 2 + wb ** 2) / np.where(w == 0, 1.0, w)
