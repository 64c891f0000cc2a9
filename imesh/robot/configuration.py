"""One configuration of a robot and the pinocchio Data computed at it: frame placements, frame
and point Jacobians, centre of mass, ZMP and inverse dynamics at a single ``q``.

Configuration vector ``q``: ``[x, y, z, qx, qy, qz, qw, joints...]`` (pinocchio free-flyer order,
base position in the world, base orientation as a unit quaternion), then one angle [rad] per
actuated joint. Velocity ``v`` (nv = nq - 1): base linear and angular velocity expressed in the
*base* frame (pinocchio's convention), then joint rates.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..core.skew import skew
from ..errors import ImeshError
from .dynamics import Dynamics
from .pin import _pinocchio

if TYPE_CHECKING:  # pragma: no cover - typing only
    import pinocchio  # no type information: its classes are Any to mypy

#: [m/s^2] gravity along -z.
GRAVITY = 9.81


class Configuration:
    """The pinocchio Data of one robot for one configuration, and what it holds.

    This is the cache behind the Robot's per-configuration getters, made explicit:

    - ``q`` is the configuration whose frame placements ``data`` holds (None before the first
      call), and ``has_jacobians`` whether ``data`` also holds the joint Jacobians at ``q``.
    - A getter given a ``q`` equal to ``self.q`` (element for element) reuses ``data``; another
      ``q`` recomputes it (placements only, or placements and Jacobians, as the getter needs)
      and becomes ``self.q``; ``q=None`` means "at ``self.q``" (an error before the first).
    - :meth:`forward` computes placements and Jacobians at once, for several Jacobian getters
      at the same ``q``.
    - Calls that run their own pinocchio pass (:meth:`com`, :meth:`com_jacobian`, :meth:`zmp`,
      :meth:`inverse_dynamics`) overwrite the joint placements in ``data``; they recompute the
      frame placements at their ``q`` afterwards, so ``self.q`` stays true to ``data``.

    Whole trajectories (:mod:`imesh.robot.trajectory`) use another Data and leave this one as
    it is.

    Args:
        model: the robot's pinocchio Model (shared, not modified).
        name: the robot name, for error messages.

    Attributes:
        model: the pinocchio Model.
        data: the pinocchio Data owned by this configuration.
        q: (nq,) float configuration the data is computed at, or None.
        has_jacobians: whether the joint Jacobians at ``q`` are computed too.
        mass: [kg] total mass.
    """

    def __init__(self, model: pinocchio.Model, name: str):
        self._pin = _pinocchio()
        self.model = model
        self.data = model.createData()
        self.name = name
        self.nq: int = int(model.nq)
        self.nv: int = int(model.nv)
        self.mass: float = float(self._pin.computeTotalMass(model))
        self.q: np.ndarray | None = None
        self.has_jacobians = False
        self._lower_triangle = np.tril_indices(self.nv, -1)

    # --- what the data holds --------------------------------------------------------------

    def check(self, q) -> np.ndarray:
        """(nq,) float ``q`` as an array.

        Raises:
            ImeshError: ``q`` has the wrong shape.
        """
        q = np.asarray(q, dtype=float)
        if q.shape != (self.nq,):
            raise ImeshError(f"robot {self.name!r}: q must have shape ({self.nq},), got "
                             f"{q.shape}")
        return q

    def forward(self, q) -> None:
        """Frame placements and joint Jacobians at ``q`` (nq,), which becomes ``self.q``."""
        q = self.check(q)
        self._pin.computeJointJacobians(self.model, self.data, q)
        self._pin.updateFramePlacements(self.model, self.data)
        self.q = q.copy()
        self.has_jacobians = True

    def _is_current(self, q: np.ndarray) -> bool:
        return self.q is not None and np.array_equal(q, self.q)

    def _current(self) -> np.ndarray:
        if self.q is None:
            raise ImeshError("no configuration yet: pass q or call forward(q) first")
        return self.q

    def placements_at(self, q) -> None:
        """Make ``data`` hold the frame placements at ``q`` (None: at ``self.q``)."""
        if q is None:
            self._current()
            return
        q = self.check(q)
        if self._is_current(q):  # already computed (e.g. by forward(q)): reuse
            return
        self._pin.framesForwardKinematics(self.model, self.data, q)
        self.q = q.copy()
        self.has_jacobians = False

    def jacobians_at(self, q) -> None:
        """Make ``data`` hold frame placements and joint Jacobians at ``q`` (None: ``self.q``)."""
        if q is None:
            q = self._current()
            if not self.has_jacobians:
                self.forward(q)
            return
        q = self.check(q)
        if not (self.has_jacobians and self._is_current(q)):
            self.forward(q)

    def _placements_after_pass(self, q: np.ndarray) -> None:
        """After a pinocchio call that overwrote the joint placements for ``q``: make the frame
        placements match ``q`` again (so that ``self.q`` tells what ``data`` holds)."""
        self._pin.framesForwardKinematics(self.model, self.data, q)
        self.q = q.copy()
        self.has_jacobians = False

    def _q_or_current(self, q) -> np.ndarray:
        return self._current() if q is None else self.check(q)

    # --- frames ---------------------------------------------------------------------------

    def frame_placements(self, q, ids: list[int]) -> np.ndarray:
        """(F, 4, 4) float world poses of the frames ``ids`` at ``q`` (None: ``self.q``)."""
        self.placements_at(q)
        return np.array([self.data.oMf[i].homogeneous for i in ids])

    def frame_positions(self, q, ids: list[int], offsets: np.ndarray | None = None
                        ) -> np.ndarray:
        """(F, 3) float [m] world positions at ``q`` (None: ``self.q``) of the points
        ``offsets`` (F, 3) [m] fixed in the frames ``ids`` (offsets None: the frame origins)."""
        self.placements_at(q)
        out = np.empty((len(ids), 3))
        for k, i in enumerate(ids):
            M = self.data.oMf[i]
            out[k] = M.translation if offsets is None else M.rotation @ offsets[k] + M.translation
        return out

    def frame_rotations(self, q, ids: list[int]) -> np.ndarray:
        """(F, 3, 3) float world rotations of frames (columns = frame axes in the world)."""
        self.placements_at(q)
        return np.array([self.data.oMf[i].rotation for i in ids])

    def point_jacobians(self, q, ids: list[int], offsets: np.ndarray | None = None
                        ) -> np.ndarray:
        """(F, 3, nv) float world-aligned linear Jacobians at ``q`` (None: ``self.q``) of the
        points ``offsets`` (F, 3) [m] fixed in the frames ``ids`` (None: the frame origins)."""
        self.jacobians_at(q)
        pin = self._pin
        out = np.empty((len(ids), 3, self.nv))
        for k, i in enumerate(ids):
            J = pin.getFrameJacobian(self.model, self.data, i, pin.LOCAL_WORLD_ALIGNED)
            if offsets is None:
                out[k] = J[:3]
            else:
                # the point moves with the frame origin plus omega x r
                r = self.data.oMf[i].rotation @ offsets[k]
                out[k] = J[:3] - skew(r) @ J[3:]
        return out

    def frame_jacobians(self, q, ids: list[int]) -> np.ndarray:
        """(F, 6, nv) float world-aligned Jacobians of frames: rows 0-2 the frame origin's
        linear velocity, rows 3-5 the angular velocity."""
        self.jacobians_at(q)
        pin = self._pin
        out = np.empty((len(ids), 6, self.nv))
        for k, i in enumerate(ids):
            out[k] = pin.getFrameJacobian(self.model, self.data, i, pin.LOCAL_WORLD_ALIGNED)
        return out

    def frame_angular_jacobians(self, q, ids: list[int]) -> np.ndarray:
        """(F, 3, nv) float world angular-velocity Jacobians of frames (``omega = J @ v``)."""
        self.jacobians_at(q)
        pin = self._pin
        return np.array([pin.getFrameJacobian(self.model, self.data, i,
                                              pin.LOCAL_WORLD_ALIGNED)[3:]
                         for i in ids])

    # --- whole body -----------------------------------------------------------------------

    def com(self, q=None) -> np.ndarray:
        """(3,) float [m] world centre of mass (q None: ``self.q``)."""
        q = self._q_or_current(q)
        c = np.array(self._pin.centerOfMass(self.model, self.data, q))
        self._placements_after_pass(q)
        return c

    def com_jacobian(self, q=None) -> np.ndarray:
        """(3, nv) float Jacobian of the centre of mass (q None: ``self.q``)."""
        q = self._q_or_current(q)
        J = np.array(self._pin.jacobianCenterOfMass(self.model, self.data, q))
        self._placements_after_pass(q)
        return J

    def zmp(self, q, v, a, ground_z: float = 0.0) -> np.ndarray:
        """(2,) float [m] multibody ZMP (x, y) on the plane z = ``ground_z`` [m].

        From the CoM ``c`` and the rate of the centroidal momentum (linear ``m cddot`` and
        angular ``Ldot`` about the CoM):
        ``p_x = c_x - ((c_z - z0) cddot_x + Ldot_y / m) / (cddot_z + g)``,
        ``p_y = c_y - ((c_z - z0) cddot_y - Ldot_x / m) / (cddot_z + g)``.

        Args:
            q: (nq,) configuration; v: (nv,) velocity; a: (nv,) acceleration (pinocchio
            convention, base twist in the base frame).
        """
        pin = self._pin
        q = self.check(q)
        dh = np.array(pin.computeCentroidalMomentumTimeVariation(
            self.model, self.data, q, np.asarray(v, float), np.asarray(a, float)))
        c = np.array(self.data.com[0])
        m = self.mass
        cdd = dh[:3] / m
        ldot = dh[3:]
        denom = cdd[2] + GRAVITY
        h = c[2] - ground_z
        self._placements_after_pass(q)
        return np.array([c[0] - (h * cdd[0] + ldot[1] / m) / denom,
                         c[1] - (h * cdd[1] - ldot[0] / m) / denom])

    def inverse_dynamics(self, q, v, a) -> np.ndarray:
        """(nv,) float generalized forces ``M(q) a + C(q, v) v + g(q) + B qd`` (recursive
        Newton-Euler, plus the joints' viscous damping ``B`` of the URDF; pinocchio convention:
        the first 6 rows are the wrench the free-flyer needs, in the base frame, the rest joint
        torques [Nm])."""
        q = self.check(q)
        v = np.asarray(v, float)
        tau = np.array(self._pin.rnea(self.model, self.data, q, v, np.asarray(a, float)))
        tau[6:] += np.asarray(self.model.damping)[6:] * v[6:]
        self._placements_after_pass(q)
        return tau

    def dynamics(self, q, v, ids: list[int], offsets: np.ndarray) -> Dynamics:
        """Equation-of-motion terms and task kinematics at the state (q, v), one pinocchio pass.

        ``computeAllTerms`` gives ``M``, ``h = C v + g``, the joint Jacobians, the CoM and its
        Jacobian; a forward pass with ``a = 0`` gives the drifts ``Jdot v`` (classical
        accelerations of the points: ``a_o + alpha x r + omega x (omega x r)`` with ``r`` the
        point's offset from the frame origin in world axes).

        Args:
            q: (nq,) float configuration; v: (nv,) float velocity (pinocchio convention).
            ids: F frame indices.
            offsets: (F, 3) float [m] points fixed in those frames.

        Returns:
            :class:`imesh.robot.dynamics.Dynamics`; afterwards ``data`` holds the placements
            and joint Jacobians at ``q`` (``self.q``).
        """
        pin = self._pin
        q = self.check(q)
        v = np.asarray(v, dtype=float)
        model, data = self.model, self.data
        pin.computeAllTerms(model, data, q, v)
        M = np.array(data.M)
        lower = self._lower_triangle
        M[lower] = M.T[lower]  # pinocchio fills the upper triangle
        bias = np.array(data.nle)
        com = np.array(data.com[0])
        com_vel = np.array(data.vcom[0])
        Jcom = np.array(data.Jcom)
        pin.updateFramePlacements(model, data)
        F = len(ids)
        poses = np.zeros((F, 4, 4))
        poses[:, 3, 3] = 1.0
        jac = np.empty((F, 6, self.nv))
        for k, i in enumerate(ids):
            oMf = data.oMf[i]
            R = oMf.rotation
            r = R @ offsets[k]
            poses[k, :3, :3] = R
            poses[k, :3, 3] = oMf.translation + r
            J = pin.getFrameJacobian(model, data, i, pin.LOCAL_WORLD_ALIGNED)
            jac[k, :3] = J[:3] - skew(r) @ J[3:]
            jac[k, 3:] = J[3:]
        twists = jac @ v
        # a = 0: the drifts (this pass also writes data.acom[0])
        pin.centerOfMass(model, data, q, v, np.zeros(self.nv))
        com_drift = np.array(data.acom[0])
        drifts = np.empty((F, 6))
        for k, i in enumerate(ids):
            acc = pin.getFrameClassicalAcceleration(model, data, i, pin.LOCAL_WORLD_ALIGNED)
            r = poses[k, :3, 3] - data.oMf[i].translation
            w = twists[k, 3:]
            # omega x (omega x r) = omega (omega . r) - r |omega|^2
            drifts[k, :3] = (acc.linear + skew(acc.angular) @ r + w * (w @ r) - r * (w @ w))
            drifts[k, 3:] = acc.angular
        pin.computeCentroidalMapTimeVariation(model, data, q, v)
        Ag = np.array(data.Ag)
        Ag_drift = np.array(data.dAg) @ v
        self.q = q.copy()
        self.has_jacobians = True
        return Dynamics(mass_matrix=M, bias=bias, com_m=com, com_velocity=com_vel,
                        com_jacobian=Jcom, com_drift=com_drift, poses=poses, jacobians=jac,
                        drifts=drifts, twists=twists, centroidal_map=Ag,
                        centroidal_drift=Ag_drift)
