"""A banded interior-point QP solver of our own, to compare with the libraries on the real QP.

The whole-body QP is banded when its unknowns are ordered frame by frame (every row couples
frames t-2..t+2). This solver keeps that structure end to end: a primal-dual interior-point
method (Mehrotra predictor-corrector, Nocedal & Wright 2006, Alg. 16.4 for QPs) whose Newton
system, the quasi-definite KKT matrix

    [ P + C^T (Z/S) C + d_x I    A^T    ]
    [ A                         -d_y I  ]

is ordered as a band (the unknowns in their frame-by-frame order, each equality's multiplier
right after the first unknown of its row; reverse Cuthill-McKee gave a half-bandwidth of 7,646
on the G1 walk, this order 318) and factored once per iteration by LAPACK's
banded LU (``dgbtrf``), then solved twice (predictor, corrector) with ``dgbtrs``. Its cost is
``O(N b^2)`` for N unknowns and half-bandwidth b, against PIQP's sparse LDL^T, whose fill-in
follows the same band.

It is here only for ``benchmarks/qp_solvers.py`` (the issue asked for the comparison); the
library uses the fastest solver of that table.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.linalg import lapack


def solve_banded_qp(qp, tol: float = 1e-7, max_iter: int = 60):
    """Solve an ``imesh.solve.qp.QpProblem``.

    Returns:
        (x (n,), status, iterations, half-bandwidth).
    """
    n = qp.n
    eye = sp.identity(n, format="csr")
    C_all = sp.vstack([qp.G, eye], format="csr")
    lo = np.concatenate([qp.l, qp.x_l])
    hi = np.concatenate([qp.u, qp.x_u])
    low, up = np.isfinite(lo), np.isfinite(hi)
    # one-sided rows C x - s = d, s >= 0
    C = sp.vstack([C_all[low], -C_all[up]], format="csr")
    d = np.concatenate([lo[low], -hi[up]])
    A, b = qp.A.tocsr(), qp.b
    P = sp.csr_matrix(qp.P)
    m, p = C.shape[0], A.shape[0]
    CT = C.T.tocsr()

    # the band (fixed over the iterations): unknowns in order, multipliers after their row's
    # first unknown
    pattern = sp.bmat([[abs(P) + abs(CT) @ abs(C) + eye, abs(A).T],
                       [abs(A), sp.identity(p)]], format="csr")
    first = np.minimum.reduceat(A.indices, A.indptr[:-1]) if p else np.zeros(0)
    perm = np.argsort(np.concatenate([np.arange(n), first + 0.5]), kind="stable")
    inv = np.empty_like(perm)
    inv[perm] = np.arange(len(perm))
    coo = pattern.tocoo()
    bw = int(np.abs(inv[coo.row] - inv[coo.col]).max())
    N = n + p

    reg_x, reg_y = 1e-9, 1e-9

    def factor(w):
        H = P + CT @ sp.diags(w) @ C + reg_x * eye
        K = sp.bmat([[H, A.T], [A, -reg_y * sp.identity(p)]], format="coo")
        K.sum_duplicates()
        ab = np.zeros((3 * bw + 1, N))
        # dgbtrf storage: rows bw..3 bw hold the band, the top bw rows its fill-in
        ab[2 * bw + inv[K.row] - inv[K.col], inv[K.col]] = K.data
        lu, piv, info = lapack.dgbtrf(ab, bw, bw)
        return lu, piv, info

    def kkt_solve(lu, piv, rhs):
        sol = lapack.dgbtrs(lu, bw, bw, rhs[perm], piv)[0]
        return sol[inv]

    def newton(state, r_c):
        """The step for the complementarity target r_c: ds = C dx + r_i, dz = (r_c - Z ds)/S."""
        lu, piv, r_d, r_p, r_i, s, z = state
        sol = kkt_solve(lu, piv, np.concatenate([-r_d + CT @ ((r_c - z * r_i) / s), -r_p]))
        dx, dy = sol[:n], sol[n:]
        ds = C @ dx + r_i
        return dx, dy, ds, (r_c - z * ds) / s

    def step_to_boundary(v, dv):
        neg = dv < 0
        return min(1.0, float(np.min(-v[neg] / dv[neg], initial=np.inf)))

    # starting point (Mehrotra 1992): the least-squares point of the unit-weighted system,
    # then s and z shifted into the positive orthant
    lu, piv, _ = factor(np.ones(m))
    sol = kkt_solve(lu, piv, np.concatenate([-qp.c + CT @ d, b]))
    x, y = sol[:n], sol[n:]
    s = C @ x - d
    z = np.ones(m)
    s = s + max(-1.5 * s.min(), 0.0) + 1e-2
    z = z + max(-1.5 * z.min(), 0.0)
    shift = 0.5 * (s @ z)
    s, z = s + shift / z.sum(), z + shift / s.sum()
    status = "max_iter"
    it = 0
    while it < max_iter:
        it += 1
        r_d = P @ x + qp.c + A.T @ y - CT @ z
        r_p = A @ x - b
        r_i = C @ x - s - d
        mu = s @ z / m
        if max(np.abs(r_d).max(), np.abs(r_p).max(initial=0), np.abs(r_i).max(), mu) < tol:
            status = "solved"
            break
        lu, piv, info = factor(z / s)
        if info != 0:
            status = f"factorization failed ({info})"
            break

        # predictor (affine scaling), then the centred corrector
        state = (lu, piv, r_d, r_p, r_i, s, z)
        dx, dy, ds, dz = newton(state, -s * z)
        a_p, a_d = step_to_boundary(s, ds), step_to_boundary(z, dz)
        mu_aff = (s + a_p * ds) @ (z + a_d * dz) / m
        sigma = (mu_aff / mu) ** 3
        dx, dy, ds, dz = newton(state, -s * z + sigma * mu - ds * dz)
        a_p = 0.99 * step_to_boundary(s, ds)
        a_d = 0.99 * step_to_boundary(z, dz)
        x, s = x + a_p * dx, s + a_p * ds
        y, z = y + a_d * dy, z + a_d * dz
    return x, status, it, bw
