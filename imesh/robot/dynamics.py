"""The rigid-body dynamics of one state (q, v) that a whole-body controller needs, computed in
one pinocchio pass (:meth:`imesh.robot.configuration.Configuration.dynamics`).

With ``M(q) a + h(q, v) = S^T tau + sum_c J_c(q)^T w_c`` (floating-base equation of motion,
``w_c`` contact wrenches at points fixed in frames) and the task accelerations
``xdd = J a + Jdot v`` of points and of the centre of mass, a controller that chooses ``a`` and
``w_c`` by a QP needs ``M``, ``h``, the Jacobians ``J`` and the drifts ``Jdot v``; this type
carries them for one state, all in the world-aligned convention (linear rows at the point,
angular rows about the world axes), ``v`` in pinocchio's convention (base twist in the base
frame).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class Dynamics:
    """Equation-of-motion terms and task kinematics at one state.

    Attributes:
        mass_matrix: (nv, nv) float joint-space inertia ``M(q)`` (symmetric) [kg, kg m^2].
        bias: (nv,) float ``h = C(q, v) v + g(q)`` [N, Nm].
        com_m: (3,) float centre of mass [m].
        com_velocity: (3,) float CoM velocity [m/s].
        com_jacobian: (3, nv) float ``cdot = J_com v``.
        com_drift: (3,) float ``Jdot_com v`` [m/s^2] (the CoM acceleration when ``a = 0``).
        poses: (F, 4, 4) float world poses of the frames asked for, their origin moved to the
            points asked for (rotation of the frame, translation of the point).
        jacobians: (F, 6, nv) float world-aligned Jacobians of those points: rows 0-2 the
            point's linear velocity, rows 3-5 the frame's angular velocity.
        drifts: (F, 6) float ``Jdot v`` of those rows (classical acceleration when ``a = 0``)
            [m/s^2, rad/s^2].
        twists: (F, 6) float ``J v``: linear velocity of the points, angular velocity of the
            frames [m/s, rad/s].
        centroidal_map: (6, nv) float ``A_g`` of the centroidal momentum ``h = A_g v`` (linear
            momentum, angular momentum about the CoM; world axes) [kg m/s, kg m^2/s].
        centroidal_drift: (6,) float ``Adot_g v``: the momentum rate when ``a = 0``.
    """

    mass_matrix: np.ndarray
    bias: np.ndarray
    com_m: np.ndarray
    com_velocity: np.ndarray
    com_jacobian: np.ndarray
    com_drift: np.ndarray
    poses: np.ndarray
    jacobians: np.ndarray
    drifts: np.ndarray
    twists: np.ndarray
    centroidal_map: np.ndarray
    centroidal_drift: np.ndarray
