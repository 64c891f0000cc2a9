"""Box-bounded damped least squares, the inner solve of joint fitting.

    dq = argmin |A dq - b|^2 + lambda^2 |dq|^2   subject to  lo <= dq <= hi

(Nakaoka & Komura 2012 eq. 7 with A = W J, b = W e; the bounds are the increment boxes of
Kim et al. 2005 eqs 9, 13, 14). The Hessian H = A^T A + lambda^2 I is small (nv ~ 30-45) and
positive definite, so a primal-dual active-set method (Hintermueller, Ito & Kunisch 2002) on the
normal equations converges in a handful of reduced solves; unbounded variables (the free-flyer
base) use lo = -inf, hi = +inf. Most frames need only the first, unconstrained solve.
"""

from __future__ import annotations

import numpy as np


def solve_box_dls(A: np.ndarray, b: np.ndarray, damping: float, lo: np.ndarray, hi: np.ndarray,
                  max_active_set_iterations: int = 20) -> tuple[np.ndarray, int]:
    """Solve the box-bounded damped least-squares problem.

    Args:
        A: (m, n) weighted Jacobian W J.
        b: (m,) weighted error W e.
        damping: lambda (> 0).
        lo: (n,) lower bounds on dq (-inf for unbounded), lo <= hi.
        hi: (n,) upper bounds on dq (+inf for unbounded).
        max_active_set_iterations: cap on active-set updates; when reached (cycling, very rare)
            the last iterate is clipped into the box.

    Returns:
        dq: (n,) the minimizer (inside the box).
        iterations: number of active-set iterations (0 when the unconstrained solution fits).
    """
    H = A.T @ A
    H.flat[:: H.shape[0] + 1] += damping * damping
    g = A.T @ b
    x = np.linalg.solve(H, g)
    below = x < lo
    above = x > hi
    if not (below.any() or above.any()):
        return x, 0
    fixed = lo >= hi
    d = H.diagonal().copy()
    act_lo = below | fixed
    act_hi = above & ~fixed
    for it in range(1, max_active_set_iterations + 1):
        active = act_lo | act_hi
        free = ~active
        x = np.where(act_lo, lo, np.where(act_hi, hi, 0.0))
        if free.any():
            rhs = g[free] - H[np.ix_(free, active)] @ x[active]
            x[free] = np.linalg.solve(H[np.ix_(free, free)], rhs)
        r = H @ x - g  # gradient; multiplier of an active lower bound is r >= 0, upper r <= 0
        new_lo = ((lo - x) + r / d > 0) | fixed
        new_hi = ((x - hi) - r / d > 0) & ~fixed
        if np.array_equal(new_lo, act_lo) and np.array_equal(new_hi, act_hi):
            return x, it
        act_lo, act_hi = new_lo, new_hi
    return np.clip(x, lo, hi), max_active_set_iterations
