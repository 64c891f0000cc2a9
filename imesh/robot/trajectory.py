"""Kinematics and dynamics along a whole trajectory of configurations ``q`` (T, nq): frame
placements and Jacobians, centroidal momentum rates, inverse dynamics and its derivatives.

pinocchio computes one configuration at a time; these loops fill (T, ...) arrays with one pass
of calls per configuration. They run on a Data of their own (:class:`TrajectoryData`), so that
a :class:`imesh.robot.configuration.Configuration` keeps what it holds.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .pin import _pinocchio

if TYPE_CHECKING:  # pragma: no cover - typing only
    import pinocchio  # no type information: its classes are Any to mypy


@dataclass(frozen=True, eq=False)
class TrajectoryKinematics:
    """Kinematics of a configuration trajectory (:meth:`TrajectoryData.kinematics`).

    Attributes:
        placements: (T, F, 4, 4) float world poses of the frames.
        jacobians: (T, F, 6, nv) float world-aligned frame Jacobians (rows 0-2 the origin's
            linear velocity, 3-5 the angular velocity).
        com: (T, 3) float [m] centre of mass.
        com_jacobians: (T, 3, nv) float Jacobians of the centre of mass.
    """

    placements: np.ndarray
    jacobians: np.ndarray
    com: np.ndarray
    com_jacobians: np.ndarray


class TrajectoryData:
    """A pinocchio Data for computing along trajectories of one robot model.

    Args:
        model: the robot's pinocchio Model (shared, not modified).
    """

    def __init__(self, model: pinocchio.Model):
        self._pin = _pinocchio()
        self.model = model
        self.data = model.createData()
        self.nv: int = int(model.nv)
        #: (nv - 6,) viscous damping of the joints [N m s/rad] (the URDF's <dynamics damping>)
        self.damping = np.array(model.damping)[6:]

    def kinematics(self, q: np.ndarray, ids: list[int]) -> TrajectoryKinematics:
        """Placements and world-aligned Jacobians of frames, CoM and its Jacobian, at every
        configuration of a trajectory (one pass of pinocchio calls per configuration: joint
        Jacobians once, then the frames and the CoM from them).

        Args:
            q: (T, nq) float configurations.
            ids: F frame indices.
        """
        pin, model, data = self._pin, self.model, self.data
        q = np.asarray(q, dtype=float)
        T = len(q)
        place = np.empty((T, len(ids), 4, 4))
        jac = np.empty((T, len(ids), 6, self.nv))
        com = np.empty((T, 3))
        jcom = np.empty((T, 3, self.nv))
        world = pin.LOCAL_WORLD_ALIGNED
        for t in range(T):  # pinocchio is per configuration; ~30 us per frame
            pin.computeJointJacobians(model, data, q[t])
            pin.updateFramePlacements(model, data)
            jcom[t] = pin.jacobianCenterOfMass(model, data, True)
            com[t] = data.com[0]
            for k, i in enumerate(ids):
                place[t, k] = data.oMf[i].homogeneous
                jac[t, k] = pin.getFrameJacobian(model, data, i, world)
        return TrajectoryKinematics(placements=place, jacobians=jac, com=com,
                                    com_jacobians=jcom)

    def centroidal(self, q: np.ndarray, v: np.ndarray, fps: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Centroidal quantities along a sampled trajectory (pinocchio ``ccrba``), their rates
        by the same differences the whole-body QP linearizes.

        The rate of the centroidal momentum is taken from the sampled trajectory itself:
        ``m c'' = m D c`` and ``Ld = grad k`` with ``D = grad grad`` (``numpy.gradient`` at the
        frame rate: central inside, one-sided at the ends) and ``k_t`` the angular part of
        ``Ag(q_t) v_t``. The CoM of every frame is exact, so ``D c`` is the acceleration the
        frames show; pinocchio's continuous-time rate (``computeCentroidalMomentumTimeVariation``
        with finite-differenced base twists) carries ``O((h w)^2)`` errors that grow with the
        spin rate ``w``: 21 m/s^2 of CoM acceleration on CMU 05_06's jete turns (950 deg/s of
        yaw at 30 fps), where the QP, which moves ``D c``, could not lower them.

        Args:
            q: (T, nq) configurations; v: (T, nv) velocities
                (:func:`imesh.metrics.derivatives.motion_derivatives`); fps: frame rate [1/s].

        Returns:
            (com (T, 3) [m], dh (T, 6) rate of the centroidal momentum [linear N, angular Nm]
            about the CoM, Ag (T, 6, nv) centroidal momentum matrix: ``h = Ag v``).
        """
        pin, model, data = self._pin, self.model, self.data
        T = len(q)
        com, ag = np.empty((T, 3)), np.empty((T, 6, self.nv))
        for t in range(T):  # pinocchio is per configuration
            ag[t] = pin.ccrba(model, data, q[t], v[t])
            com[t] = data.com[0]
        dh = np.zeros((T, 6))
        if T >= 2:
            h = 1.0 / fps
            mass = float(pin.computeTotalMass(model))
            dh[:, :3] = mass * np.gradient(np.gradient(com, h, axis=0), h, axis=0)
            dh[:, 3:] = np.gradient(np.einsum("tij,tj->ti", ag[:, 3:], v), h, axis=0)
        return com, dh, ag

    def momentum_jacobians(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(T, 6, nv) derivative of the centroidal momentum ``h = Ag(q) v`` (about the CoM) with
        respect to a tangent perturbation of each ``q_t``, its velocity ``v_t`` held (pinocchio
        ``computeCentroidalDynamicsDerivatives``): a spinning body tilted turns its angular
        momentum with it."""
        pin, model, data = self._pin, self.model, self.data
        out = np.empty((len(q), 6, self.nv))
        zero = np.zeros(self.nv)
        for t in range(len(q)):  # pinocchio is per configuration
            out[t] = pin.computeCentroidalDynamicsDerivatives(model, data, q[t], v[t], zero)[0]
        return out

    def inverse_dynamics(self, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                         derivatives: np.ndarray | None = None
                         ) -> tuple[np.ndarray, np.ndarray]:
        """Inverse dynamics along a trajectory (pinocchio ``rnea``; where asked, also
        ``computeRNEADerivatives``), plus the joints' viscous damping ``B qd`` (the URDF's
        ``<dynamics damping>``, which the simulator applies and the motors pay: iCub's 1 N m s
        /rad on a wrist of 0.45-0.65 N m caps its speed near 0.5 rad/s).

        Args:
            q: (T, nq) configurations; v, a: (T, nv) velocities and accelerations.
            derivatives: (T,) bool frames whose partial derivatives are wanted (None: none).

        Returns:
            (tau (T, nv), dtau (T, 3, nv, nv)): generalized forces (the base's wrench in the base
            frame, then joint torques [Nm]) and, at the frames asked for, ``[dtau/dq, dtau/dv,
            dtau/da]`` (with respect to a tangent perturbation of q); zeros elsewhere.
        """
        damped = np.arange(6, self.nv)
        pin, model, data = self._pin, self.model, self.data
        T = len(q)
        tau = np.empty((T, self.nv))
        dtau = np.zeros((T, 3, self.nv, self.nv))
        want = np.zeros(T, bool) if derivatives is None else np.asarray(derivatives, bool)
        upper = np.triu(np.ones((self.nv, self.nv), bool), 1)
        for t in range(T):  # pinocchio is per configuration
            tau[t] = pin.rnea(model, data, q[t], v[t], a[t])
            if want[t]:
                dq, dv, da = pin.computeRNEADerivatives(model, data, q[t], v[t], a[t])
                dtau[t, 0], dtau[t, 1], dtau[t, 2] = dq, dv, da
                # pinocchio fills only the upper triangle of dtau/da (the mass matrix)
                dtau[t, 2][upper.T] = dtau[t, 2].T[upper.T]
        tau[:, 6:] += self.damping * v[:, 6:]
        dtau[:, 1, damped, damped] += np.where(want[:, None], self.damping, 0.0)
        return tau, dtau
