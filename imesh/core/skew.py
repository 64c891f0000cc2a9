"""Cross-product matrices: ``skew(r) @ x == np.cross(r, x)``, for one vector or a batch."""

from __future__ import annotations

import numpy as np


def skew(r: np.ndarray) -> np.ndarray:
    """(..., 3, 3) cross-product matrices of (..., 3) vectors ``r``: ``skew(r) @ x ==
    np.cross(r, x)`` (a (3,) vector gives one (3, 3) matrix)."""
    r = np.asarray(r, dtype=float)
    out = np.zeros((*r.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -r[..., 2], r[..., 1], -r[..., 0]
    return out - np.swapaxes(out, -1, -2)
