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


def _solve_with_active(H: np.ndarray, g: np.ndarray, active: np.ndarray,
                       values: np.ndarray) -> np.ndarray:
    """Minimize over the free variables with the active ones fixed at ``values``.

    The active rows/columns are replaced by identity rows (same size as H, no fancy-index
    sub-matrix: for n ~ 40 the copy is cheaper than np.ix_).
    """
    rhs = g - H[:, active] @ values[active]
    m = H.copy()
    m[active, :] = 0.0
    m[:, active] = 0.0
    idx = np.flatnonzero(active)
    m[idx, idx] = 1.0
    rhs[active] = values[active]
    return np.linalg.solve(m, rhs)


def solve_box_qp(H: np.ndarray, g: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                 max_active_set_iterations: int = 20,
                 guess: tuple[np.ndarray, np.ndarray] | None = None
                 ) -> tuple[np.ndarray, int, tuple[np.ndarray, np.ndarray]]:
    """Minimize 0.5 x^T H x - g^T x subject to lo <= x <= hi (H symmetric positive definite).

    Args:
        H: (n, n) Hessian, e.g. J^T W^2 J + lambda^2 I (eq. 7).
        g: (n,) e.g. J^T W^2 e.
        lo: (n,) lower bounds (-inf for unbounded), lo <= hi; lo == hi pins a variable.
        hi: (n,) upper bounds (+inf for unbounded).
        max_active_set_iterations: cap on active-set updates; when reached (cycling, very rare)
            the last iterate is clipped into the box.
        guess: (at lower, at upper) boolean masks to start the active set from (e.g. the sets
            returned by the previous solve of a similar problem); None starts from the
            unconstrained minimizer.

    Returns:
        x: (n,) the minimizer (inside the box).
        iterations: active-set iterations (0 when the start was already optimal).
        active: (at lower, at upper) boolean masks of the final active set.
    """
    fixed = lo >= hi
    if guess is None or not (guess[0].any() or guess[1].any() or fixed.any()):
        x = np.linalg.solve(H, g)
        below = x < lo
        above = x > hi
        if not (below.any() or above.any()):
            return x, 0, (below, above)
        act_lo = below | fixed
        act_hi = above & ~fixed
    else:
        act_lo = (guess[0] & np.isfinite(lo)) | fixed
        act_hi = guess[1] & np.isfinite(hi) & ~fixed
    d = H.diagonal()
    for it in range(1, max_active_set_iterations + 1):
        active = act_lo | act_hi
        values = np.where(act_lo, lo, np.where(act_hi, hi, 0.0))
        x = _solve_with_active(H, g, active, values) if active.any() else np.linalg.solve(H, g)
        r = H @ x - g  # gradient; multiplier of an active lower bound is r >= 0, upper r <= 0
        new_lo = ((lo - x) + r / d > 0) | fixed
        new_hi = ((x - hi) - r / d > 0) & ~fixed
        if np.array_equal(new_lo, act_lo) and np.array_equal(new_hi, act_hi):
            return x, it - 1, (act_lo, act_hi)
        act_lo, act_hi = new_lo, new_hi
    x = np.clip(x, lo, hi)
    return x, max_active_set_iterations, (x <= lo, x >= hi)


def solve_box_dls(A: np.ndarray, b: np.ndarray, damping: float, lo: np.ndarray, hi: np.ndarray,
                  max_active_set_iterations: int = 20) -> tuple[np.ndarray, int]:
    """Box-bounded damped least squares: argmin |A x - b|^2 + damping^2 |x|^2, lo <= x <= hi.

    Args:
        A: (m, n) weighted Jacobian W J.
        b: (m,) weighted error W e.
        damping: lambda (> 0).
        lo, hi: (n,) bounds as in :func:`solve_box_qp`.
        max_active_set_iterations: as in :func:`solve_box_qp`.

    Returns:
        (x, active-set iterations) as :func:`solve_box_qp`.
    """
    H = A.T @ A
    H.flat[:: H.shape[0] + 1] += damping * damping
    x, it, _ = solve_box_qp(H, A.T @ b, lo, hi, max_active_set_iterations)
    return x, it
