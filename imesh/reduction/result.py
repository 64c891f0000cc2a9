"""What the motion-reduction optimizer hands back: one record per iteration of stages (I) and
(II) with both terms of E = J_r + J_m (eq. 12) and the constraint evidence, and the optimized
motion with its torques."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .config import ReductionConfig
from .objective import Evaluation
from .pca import PCABasis


@dataclass
class IterationRecord:
    """One iteration (stage I + II): both evaluation terms and the constraint evidence."""

    iteration: int
    J_m: float
    J_r: float
    E: float
    penalty: float
    closure_max_mm: float
    slip_max_m_s: float
    min_grf_N: float
    angle_violations: int
    torque_violations: int
    seconds: float
    step: float = float("nan")
    projected_angles: int = 0
    projected_torques: int = 0


@dataclass
class OptimizationResult:
    """The optimized motion and the evidence.

    Attributes:
        phi, phid, phidd: (n, 7) link angles, rates, accelerations of the robot motion.
        torque: (n, 6) [Nm] joint torques (JOINTS order).
        initial: evaluation of the initial motion with its best torques.
        final: evaluation of the result.
        history: one record per iteration (stage I + II).
        basis: the PCA basis (None when not reduced).
        seconds: wall time [s].
        converged: the stopping tests were met (not just the iteration limit).
    """

    phi: np.ndarray
    phid: np.ndarray
    phidd: np.ndarray
    torque: np.ndarray
    initial: Evaluation
    final: Evaluation
    history: list[IterationRecord]
    basis: PCABasis | None
    seconds: float
    converged: bool
    config: ReductionConfig = field(default_factory=ReductionConfig)
