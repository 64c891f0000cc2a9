"""One morph step: the equality-constrained QP solved exactly on its banded structure.

With the variables ordered frame by frame (``x[(i*M + j)*3 + k]`` is coordinate k of marker j at
frame i), the Hessian H of eq. 6 is banded: the Laplacian couples markers within a frame and the
acceleration energy couples frames i-2..i+2, so its half bandwidth is 6M. The KKT system

    [[H, A^T], [A, 0]] [x; lambda] = [g; c]

is solved by the method of multipliers on that band: factor K = H + rho A^T A once per step with a
banded Cholesky (LAPACK ``pbtrf``; about 108 M^3 T flops), then

    K x_k = g + A^T (rho c - lambda_k),    lambda_{k+1} = lambda_k + rho (A x_k - c)

until ``max |A x - c|`` is below tolerance. Each update is two triangular band solves; the
iteration converges to the exact KKT solution (the one of eq. 6) and tolerates redundant rows,
which make a direct KKT factorization singular.

The constraint rows have a fixed pattern (bones: 6 entries u, -u; positions: one entry 1), only
their values change between steps, so A^T A is scattered straight into a preallocated band
(Fortran order, factored in place: no per-step allocation of the band).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.linalg.lapack import dpbtrf, dpbtrs

from ..errors import SolverError


def upper_band(matrix: sp.spmatrix, kd: int) -> np.ndarray:
    """LAPACK upper band storage ``ab[kd + r - c, c] = A[r, c]`` (r <= c), Fortran order.

    The matrix must have no duplicate entries (CSR/CSC after sum_duplicates): entries are
    assigned, not accumulated, so the cost is O(nnz) besides zeroing the band.
    """
    coo = matrix.tocoo()
    coo.sum_duplicates()
    keep = coo.row <= coo.col
    r, c, v = coo.row[keep], coo.col[keep], coo.data[keep]
    if len(r) and int((c - r).max()) > kd:
        raise ValueError(f"matrix half bandwidth {(c - r).max()} exceeds kd={kd}")
    ab = np.zeros((kd + 1, matrix.shape[0]), order="F")
    ab[kd + r - c, c] = v
    return ab


@dataclass(frozen=True)
class StepSolution:
    """Result of one constrained solve.

    Attributes:
        x: (N,) solution.
        multipliers: (R,) Lagrange multipliers of the hard constraints.
        iterations: multiplier updates used.
        residual: max |A x - c| reached.
    """

    x: np.ndarray
    multipliers: np.ndarray
    iterations: int
    residual: float


class BandedKKT:
    """Exact solver of min 1/2 x^T K0 x - g^T x s.t. A x = c on the band.

    K0 = H + S^T S: H fixed, S the soft pair rows (linearized distance terms, re-weighted at
    every factorization). A holds the hard rows: pair rows (bone lengths, eq. 3) and positional
    rows (eq. 4).

    Args:
        hessian: (N, N) CSR, symmetric positive definite, half bandwidth <= kd.
        kd: half bandwidth.
        bone_cols: (R_b, 2, 3) variable indices of the two markers of each hard pair row.
        pos_cols: (R_p,) variable index of each hard positional row.
        penalty: rho relative to the mean diagonal of H.
        soft_cols: (R_s, 2, 3) variable indices of the soft pair rows (may be empty).
    """

    def __init__(self, hessian: sp.csr_matrix, kd: int, bone_cols: np.ndarray,
                 pos_cols: np.ndarray, penalty: float, soft_cols: np.ndarray | None = None):
        self.hessian = hessian
        self.kd = kd
        self.n = hessian.shape[0]
        self.band = upper_band(hessian, kd)
        self.work = np.empty_like(self.band, order="F")
        self.rho = penalty * float(np.mean(self.band[-1]))
        bone_cols = bone_cols.reshape(-1, 6)
        soft_cols = np.zeros((0, 6), dtype=np.int64) if soft_cols is None else soft_cols.reshape(
            -1, 6)
        self.n_bone_rows = len(bone_cols)
        self.n_soft_rows = len(soft_cols)
        self.pair_cols = np.concatenate([bone_cols, soft_cols])
        self.pos_cols = np.asarray(pos_cols, dtype=np.int64)
        self.n_rows = self.n_bone_rows + len(self.pos_cols)
        # Pattern of the pair rows' outer products in the band (upper part), fixed across steps.
        rr = np.repeat(self.pair_cols, 6, axis=1)  # (R, 36) row index
        cc = np.tile(self.pair_cols, (1, 6))  # (R, 36) column index
        self._upper = rr <= cc
        flat = cc * (kd + 1) + (kd + rr - cc)
        flat = np.concatenate([flat[self._upper], self.pos_cols * (kd + 1) + kd])
        self._band_index, self._inverse = np.unique(flat, return_inverse=True)
        sign = np.array([1.0, 1.0, 1.0, -1.0, -1.0, -1.0])
        self._sign = np.outer(sign, sign).reshape(-1)  # (36,)
        self._row_idx = np.concatenate([np.repeat(np.arange(self.n_bone_rows), 6),
                                        self.n_bone_rows + np.arange(len(self.pos_cols))])
        self._col_idx = np.concatenate([bone_cols.reshape(-1), self.pos_cols])
        self._soft_row_idx = np.repeat(np.arange(self.n_soft_rows), 6)
        self._factor = None
        self._a: sp.csr_matrix | None = None  # by factor()
        self._s = sp.csr_matrix((0, self.n))

    def factor(self, directions: np.ndarray, soft_directions: np.ndarray | None = None,
               soft_weights: np.ndarray | None = None) -> None:
        """Factor K = H + S^T S + rho A^T A.

        Args:
            directions: (R_b, 3) unit directions of the hard pair rows.
            soft_directions: (R_s, 3) unit directions of the soft pair rows.
            soft_weights: (R_s,) weights of the soft pair rows.
        """
        if self.n_soft_rows:
            u = np.concatenate([directions, soft_directions])
            scale = np.concatenate([np.full(self.n_bone_rows, self.rho), soft_weights])
        else:
            u, scale = directions, np.full(self.n_bone_rows, self.rho)
        u6 = np.concatenate([u, u], axis=1)  # (R, 6), signs in _sign
        outer = (u6[:, :, None] * u6[:, None, :]).reshape(len(u6), 36) * self._sign
        outer *= scale[:, None]
        vals = np.concatenate([outer[self._upper], np.full(len(self.pos_cols), self.rho)])
        add = np.bincount(self._inverse, weights=vals, minlength=len(self._band_index))
        np.copyto(self.work, self.band)
        self.work.reshape(-1, order="F")[self._band_index] += add
        factor, info = dpbtrf(self.work, lower=0, overwrite_ab=1)
        if info != 0:
            raise SolverError(f"banded Cholesky failed (LAPACK info {info}): the morph Hessian is "
                              "not positive definite; check weights (MorphWeights.anchor must "
                              "be > 0)")
        self._factor = factor
        vals_a = np.concatenate([np.concatenate([directions, -directions], axis=1).reshape(-1),
                                 np.ones(len(self.pos_cols))])
        self._a = sp.csr_matrix((vals_a, (self._row_idx, self._col_idx)),
                                shape=(self.n_rows, self.n))
        if self.n_soft_rows:
            assert soft_directions is not None and soft_weights is not None, \
                "soft pair rows need their directions and weights"
            root = np.sqrt(soft_weights)[:, None] * soft_directions
            vals_s = np.concatenate([root, -root], axis=1).reshape(-1)
            self._s = sp.csr_matrix(
                (vals_s, (self._soft_row_idx, self.pair_cols[self.n_bone_rows:].reshape(-1))),
                shape=(self.n_soft_rows, self.n))

    @property
    def soft_matrix(self) -> sp.csr_matrix:
        """S (R_s, N): rows sqrt(w) [u, -u] of the soft pair terms of the last factorization."""
        return self._s

    @property
    def constraint_matrix(self) -> sp.csr_matrix:
        return self._a

    def _solve_k(self, rhs: np.ndarray) -> np.ndarray:
        x, _ = dpbtrs(self._factor, rhs, lower=0)
        return x

    def solve(self, gradient: np.ndarray, c: np.ndarray, *, multipliers: np.ndarray | None = None,
              tolerance: float = 1e-10, fail_tolerance: float = 1e-5,
              max_iterations: int = 60) -> StepSolution:
        """Solve with the current factorization (call :meth:`factor` first).

        Args:
            gradient: (N,) g.
            c: (R,) constraint right-hand sides.
            multipliers: (R,) warm start.
            tolerance: stop once max |A x - c| <= tolerance.
            fail_tolerance: after ``max_iterations``, a residual above this is an error.
            max_iterations: multiplier updates at most.

        Raises:
            SolverError: the residual stayed above ``fail_tolerance`` (conflicting constraints).
        """
        a, rho = self._a, self.rho
        assert a is not None, "factor() before solve()"
        lam = np.zeros(self.n_rows) if multipliers is None else multipliers.copy()
        residual = np.inf
        for it in range(1, max_iterations + 1):
            x = self._solve_k(gradient + a.T @ (rho * c - lam))
            r = a @ x - c
            residual = float(np.abs(r).max()) if r.size else 0.0
            if not np.isfinite(residual):
                raise SolverError("the morph solve produced non-finite values", residual, tolerance)
            lam = lam + rho * r
            if residual <= tolerance:
                return StepSolution(x=x, multipliers=lam, iterations=it, residual=residual)
        if residual <= fail_tolerance:
            # near-redundant rows (e.g. collinear pelvis markers) slow the multiplier updates;
            # the final projection restores exact lengths, so a small residual is not an error
            return StepSolution(x=x, multipliers=lam, iterations=max_iterations, residual=residual)
        raise SolverError(
            f"hard constraints not met after {max_iterations} multiplier updates: residual "
            f"{residual:.3g} m > {fail_tolerance:.3g} m (conflicting hard constraints?)",
            residual, fail_tolerance,
        )
