"""The design parameters of the optimization: the reduced trajectory ``Theta_hat`` (r x n) of the
five non-foot link angles, band-limited to K harmonics of the cycle, and the torques ``U``
(n x 6), optionally band-limited the same way.

The link angles come from the parameters by the PCA restoration (eq. 27) and go back by the
PCA projection (eq. 26); the foot angles are the contact schedule's, never optimized.
"""

from __future__ import annotations

import numpy as np

from ..errors import OptionError
from .pca import PCABasis


def fourier_basis(n: int, harmonics: int | None) -> np.ndarray:
    """(n, nb) orthonormal real Fourier basis of harmonics 0..K of an n-sample cycle
    (identity for None: every sample free)."""
    if harmonics is None:
        return np.eye(n)
    K = int(harmonics)
    if not 1 <= K < n // 2:
        raise OptionError("harmonics", harmonics, f"1..{n // 2 - 1} or None")
    t = 2 * np.pi * np.arange(n) / n
    cols = [np.ones(n) / np.sqrt(n)]
    for k in range(1, K + 1):
        cols.append(np.cos(k * t) * np.sqrt(2.0 / n))
        cols.append(np.sin(k * t) * np.sqrt(2.0 / n))
    return np.stack(cols, axis=1)


class Parametrization:
    """Parameters <-> link angles and torques (eqs 26-27 and the band limits), a part of
    :class:`~imesh.reduction.optimize.MotionOptimizer`.

    Attributes:
        phi0: (n, 7) initial link angles with the schedule's feet.
        mid: indices of the five non-foot link angles.
        basis: the PCA basis (None when not reduced).
        fourier: (n, nb) band-limited basis of the trajectory parameters.
        fourier_u: (n, nbu) band-limited basis of the torque parameters.
    """

    phi0: np.ndarray
    mid: list[int]
    basis: PCABasis | None
    fourier: np.ndarray
    fourier_u: np.ndarray

    @property
    def basis_matrix(self) -> np.ndarray:
        """(5, r) d Theta_mid / d Theta_hat."""
        return self.basis.Q1 if self.basis is not None else np.eye(5)

    def to_params(self, phi: np.ndarray) -> np.ndarray:
        """(r, nb) parameters of a motion's non-foot angles: PCA projection (eq. 26), then the
        band-limited projection."""
        mid = phi[:, self.mid].T
        hat = self.basis.reduce(mid) if self.basis is not None else mid.copy()
        return hat @ self.fourier

    def to_phi(self, params: np.ndarray) -> np.ndarray:
        """(n, 7) link angles from parameters (restoration, eq. 27) and the given feet."""
        phi = self.phi0.copy()
        hat = params @ self.fourier.T
        mid = self.basis.restore(hat) if self.basis is not None else hat
        phi[:, self.mid] = mid.T
        return phi

    def split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Trajectory parameters (r, nb) and torque parameters (6, nbu) of a flat vector
        (trajectory parameters first, harmonic-major: the Jacobian's column order)."""
        nb, r = self.fourier.shape[1], self.basis_matrix.shape[1]
        pt = x[: nb * r].reshape(nb, r).T
        pu = x[nb * r:].reshape(self.fourier_u.shape[1], 6).T
        return pt, pu

    def to_torque_params(self, torque: np.ndarray) -> np.ndarray:
        """(6, nbu) band-limited torque parameters of (n, 6) torques."""
        return torque.T @ self.fourier_u

    def to_torque(self, params_u: np.ndarray) -> np.ndarray:
        """(n, 6) torques of (6, nbu) band-limited torque parameters."""
        return (params_u @ self.fourier_u.T).T
