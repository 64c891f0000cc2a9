"""The dense QP of the whole-body controller: ``min 1/2 x^T H x + c^T x`` s.t. ``E x = e``,
``lo <= G x <= up``, about 50 unknowns and 100 rows per control step.

Solved by DAQP (Arnström, Bemporad & Axehill 2022), a dual active-set method for small dense
QPs: chosen by measurement on the controller's real QPs (``benchmarks/physics.py --qp``;
docs/checking.md), against quadprog and ProxSuite's dense solver.
"""

from __future__ import annotations

import numpy as np

from ..core.lazy import optional

#: DAQP's exit flags that mean "solved" (1 optimal, 2 soft optimal).
_SOLVED = (1, 2)


def dense_qp(H: np.ndarray, c: np.ndarray, E: np.ndarray, e: np.ndarray, G: np.ndarray,
             lo: np.ndarray, up: np.ndarray) -> np.ndarray | None:
    """The minimizer (n,), or None when the QP is infeasible or the solver fails.

    Args:
        H: (n, n) float positive definite Hessian; c: (n,) float linear term.
        E: (m_e, n) float, e: (m_e,) float equality rows.
        G: (m_i, n) float, lo/up: (m_i,) float inequality rows (lo may be -inf).
    """
    daqp = optional("daqp", "pip install daqp", "the whole-body controller of the DART check")
    A = np.ascontiguousarray(np.vstack([E, G]), dtype=np.float64)
    big = 1e20  # DAQP's "no bound"
    bu = np.concatenate([e, np.minimum(up, big)])
    bl = np.concatenate([e, np.maximum(lo, -big)])
    sense = np.zeros(len(bu), dtype=np.int32)
    sense[:len(e)] = 5  # equality (active, immutable)
    x, _, flag, _ = daqp.solve(np.ascontiguousarray(H), np.ascontiguousarray(c), A, bu, bl,
                               sense)
    if flag not in _SOLVED or not np.all(np.isfinite(x)):
        return None
    return np.asarray(x)
