"""Final projection onto the exact (nonlinear) bone-length manifold.

The morph steps satisfy the bone constraints linearized at the previous solution, so the true
lengths are off by a second-order term (|perpendicular motion|^2 / 2l). Sequential re-solves of
the full QP shrink it only linearly. This projection is Newton's method on the underdetermined
system c(x) = |p_a - p_b| - l = 0 with the minimum-norm step

    dx = -J^T (J J^T)^-1 c(x),

frame by frame (the frames are independent here), holding the hard positional constraints
fixed. It converges quadratically; started from the morph's micrometre-level residual it moves
markers by micrometres, so the interaction-mesh energy is unchanged to that order.
"""

from __future__ import annotations

import numpy as np

from ..mesh.bones import bone_directions, bone_lengths


def project_lengths(positions_m: np.ndarray, pairs: np.ndarray, targets_m: np.ndarray,
                    fixed: np.ndarray, *, tolerance_m: float = 1e-10, max_iterations: int = 8,
                    chunk_frames: int = 512) -> tuple[np.ndarray, int, float]:
    """Project positions so every pair has its target length (vectorized over frames).

    Args:
        positions_m: (T, M, 3) positions [m], close to the manifold.
        pairs: (B, 2) length-constrained marker pairs.
        targets_m: (T, B) target lengths [m].
        fixed: (T, M, 3) bool, coordinates that must not move (hard positional constraints).
        tolerance_m: stop when max |length - target| <= this.
        max_iterations: Newton iterations at most.
        chunk_frames: frames per batched solve (bounds memory).

    Returns:
        (positions (T, M, 3), iterations used, final max residual [m]).
    """
    pos = positions_m.copy()
    n_frames, n_markers, _ = pos.shape
    n_pairs = len(pairs)
    free = (~fixed).reshape(n_frames, 3 * n_markers).astype(float)
    residual = float(np.abs(bone_lengths(pos, pairs) - targets_m).max())
    iterations = 0
    rows = np.arange(n_pairs)
    cols_a = pairs[:, 0, None] * 3 + np.arange(3)
    cols_b = pairs[:, 1, None] * 3 + np.arange(3)
    while residual > tolerance_m and iterations < max_iterations:
        iterations += 1
        for start in range(0, n_frames, chunk_frames):  # memory bound, not a per-frame loop
            sl = slice(start, min(n_frames, start + chunk_frames))
            p = pos[sl]
            c = bone_lengths(p, pairs) - targets_m[sl]  # (F, B)
            u = bone_directions(p, pairs)  # (F, B, 3)
            jac = np.zeros((p.shape[0], n_pairs, 3 * n_markers))
            jac[:, rows[:, None], cols_a] = u
            jac[:, rows[:, None], cols_b] = -u
            jac *= free[sl, None, :]
            jjt = jac @ jac.transpose(0, 2, 1)
            # pairs with both ends pinned have a zero row: the ridge keeps the solve defined
            jjt += 1e-12 * np.eye(n_pairs)
            y = np.linalg.solve(jjt, -c[..., None])
            pos[sl] += (jac.transpose(0, 2, 1) @ y).reshape(p.shape)
        residual = float(np.abs(bone_lengths(pos, pairs) - targets_m).max())
    return pos, iterations, residual
