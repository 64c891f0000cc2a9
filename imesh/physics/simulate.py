"""Track a RobotMotion in DART: stable PD (or PID) plus inverse-dynamics feed-forward at 1 kHz,
torques clamped to the motors' limits, falls detected, contact forces turned into a ZMP.

The loop, per control step (all vectors in DART's DOF order, the base rows of the gains zero):

- SPD (Tan, Liu & Turk 2011): ``tau = -Kp (q + dt qdot - qref') - Kd (qdot + dt qddot - dqref')
  + tau_ff`` (``'`` = the next step's reference) with ``qddot`` predicted from
  ``(M + dt Kd) qddot = -C + p + d + tau_ff + f_c``, ``f_c`` the generalized constraint (contact)
  forces of the previous step (as in DART's biped example). Without ``f_c`` a floating base
  predicts that an ankle torque spins the light foot; the implicit damping then cancels the
  ankles' stiffness and a standing robot tips over (JVRC-1) or chatters (G1, HRP-4C). The mass
  matrix (about as costly as a physics step) is refreshed and Cholesky-factored every
  ``ControlConfig.mass_matrix_every`` steps; ``C`` (Coriolis and gravity) and ``f_c`` every step.
- PID: ``tau = tau_ff + Kp e + Kd de + Ki int(e)``.
- ``tau`` clamped to ``effort_max * ControlConfig.torque_limit_scale``.

The feed-forward is precomputed once per motion frame with pinocchio's inverse dynamics of the
reference (recursive Newton-Euler on the model the motion was fitted with; the DART model is
built from the same reduced URDF and checked against it): the base wrench it needs is
distributed over the support feet (wrenches at the sole centres, weighted least norm), the joint
torques follow, and they are interpolated linearly between frames. Joint targets are a cubic
spline of the frames.
"""

from __future__ import annotations

import logging
import time

import numpy as np
from scipy.linalg import lapack
from scipy.spatial.transform import Rotation

from ..contacts.phases import SIDES
from ..errors import ImeshError
from .config import PhysicsConfig
from .reference import Reference, build_reference, joint_splines, sample_frames
from .result import PhysicsResult
from .world import DartRobot, PhysicsError

log = logging.getLogger(__name__)

#: Control steps of the reference sampled at once (bounds the memory for long motions).
CHUNK_STEPS = 4000
#: A base faster than this [m/s or rad/s] or this far from the origin [m] has diverged.
DIVERGED_SPEED = 200.0
DIVERGED_M = 1000.0
#: Moment arm [m] that weighs the torques against the forces in the contact-wrench distribution.
WRENCH_ARM_M = 0.05


def _gains(robot, config: PhysicsConfig) -> tuple[np.ndarray, np.ndarray]:
    kp = config.control.kp_per_effort * robot.effort_max
    kd = config.control.kd_ratio * kp
    for name, (p, d) in config.control.gains.items():
        i = robot.joint_index(name)
        kp[i], kd[i] = p, d
    return kp, kd


def _explicit_gains(sim: DartRobot, kp: np.ndarray, kd: np.ndarray, dt: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Gains an explicit PD(-I) can integrate at ``dt``: capped per joint by its smallest
    effective inertia ``1 / (M^-1)_ii`` (every other DOF free): ``kp <= 0.2 I / dt^2``,
    ``kd <= 0.5 I / dt``."""
    M = np.asarray(sim.skeleton.getMassMatrix())
    inertia = 1.0 / np.diag(np.linalg.inv(M))[sim.joint_dofs]
    kp_cap, kd_cap = 0.2 * inertia / dt ** 2, 0.5 * inertia / dt
    capped = (kp > kp_cap) | (kd > kd_cap)
    if capped.any():
        log.info("PID: gains of %d joints capped for explicit stability at dt = %g s "
                 "(lightest: %s)", int(capped.sum()), dt,
                 sim.robot.joint_names[int(np.argmin(inertia))])
    return np.minimum(kp, kp_cap), np.minimum(kd, kd_cap)


def feedforward(sim: DartRobot, ref: Reference) -> tuple[np.ndarray, np.ndarray]:
    """Inverse-dynamics feed-forward of every reference frame (pinocchio, the model the motion
    was made with).

    Per frame, the generalized forces ``h = M a + C v + g`` (:meth:`imesh.robot.Robot.
    inverse_dynamics`); the base wrench ``h[:6]`` is produced by wrenches ``f`` at the centres
    of the support soles: ``J_base^T f = h[:6]``, weighted least norm (forces count
    ``WRENCH_ARM_M`` times more than moments), and the joint torques are
    ``(h - J^T f)[6:]``. A fixed base takes the base wrench itself.

    Args:
        sim: the robot in DART.
        ref: the reference.

    Returns:
        (tau_ff, wrenches): (T, n_dofs) float joint torques in DART DOF order (base rows 0)
        [Nm] and (T, 2, 6) float [left, right] planned sole wrenches (force [N], moment [Nm],
        world axes, at the sole centres; 0 off support).
    """
    robot = sim.robot
    nb = sim.base_dofs
    frames = [robot.soles[s].frame for s in SIDES]
    centres = np.array([robot.soles[s].center for s in SIDES])
    w2 = np.tile(np.r_[np.full(3, WRENCH_ARM_M ** 2), np.ones(3)], 2)
    T = ref.n_frames
    tau = np.zeros((T, sim.n_dofs))
    wrenches = np.zeros((T, 2, 6))
    for t in range(T):
        h = robot.inverse_dynamics(ref.q[t], ref.v[t], ref.a[t])
        feet = np.flatnonzero(ref.support[t])
        if nb and len(feet):
            robot.forward(ref.q[t])
            J = np.concatenate([robot.point_jacobians(None, frames, centres),
                                robot.frame_angular_jacobians(None, frames)], axis=1)[feet]
            J = J.reshape(6 * len(feet), -1)  # rows: (foot, [force xyz, moment xyz])
            A = J[:, :6].T  # (6, 6k): base rows of J^T
            W = w2[:6 * len(feet)]
            try:
                f = W * (A.T @ np.linalg.solve((A * W) @ A.T, h[:6]))
            except np.linalg.LinAlgError:
                f = np.linalg.lstsq(A, h[:6], rcond=None)[0]
            h = h - J.T @ f
            wrenches[t, feet] = f.reshape(len(feet), 6)
        tau[t, sim.joint_dofs] = h[6:]
    return tau, wrenches


def _tilt(rotvec_sim: np.ndarray, quat_ref: np.ndarray) -> float:
    """Angle [rad] between the base z axes of a DART base rotation vector and a reference
    quaternion (xyzw)."""
    z_sim = Rotation.from_rotvec(rotvec_sim).as_matrix()[:, 2]
    z_ref = Rotation.from_quat(quat_ref).as_matrix()[:, 2]
    return float(np.arccos(np.clip(z_sim @ z_ref, -1.0, 1.0)))


def simulate_motion(robot, motion, *, config: PhysicsConfig | None = None) -> PhysicsResult:
    """Track a robot motion in DART and judge it.

    The motion's first frame is placed on the ground (base height shifted for all frames so its
    lowest point is ``ground.start_clearance_m`` above z = 0), held for ``timing.settle_s``,
    then tracked; the last frame is held for ``timing.extra_time_s``.

    Args:
        robot: an :class:`imesh.robot.Robot`.
        motion: a :class:`imesh.core.robot_motion.RobotMotion` of this robot.
        config: PhysicsConfig.

    Returns:
        PhysicsResult (``.metrics()`` gives the DESIGN.md physics metrics, ``.plot(path)`` a
        figure).

    Raises:
        ImeshError: the motion is of another robot or has other joints.
        MissingDependencyError: dartpy missing (names the install command).
        PhysicsError: the DART model does not match.
    """
    config = config or PhysicsConfig()
    if motion.robot != robot.name or tuple(motion.joint_names) != tuple(robot.joint_names):
        raise ImeshError(f"motion of robot {motion.robot!r} with {len(motion.joint_names)} "
                         f"joints cannot be simulated on robot {robot.name!r} "
                         f"({robot.dof} joints): robot or joint names differ")
    t_setup = time.perf_counter()
    ref = build_reference(robot, motion.q, motion.fps, clearance_m=config.ground.start_clearance_m,
                          place_on_ground=not config.fixed_base)
    base_pose = np.eye(4)
    base_pose[:3, :3] = Rotation.from_quat(ref.q[0, 3:7]).as_matrix()
    base_pose[:3, 3] = ref.q[0, :3]
    sim = DartRobot(robot, config, base_pose=base_pose)
    skel, world = sim.skeleton, sim.world
    n, nb, dt = sim.n_dofs, sim.base_dofs, config.timing.dt
    fps = ref.fps

    # --- reference at the control rate ---------------------------------------------------------
    settle = int(round(config.timing.settle_s / dt))
    track = int(round((ref.duration_s + config.timing.extra_time_s) / dt))
    spline = joint_splines(ref.q, fps)
    jd = sim.joint_dofs
    if config.control.feedforward:
        tau_ff_frames = feedforward(sim, ref)[0]
    else:
        tau_ff_frames = np.zeros((ref.n_frames, n))

    def reference_chunk(start: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Targets, target rates and feed-forward of tracking steps start .. start + CHUNK
        (inclusive, so step i + 1 is there for every step i of the chunk)."""
        times = np.arange(start, min(start + CHUNK_STEPS, track) + 2) * dt
        qb, dqb = np.zeros((len(times), n)), np.zeros((len(times), n))
        tc = np.minimum(times, ref.duration_s)
        if spline is not None:
            qb[:, jd] = spline(tc)
            dqb[:, jd] = spline(tc, 1)
            dqb[times > ref.duration_s] = 0.0
        else:
            qb[:, jd] = ref.q[0, 7:]
        return qb, dqb, sample_frames(tau_ff_frames, times, fps)

    sim.set_state(ref.q[0])  # the first frame, at rest
    kp_j, kd_j = _gains(robot, config)
    if config.control.controller == "pid":
        kp_j, kd_j = _explicit_gains(sim, kp_j, kd_j, dt)
    kp, kd = np.zeros(n), np.zeros(n)
    kp[jd], kd[jd] = kp_j, kd_j
    ki = config.control.ki_ratio * kp
    limit = np.full(n, np.inf)
    limit[jd] = robot.effort_max * config.control.torque_limit_scale
    inv_limit = np.zeros(n)
    inv_limit[jd] = 1.0 / limit[jd]
    kd_dt = kd * dt
    spd = config.control.controller == "spd"

    setup_s = time.perf_counter() - t_setup

    # --- recording -----------------------------------------------------------------------------
    T = ref.n_frames
    frame_step = np.rint(np.arange(T) / fps / dt).astype(np.int64)  # tracking step of frame i
    frame_of_step = np.minimum(np.rint(np.arange(track + 1) * dt * fps).astype(np.int64), T - 1)
    pos_rec = np.full((T, n), np.nan)
    tau_rec = np.full((T, n), np.nan)
    ratio_rec = np.full(T, np.nan)
    cop = np.zeros((T, 3))  # sum fz*x, fz*y, fz over contact samples
    samples = np.zeros(T)
    sample_every = config.ground.contact_sample_every

    get_pos, get_vel = skel.getPositions, skel.getVelocities
    get_mass, get_cg = skel.getMassMatrix, skel.getCoriolisAndGravityForces
    set_forces, step = skel.setForces, world.step
    collision_result = world.getLastCollisionResult
    diag = np.diag_indices(n)
    chol = None
    get_constraint = skel.getConstraintForces
    integral = np.zeros(n)
    fell, reason = False, ""
    fall_step = None
    saturated = 0
    ratio_max = 0.0
    ctrl_s = 0.0
    base_z_ref = ref.q[:, 2]
    t0 = time.perf_counter()

    total = settle + track + 1
    buf = np.empty(n)
    next_frame = 0  # the next motion frame to record
    c0_step = 0
    qbar, dqbar, tau_ff = reference_chunk(0)
    for k in range(total):
        tracking = k >= settle
        i = k - settle if tracking else 0  # tracking step index
        c0 = time.perf_counter()
        pos = get_pos()
        vel = get_vel()
        nxt = i + 1 if tracking else 0
        if nxt >= c0_step + len(qbar):  # next chunk of the reference (bounded memory)
            c0_step = i
            qbar, dqbar, tau_ff = reference_chunk(i)
        if spd:
            if chol is None or k % config.control.mass_matrix_every == 0:
                M = get_mass()
                M[diag] += kd_dt
                chol, info = lapack.dpotrf(M)
                if info != 0:
                    raise PhysicsError(f"mass matrix not positive definite at step {k}")
            p = -kp * (pos + dt * vel - qbar[nxt - c0_step])
            d = -kd * (vel - dqbar[nxt - c0_step])
            ff = tau_ff[i - c0_step]
            rhs = p + d + ff - get_cg() + get_constraint()
            qdd = lapack.dpotrs(chol, rhs)[0]
            tau = p + d - kd_dt * qdd + ff
        else:
            e = qbar[i - c0_step] - pos
            integral += e * dt
            tau = (tau_ff[i - c0_step] + kp * e + kd * (dqbar[i - c0_step] - vel)
                   + ki * integral)
        np.abs(tau, out=buf)
        buf *= inv_limit
        ratio = float(buf.max())
        if ratio != ratio:  # NaN: a non-finite state propagates into every torque
            fell, reason, fall_step = True, "simulation diverged (non-finite state)", i
            break
        if nb and (abs(vel[:6]).max() > DIVERGED_SPEED or abs(pos[3:6]).max() > DIVERGED_M):
            # stop before ODE's collision space asserts (it aborts the process) on bodies
            # thrown kilometres away
            fell, fall_step = True, i
            reason = (f"simulation diverged (base speed {abs(vel[:6]).max():.0f}) at "
                      f"t = {i * dt:.2f} s")
            break
        if ratio > 1.0:
            np.clip(tau, -limit, limit, out=tau)
            if tracking:
                saturated += 1
        if nb:
            tau[:nb] = 0.0
        set_forces(tau)
        ctrl_s += time.perf_counter() - c0

        if tracking:
            f = frame_of_step[i]
            if ratio > ratio_max:
                ratio_max = ratio
            if not ratio <= ratio_rec[f]:  # NaN-aware max
                ratio_rec[f] = ratio
            while next_frame < T and frame_step[next_frame] <= i:
                f = next_frame
                next_frame += 1
                pos_rec[f] = pos
                tau_rec[f] = tau
                if nb:
                    low = pos[5] < base_z_ref[f] - config.fall.height_m
                    tilt = _tilt(pos[:3], ref.q[f, 3:7])
                    if (low or tilt > config.fall.tilt_rad) and not fell:
                        fell, fall_step = True, i
                        reason = (f"base {base_z_ref[f] - pos[5]:.2f} m below the reference"
                                  if low else f"base tilted {np.degrees(tilt):.0f} deg from the "
                                  "reference") + f" at t = {i * dt:.2f} s"
            if fell and config.fall.stop:
                pos_rec[f] = np.nan
                tau_rec[f] = np.nan
                break
        elif nb and k == settle - 1:
            tilt = _tilt(pos[:3], ref.q[0, 3:7])
            if pos[5] < base_z_ref[0] - config.fall.height_m or tilt > config.fall.tilt_rad:
                fell, fall_step, reason = True, 0, "fell while settling on the first frame"
                break
        step()
        if tracking and nb and i % sample_every == 0:
            f = frame_of_step[i]
            for c in collision_result().getContacts():
                fz = abs(c.force[2])
                pt = c.point
                cop[f, 0] += fz * pt[0]
                cop[f, 1] += fz * pt[1]
                cop[f, 2] += fz
            samples[f] += 1
    wall = time.perf_counter() - t0
    steps_done = k + 1

    # --- results -------------------------------------------------------------------------------
    if fell and fall_step is not None:
        survived = max(0.0, min(fall_step * dt, ref.duration_s))
    else:
        survived = ref.duration_s
    q_sim = np.full((T, robot.nq), np.nan)
    ok = ~np.isnan(pos_rec[:, 0])
    if ok.any():
        q_sim[ok] = sim.q_from_positions(pos_rec[ok], base_q=ref.q[0])
    err = q_sim[:, 7:] - ref.q[:, 7:]
    tracking_rms = float(np.sqrt(np.nanmean(err[ok] ** 2))) if ok.any() else float("nan")
    torques = np.full((T, robot.dof), np.nan)
    torques[ok] = tau_rec[ok][:, jd]
    with np.errstate(invalid="ignore", divide="ignore"):
        zmp_contact = cop[:, :2] / cop[:, 2:3]
        zmp_contact[(cop[:, 2] < 1.0) | ~ok] = np.nan
        force = np.where(samples > 0, cop[:, 2] / np.maximum(samples, 1), np.nan)
    force[~ok] = np.nan
    if ok.any():
        lastok = int(np.flatnonzero(ok)[-1])
        drift = float(np.linalg.norm(q_sim[lastok, :3] - ref.q[lastok, :3]))
        height_drift = float(np.nanmax(np.abs(q_sim[ok, 2] - ref.q[ok, 2])))
    else:
        drift = height_drift = float("nan")
    if config.fixed_base:
        drift = height_drift = 0.0
    tracked_steps = max(0, steps_done - settle)
    sim_time = steps_done * dt
    result = PhysicsResult(
        robot=robot.name, joint_names=tuple(robot.joint_names), fps=fps, fell=fell,
        fall_reason=reason, survived_s=float(survived),
        duration_s=float(ref.duration_s + config.timing.extra_time_s),
        tracking_rms_rad=tracking_rms, torque_ratio_max=float(ratio_max),
        saturation_fraction=saturated / max(tracked_steps, 1), base_drift_m=drift,
        base_height_drift_m=height_drift, real_time_factor=sim_time / max(wall, 1e-9),
        wall_s=wall, controller_us_per_step=1e6 * ctrl_s / max(steps_done, 1),
        physics_us_per_step=1e6 * (wall - ctrl_s) / max(steps_done, 1),
        times_s=np.arange(T) / fps, q=q_sim, q_reference=ref.q, joint_error_rad=err,
        torques_nm=torques, torque_ratio=ratio_rec, zmp_contact_m=zmp_contact,
        zmp_planned_m=ref.zmp_m, contact_force_n=force, support=ref.support,
        ground_offset_m=ref.ground_offset_m, config=config)
    log.info("DART %s (%s, %d frames at %g fps): %s, survived %.2f of %.2f s, tracking RMS "
             "%.4f rad, torque ratio %.2f, real-time factor %.2f (setup %.2f s)", robot.name,
             config.control.controller, T, fps, f"FELL ({reason})" if fell else "did not fall",
             survived, ref.duration_s, tracking_rms, ratio_max, result.real_time_factor, setup_s)
    return result
