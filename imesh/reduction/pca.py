"""Motion reduction by principal component analysis (eqs 23-29).

``Theta = Q S V^T`` (m signals x n samples); keeping the r largest singular values,
``Theta_hat = S_1 V_1^T`` (r x n, eq. 26) is the reduced motion and ``Theta = Q_1 Theta_hat``
(eq. 27) restores it. The gradient of any E w.r.t. Theta_hat is ``Q_1^T dE/dTheta`` (eq. 28).
As in the paper the SVD is of Theta itself (not mean-centred), so the first component carries the
mean posture; ``center=True`` subtracts the mean posture first (then restore adds it back).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import OptionError


@dataclass(frozen=True, eq=False)
class PCABasis:
    """A reduction basis.

    Attributes:
        Q1: (m, r) orthonormal columns spanning the kept subspace.
        singular_values: (min(m, n),) all singular values of the (centred) motion.
        mean: (m,) posture subtracted before the SVD (zeros unless centred).
    """

    Q1: np.ndarray
    singular_values: np.ndarray
    mean: np.ndarray

    @property
    def rank(self) -> int:
        return int(self.Q1.shape[1])

    def reduce(self, theta: np.ndarray) -> np.ndarray:
        """(r, n) Theta_hat = Q1^T (Theta - mean): the projection of a motion (eq. 26)."""
        return self.Q1.T @ (np.asarray(theta) - self.mean[:, None])

    def restore(self, theta_hat: np.ndarray) -> np.ndarray:
        """(m, n) Theta = Q1 Theta_hat + mean (eq. 27)."""
        return self.Q1 @ np.asarray(theta_hat) + self.mean[:, None]

    def gradient(self, dE_dtheta: np.ndarray) -> np.ndarray:
        """(r, n) dE/dTheta_hat = Q1^T dE/dTheta (eq. 28)."""
        return self.Q1.T @ np.asarray(dE_dtheta)

    def explained(self) -> float:
        """Fraction of the motion's squared norm the kept components carry."""
        s2 = self.singular_values ** 2
        return float(s2[: self.rank].sum() / s2.sum()) if s2.sum() > 0 else 1.0


def pca_basis(theta: np.ndarray, rank: int | None, center: bool = False) -> PCABasis:
    """The rank-r basis of a motion Theta (m, n) (eqs 23-25); ``rank=None`` keeps all m.

    Raises:
        OptionError: rank outside 1..m.
    """
    theta = np.asarray(theta, float)
    m = theta.shape[0]
    r = m if rank is None else int(rank)
    if not 1 <= r <= m:
        raise OptionError("reduced dimension r", rank, f"1..{m}")
    mean = theta.mean(axis=1) if center else np.zeros(m)
    Q, s, _ = np.linalg.svd(theta - mean[:, None], full_matrices=False)
    return PCABasis(Q1=Q[:, :r].copy(), singular_values=s, mean=mean)
