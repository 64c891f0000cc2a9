"""Nishiwaki's CoM correction for a ZMP error, with variable CoM height (Nakaoka & Komura 2012,
eqs 9-10; Nishiwaki et al. 2002).

The cart-table model linearized about the current motion: a horizontal CoM change ``dx_i``
(one axis, frame i) changes the ZMP by

    dp_i = (-z_i dx_{i-1} + (2 z_i + (g + zddot_i) dt^2) dx_i - z_i dx_{i+1})
           / ((g + zddot_i) dt^2)                                                (eq. 10)

with ``z_i`` the CoM height above the ground and ``zddot_i`` its vertical acceleration (eq. 9 is
the case of a constant ``z``). Asking for ``dp = p_desired - p`` over all frames gives one
tridiagonal system per horizontal axis (``scipy.linalg.solve_banded``). The ends take a
zero-slope condition (``dx_{-1} = dx_0``, ``dx_T = dx_{T-1}``): the first and last poses may
shift as a whole (a static pose whose CoM is not over its feet must move), but do not start or
end with a jerk. Frames listed in ``free`` (flight) ask for no ZMP change there but stay in the
chain (their row is the plain second difference, ``dx`` is smooth through them).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_banded

from ..robot.configuration import GRAVITY


def nishiwaki_correction(zmp_change_m: np.ndarray, com_height_m: np.ndarray,
                         com_zdd_m_s2: np.ndarray, fps: float,
                         free: np.ndarray | None = None) -> np.ndarray:
    """Horizontal CoM correction that changes the ZMP by ``zmp_change_m`` (eq. 10).

    Args:
        zmp_change_m: (T, 2) float [m] wanted ZMP change (desired - current), per axis x, y.
        com_height_m: (T,) float [m] CoM height above the ground.
        com_zdd_m_s2: (T,) float [m/s^2] vertical CoM acceleration.
        fps: frame rate [1/s].
        free: (T,) bool frames whose ZMP is not constrained (flight); None: none.

    Returns:
        (T, 2) float [m] CoM correction dx.
    """
    dp = np.asarray(zmp_change_m, dtype=np.float64)
    n = len(dp)
    if n == 0:
        return np.zeros((0, 2))
    dt = 1.0 / fps
    denom = (GRAVITY + np.asarray(com_zdd_m_s2, dtype=np.float64)) * dt * dt
    k = np.asarray(com_height_m, dtype=np.float64) / denom  # z_i / ((g + zdd_i) dt^2)
    lower = -k.copy()  # coefficient of dx_{i-1} in row i
    upper = -k.copy()  # coefficient of dx_{i+1} in row i
    diag = 1.0 + 2.0 * k
    # zero-slope ends: the missing neighbour equals the end value
    diag[0] += lower[0]
    diag[-1] += upper[-1]
    rhs = dp.copy()
    if free is not None and np.any(free):
        # no ZMP in flight: keep dx smooth there (second difference zero), ask for nothing
        f = np.asarray(free, dtype=bool)
        lower[f], diag[f], upper[f] = -1.0, 2.0, -1.0
        diag[0] = diag[0] if not f[0] else 1.0
        diag[-1] = diag[-1] if not f[-1] else 1.0
        rhs[f] = 0.0
    if n == 1:
        return rhs / diag[0]
    ab = np.zeros((3, n))
    ab[0, 1:] = upper[:-1]
    ab[1] = diag
    ab[2, :-1] = lower[1:]
    return solve_banded((1, 1), ab, rhs)
