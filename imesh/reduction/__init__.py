"""Dynamically consistent motion design by PCA motion reduction (Okada & Miyazaki).

A human periodic motion (a walking cycle) becomes a cyclic robot motion that satisfies the
robot's equations of motion with its contacts, joint-angle and torque limits and positive
ground forces, optimized in a low-dimensional PCA subspace. Independent of the interaction-mesh
path; shares the loaders, robots and export.

Pipeline (each step is a public function):

    sagittal_capture(motion)      projection, link scaling, 2D inverse kinematics  (capture)
    make_cyclic(capture)          period, cycle averaging, FFT low-pass            (cyclic)
    contact_schedule(...)         base/moving foot, toe line/point contact, feet    (contact)
    derivative_matrices(n, dt, f) circulant F1, F2 (eqs 14-22)                     (diff)
    pca_basis(Theta, r)           SVD reduction (eqs 23-27)                        (pca)
    MotionOptimizer(...).run()    stages (I) and (II) (eqs 4-13, 28-34)            (optimize)

The optimizer is split by concept: its settings (``config``), the design parameters and their
restoration (eqs 26-27, ``parametrization``), the evaluation function and its residuals
(eqs 4-12, 31-34, ``objective``), their derivatives (eqs 13, 28, ``linearization``), the stage
(II) projections (eqs 8-11, ``projection``), the iterations (``optimize``) and what they hand
back (``result``).

``reduce_motion(motion, robot)`` runs them all. This package calls neither pinocchio nor DART:
the chain's rigid-body dynamics are behind :mod:`imesh.robot.planar`, the DART check is
:mod:`imesh.physics.reduction`. The 3D robots' sagittal joints are named in their
``robot.toml`` (``[sagittal] joints``).
"""

from ..core.lazy import lazy_exports

_LAZY = {
    **dict.fromkeys(("SagittalCapture", "sagittal_capture"), ".capture"),
    **dict.fromkeys(("JOINTS", "LINKS", "PlanarChain"), ".chain"),
    **dict.fromkeys(("ContactSchedule", "contact_schedule"), ".contact"),
    **dict.fromkeys(("CyclicMotion", "CyclicReport", "make_cyclic"), ".cyclic"),
    "derivative_matrices": ".diff",
    **dict.fromkeys(("GroundForceConfig", "JointLimitConfig", "MotionWeights",
                     "ReductionConfig", "SolverConfig", "SubspaceConfig"),
                    ".config"),
    "MotionOptimizer": ".optimize",
    "OptimizationResult": ".result",
    **dict.fromkeys(("PCABasis", "pca_basis"), ".pca"),
    **dict.fromkeys(("CycleConfig", "ReductionResult", "reduce_motion"),
                    ".pipeline"),
}
__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals())

__all__ = [
    "JOINTS", "LINKS", "ContactSchedule", "CycleConfig", "CyclicMotion", "CyclicReport",
    "GroundForceConfig", "JointLimitConfig", "MotionOptimizer", "MotionWeights",
    "OptimizationResult", "PCABasis", "PlanarChain", "ReductionConfig",
    "ReductionResult", "SagittalCapture", "SolverConfig", "SubspaceConfig", "contact_schedule",
    "derivative_matrices", "make_cyclic", "pca_basis", "reduce_motion", "sagittal_capture",
]
