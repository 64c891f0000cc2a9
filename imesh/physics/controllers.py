"""The controllers of the DART check, one class per ``ControlConfig.controller``:

- ``wbc`` (:class:`WbcTracker`): the whole-body QP controller of :mod:`imesh.physics.wbc`
  (balance feedback; what a real humanoid runs);
- ``kinematic`` (:class:`KinematicTracker`): the paper's check: every joint follows the reference
  exactly (DART velocity actuators, as the "high-gain" joints of Choreonoid's simulator), only the
  base is free, so the motion stands or falls by its own dynamics;
- ``spd`` / ``pid`` (:class:`JointTracker`): open-loop joint tracking, stable PD (Tan, Liu & Turk
  2011) or explicit PID, each with the inverse-dynamics feed-forward of the reference.

Each is built once per simulation and called once per physics step with the DART state; it sets
the skeleton's forces (or commands) and returns the demanded torques and their largest ratio to
the effort limits (before any clamping).
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import numpy as np
from scipy.linalg import lapack

from .config import PhysicsConfig
from .points import planned_point_contacts
from .reference import Reference, joint_splines, sample_frames
from .so3 import exp_so3, matrix_to_quat_xyzw
from .track import ReferenceTrack
from .wbc import ControlStep, WholeBodyController
from .world import DartRobot, PhysicsError

if TYPE_CHECKING:
    from ..scene.surfaces import SupportSurfaces

log = logging.getLogger(__name__)

#: Control steps of the reference sampled at once (bounds the memory for long motions).
CHUNK_STEPS = 4000


class _Limits:
    """Effort limits in DART's DOF order (base rows unlimited)."""

    def __init__(self, sim: DartRobot, scale: float):
        n, jd = sim.n_dofs, sim.joint_dofs
        self.limit = np.full(n, np.inf)
        self.limit[jd] = sim.robot.effort_max * scale
        self.inverse = np.zeros(n)
        self.inverse[jd] = 1.0 / self.limit[jd]

    def ratio(self, tau: np.ndarray) -> float:
        return float(np.max(np.abs(tau) * self.inverse))


class JointTracker:
    """Open-loop joint tracking: SPD or PID plus the inverse-dynamics feed-forward, torques
    clamped to the limits (``docs/checking.md``)."""

    def __init__(self, sim: DartRobot, ref: Reference, config: PhysicsConfig,
                 tau_ff_frames: np.ndarray, track_steps: int):
        self.sim, self.ref, self.config = sim, ref, config
        robot, n, dt = sim.robot, sim.n_dofs, config.timing.dt
        self.dt, self.n, self.track_steps = dt, n, track_steps
        self.spline = joint_splines(ref.q, ref.fps)
        self.tau_ff_frames = tau_ff_frames
        kp_j = config.control.kp_per_effort * robot.effort_max
        kd_j = config.control.kd_ratio * kp_j
        for name, (p, d) in config.control.gains.items():
            i = robot.joint_index(name)
            kp_j[i], kd_j[i] = p, d
        if config.control.controller == "pid":
            kp_j, kd_j = self._explicit_gains(kp_j, kd_j)
        jd = sim.joint_dofs
        self.kp, self.kd = np.zeros(n), np.zeros(n)
        self.kp[jd], self.kd[jd] = kp_j, kd_j
        self.ki = config.control.ki_ratio * self.kp
        self.kd_dt = self.kd * dt
        self.limits = _Limits(sim, config.control.torque_limit_scale)
        self.spd = config.control.controller == "spd"
        self.integral = np.zeros(n)
        self.chol: np.ndarray | None = None
        self.diag = np.diag_indices(n)
        self.c0 = 0
        self.qbar, self.dqbar, self.tau_ff = self._chunk(0)

    def _explicit_gains(self, kp: np.ndarray, kd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gains an explicit PD(-I) can integrate at ``dt``: capped per joint by its smallest
        effective inertia ``1 / (M^-1)_ii`` (every other DOF free): ``kp <= 0.2 I / dt^2``,
        ``kd <= 0.5 I / dt``."""
        sim, dt = self.sim, self.dt
        M = np.asarray(sim.skeleton.getMassMatrix())
        inertia = 1.0 / np.diag(np.linalg.inv(M))[sim.joint_dofs]
        kp_cap, kd_cap = 0.2 * inertia / dt ** 2, 0.5 * inertia / dt
        capped = (kp > kp_cap) | (kd > kd_cap)
        if capped.any():
            log.info("PID: gains of %d joints capped for explicit stability at dt = %g s "
                     "(lightest: %s)", int(capped.sum()), dt,
                     sim.robot.joint_names[int(np.argmin(inertia))])
        return np.minimum(kp, kp_cap), np.minimum(kd, kd_cap)

    def _chunk(self, start: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Targets, target rates and feed-forward of tracking steps start .. start + CHUNK
        (inclusive, so step i + 1 is there for every step i of the chunk)."""
        ref, n, jd, dt = self.ref, self.n, self.sim.joint_dofs, self.dt
        times = np.arange(start, min(start + CHUNK_STEPS, self.track_steps) + 2) * dt
        qb, dqb = np.zeros((len(times), n)), np.zeros((len(times), n))
        tc = np.minimum(times, ref.duration_s)
        if self.spline is not None:
            qb[:, jd] = self.spline(tc)
            dqb[:, jd] = self.spline(tc, 1)
            dqb[times > ref.duration_s] = 0.0
        else:
            qb[:, jd] = ref.q[0, 7:]
        return qb, dqb, sample_frames(self.tau_ff_frames, times, ref.fps)

    def __call__(self, k: int, i: int, tracking: bool, pos: np.ndarray, vel: np.ndarray
                 ) -> tuple[np.ndarray, float]:
        skel, dt = self.sim.skeleton, self.dt
        nxt = i + 1 if tracking else 0
        if nxt >= self.c0 + len(self.qbar):  # next chunk of the reference (bounded memory)
            self.c0 = i
            self.qbar, self.dqbar, self.tau_ff = self._chunk(i)
        c0 = self.c0
        if self.spd:
            if self.chol is None or k % self.config.control.mass_matrix_every == 0:
                M = skel.getMassMatrix()
                M[self.diag] += self.kd_dt
                self.chol, info = lapack.dpotrf(M)
                if info != 0:
                    raise PhysicsError(f"mass matrix not positive definite at step {k}")
            p = -self.kp * (pos + dt * vel - self.qbar[nxt - c0])
            d = -self.kd * (vel - self.dqbar[nxt - c0])
            ff = self.tau_ff[i - c0]
            rhs = p + d + ff - skel.getCoriolisAndGravityForces() + skel.getConstraintForces()
            qdd = lapack.dpotrs(self.chol, rhs)[0]
            tau = p + d - self.kd_dt * qdd + ff
        else:
            e = self.qbar[i - c0] - pos
            self.integral += e * dt
            tau = (self.tau_ff[i - c0] + self.kp * e + self.kd * (self.dqbar[i - c0] - vel)
                   + self.ki * self.integral)
        ratio = self.limits.ratio(tau)
        if ratio > 1.0:
            np.clip(tau, -self.limits.limit, self.limits.limit, out=tau)
        tau[:self.sim.base_dofs] = 0.0
        skel.setForces(tau)
        return tau, ratio


class WbcTracker:
    """The whole-body QP controller in DART: the DART state converted to pinocchio's (q, v),
    one QP every ``1 / WbcConfig.rate_hz`` seconds, the torques held in between."""

    def __init__(self, sim: DartRobot, ref: Reference, config: PhysicsConfig,
                 surfaces: SupportSurfaces | None = None):
        self.sim = sim
        self.config = config
        self.track = ReferenceTrack(sim.robot, ref)
        # hands and knees the reference rests on prop tops (none on a floor alone)
        points = (planned_point_contacts(sim.robot, ref.q, surfaces)
                  if surfaces is not None and not surfaces.flat else None)
        self.controller = WholeBodyController(sim.robot, self.track, config.control.wbc,
                                              config.ground.friction,
                                              joint_damping=sim.joint_damping,
                                              time_step_s=config.timing.dt,
                                              slide_friction=config.ground.slide_friction,
                                              surfaces=surfaces, points=points)
        dt = config.timing.dt
        self.every = max(1, int(round(1.0 / (config.control.wbc.rate_hz * dt))))
        self.dt = dt
        self.limits = _Limits(sim, 1.0)
        self.tau = np.zeros(sim.n_dofs)
        self.ratio = 0.0
        self.last: ControlStep | None = None

    def __call__(self, k: int, i: int, tracking: bool, pos: np.ndarray, vel: np.ndarray
                 ) -> tuple[np.ndarray, float]:
        if k % self.every == 0 or self.last is None:
            sim = self.sim
            # DART (rotation vector, translation; world twist) -> pinocchio (position,
            # quaternion xyzw, joints; base-frame twist), per step without scipy
            R = exp_so3(pos[:3])
            q = np.concatenate([pos[3:6], matrix_to_quat_xyzw(R), pos[sim.joint_dofs]])
            v = np.concatenate([R.T @ vel[3:6], R.T @ vel[:3], vel[sim.joint_dofs]])
            t = i * self.dt if tracking else 0.0
            step = self.controller.step(t, q, v)
            self.last = step
            self.tau = np.zeros(sim.n_dofs)
            self.tau[sim.joint_dofs] = step.tau
            self.ratio = self.limits.ratio(self.tau)
            sim.skeleton.setForces(self.tau)
        return self.tau, self.ratio


class KinematicTracker:
    """The paper's check: every joint a velocity actuator following the reference (DART
    computes whatever torque that takes), the base free. The joint velocity command is the
    reference's rate plus ``(q_ref - q) / tau`` with ``tau`` five steps, so the joints track to
    the integration error. DART's velocity actuators act through its constraint solver and
    report no joint force, so this mode has no torque figures (its torque ratio reads 0): it
    asks whether the motion balances, not whether the motors can."""

    def __init__(self, sim: DartRobot, ref: Reference, config: PhysicsConfig):
        dart = sim.dart
        self.sim, self.ref, self.dt = sim, ref, config.timing.dt
        self.spline = joint_splines(ref.q, ref.fps)
        skel = sim.skeleton
        for j in range(skel.getNumJoints()):
            joint = skel.getJoint(j)
            if joint.getNumDofs() and joint is not skel.getRootJoint():
                joint.setActuatorType(dart.dynamics.ActuatorType.VELOCITY)
        if config.fixed_base:
            skel.getRootJoint().setActuatorType(dart.dynamics.ActuatorType.LOCKED)
        self.limits = _Limits(sim, 1.0)
        self.command = np.zeros(sim.n_dofs)
        self.gain = 1.0 / (5 * self.dt)

    def __call__(self, k: int, i: int, tracking: bool, pos: np.ndarray, vel: np.ndarray
                 ) -> tuple[np.ndarray, float]:
        sim, jd = self.sim, self.sim.joint_dofs
        t = min(i * self.dt, self.ref.duration_s) if tracking else 0.0
        if self.spline is None:
            q_ref, dq_ref = self.ref.q[0, 7:], np.zeros(len(jd))
        else:
            q_ref = self.spline(t)
            dq_ref = self.spline(t, 1) if 0.0 < t < self.ref.duration_s else 0.0 * q_ref
        self.command[jd] = dq_ref + self.gain * (q_ref - pos[jd])
        sim.skeleton.setCommands(self.command)
        tau = np.asarray(sim.skeleton.getForces())  # the previous step's actuator forces
        return tau, self.limits.ratio(tau)

