"""Track a RobotMotion in DART and judge it: one of the controllers of
:mod:`imesh.physics.controllers` at 1 kHz (the whole-body QP controller by default), falls
detected, the ground contact forces of each sole read back (centre of pressure, friction ratio),
and the simulated motion compared with the reference (joints, key points, base, sole slip).

The SPD and PID trackers add the feed-forward of :func:`feedforward`, precomputed once per
motion frame with pinocchio's inverse dynamics of the reference (recursive Newton-Euler on the
model the motion was fitted with; the DART model is built from the same reduced URDF and
checked against it): the base wrench it needs is distributed over the support feet (wrenches
at the sole centres, weighted least norm), the joint torques follow, and they are interpolated
linearly between frames.
"""

from __future__ import annotations

import dataclasses
import logging
import time

import numpy as np
from scipy.spatial.transform import Rotation

from ..contacts.phases import SIDES, runs
from ..errors import ImeshError
from ..metrics.markers import keypoint_motion
from ..metrics.soles import sole_tracks
from ..scene.surfaces import SupportSurfaces
from .config import PhysicsConfig
from .controllers import JointTracker, KinematicTracker, WbcTracker
from .reference import Reference, build_reference
from .result import PhysicsResult
from .world import DartRobot

log = logging.getLogger(__name__)

#: A base faster than this [m/s or rad/s] or this far from the origin [m] has diverged.
DIVERGED_SPEED = 200.0
DIVERGED_M = 1000.0
#: A sole corner this close to the ground is on it (for the slip figure) [m]. Loaded soles'
#: corners sit between -1.8 and +0.6 mm in DART (5th-95th percentile -0.7 and +0.6 mm over the
#: 12 runs of docs/wholebody.md); at 5 mm a heel 1.8 mm up, swinging sideways while its sole
#: turned on its toe, read as 8.9 mm of slip.
CONTACT_M = 0.001
#: Moment arm [m] that weighs the torques against the forces in the contact-wrench distribution.
WRENCH_ARM_M = 0.05
#: A sole this far below a prop's top, over it, still stands on it (the controller's contact
#: test, the slip figure) [m]: soles press 1-2 mm into a surface in DART.
SURFACE_BELOW_M = 0.05


def feedforward(sim: DartRobot, ref: Reference) -> tuple[np.ndarray, np.ndarray]:
    """Inverse-dynamics feed-forward of every reference frame (pinocchio, the model the motion
    was made with).

    Per frame, the generalized forces ``h = M a + C v + g + B qd`` (:meth:`imesh.robot.Robot.
    inverse_dynamics`, with the joints' damping the simulator applies); the base
    wrench ``h[:6]`` is produced by wrenches ``f`` at the centres of the support soles:
    ``J_base^T f = h[:6]``, weighted least norm (forces count
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


class _LostReference:
    """Whether the robot has lost the motion: a key point (markers.toml) farther than
    ``FallConfig.lost_m`` from where the reference has it. The reference's key points are
    computed once; a simulated frame costs one forward kinematics."""

    def __init__(self, robot, ref: Reference, limit_m: float):
        self.limit = limit_m
        self.on = limit_m > 0 and robot.markers is not None
        if self.on:
            self.robot = robot
            self.names, self.frames, self.offsets, _ = robot.keypoint_arrays()
            self.planned = keypoint_motion(robot, ref.q, ref.fps).positions_m

    def __call__(self, q: np.ndarray, frame: int) -> str:
        """'' while the key points of ``q`` (nq,) are within the limit of frame ``frame``'s,
        else the reason."""
        if not self.on:
            return ""
        pts = self.robot.frame_positions(q, self.frames, self.offsets)
        d = np.linalg.norm(pts - self.planned[frame], axis=1)
        k = int(np.argmax(d))
        if d[k] <= self.limit:
            return ""
        return (f"lost the motion: key point {self.names[k]!r} {d[k]:.2f} m from the "
                f"reference (limit {self.limit:g} m)")


def _contact_sides(sim: DartRobot) -> dict[str, int]:
    """Shape-node name -> sole index (0 left, 1 right) of the sole boxes."""
    return {f"{side}_sole": k for k, side in enumerate(SIDES)}


def _joint_tracking(config: PhysicsConfig) -> PhysicsConfig:
    """``config`` with the SPD joint tracker (a welded base has no balance to keep)."""
    return dataclasses.replace(config, control=dataclasses.replace(config.control,
                                                                   controller="spd"))


def _keypoint_errors(robot, ref: Reference, q_sim: np.ndarray, ok: np.ndarray
                     ) -> tuple[float, float, str, float]:
    """(RMS, max) [mm] distance between the robot's key points (markers.toml) in the simulated
    and the reference motion over the survived frames, the key point of the max and its time
    [s] (NaN and "" without key points)."""
    if robot.markers is None or not ok.any():
        return float("nan"), float("nan"), "", float("nan")
    sim = keypoint_motion(robot, q_sim[ok], ref.fps)
    planned = keypoint_motion(robot, ref.q[ok], ref.fps).positions_m
    d = np.linalg.norm(sim.positions_m - planned, axis=-1)
    f, k = np.unravel_index(int(np.argmax(d)), d.shape)
    return (float(1e3 * np.sqrt(np.mean(d ** 2))), float(1e3 * d.max()), sim.names[k],
            float(np.flatnonzero(ok)[f] / ref.fps))


def sole_slip(corners_m: np.ndarray, support: np.ndarray, contact_m: float = CONTACT_M
              ) -> tuple[float, int, int]:
    """Largest horizontal displacement of a sole corner on the ground within a support phase.

    What slides is the part of the sole on the ground: each corner counts from the first frame
    of the support phase in which it is down (``z <= contact_m``) for as long as it stays
    down, so neither a landing nor a sole turning on its toe edge (its centre and lifted heel
    move, its toe corners do not) is slip.

    Args:
        corners_m: (T, 2, 4, 3) float [left, right] sole corners [m].
        support: (T, 2) bool frames of each sole's support phases.
        contact_m: a corner this close to the ground is on it [m].

    Returns:
        (slip [m], its sole's index, its frame); (0.0, -1, -1) without any displacement.
    """
    down = corners_m[..., 2] <= contact_m  # (T, 2, 4)
    slip, side, frame = 0.0, -1, -1
    for k in range(2):
        for a, b in runs(support[:, k]):
            for c in range(4):
                for a2, b2 in runs(down[a:b, k, c]):
                    xy = corners_m[a + a2:a + b2, k, c, :2]
                    moved = np.linalg.norm(xy - xy[0], axis=1)
                    if moved.max() > slip:
                        slip, side = float(moved.max()), k
                        frame = a + a2 + int(np.argmax(moved))
    return slip, side, frame


def _contact_figures(robot, ref: Reference, q_sim: np.ndarray, ok: np.ndarray,
                     sole_force: np.ndarray, sole_moment: np.ndarray, samples: np.ndarray,
                     friction: float, surfaces: SupportSurfaces | None = None) -> dict:
    """What the ground contact did, per frame and sole (forces summed over the contact samples
    of each frame period):

    - ``zmp`` (T, 2): centre of pressure of all ground contacts [m] (NaN below 1 N);
      ``force`` (T,): mean vertical ground force [N];
    - ``sole_forces`` (T, 2, 3): mean force on each sole [N]; ``sole_cop`` (T, 2, 2) its centre
      of pressure [m] (NaN below 1 N);
    - ``friction_ratio``: largest tangential / (mu x normal) ratio of a sole carrying more
      than 5 % of the robot's weight;
    - ``cop_margin_mm``: smallest distance of a loaded sole's centre of pressure to the edge of
      its rectangle (negative outside) [mm];
    - ``slip_mm``: largest horizontal displacement of a sole corner on the ground within one
      planned support phase that does not slide or pivot, while it stays on the ground
      (:func:`sole_slip`; with ``surfaces``, on the surface under it), over the
      survived frames [mm].

    With a scene the centres of pressure are those of the soles' contacts with the floor and
    the props together (their horizontal coordinates).
    """
    n = np.maximum(samples, 1)[:, None, None]
    forces = sole_force / n
    with np.errstate(invalid="ignore", divide="ignore"):
        sole_cop = sole_moment / sole_force[..., 2:3]
        sole_cop[sole_force[..., 2] * (1 / n[..., 0]) < 1.0] = np.nan
        total = sole_force.sum(axis=1)
        zmp = sole_moment.sum(axis=1) / total[:, 2:3]
        zmp[(total[:, 2] / n[:, 0, 0] < 1.0) | ~ok] = np.nan
        force = np.where(samples > 0, total[:, 2] / n[:, 0, 0], np.nan)
    force[~ok] = np.nan
    sole_cop[~ok] = np.nan
    loaded = (forces[..., 2] > 0.05 * robot.mass * 9.81) & ok[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        fr = np.linalg.norm(forces[..., :2], axis=-1) / (friction * forces[..., 2])
    friction_ratio = float(fr[loaded].max()) if loaded.any() else float("nan")
    margin = float("nan")
    slip, slip_side, slip_s = 0.0, "", float("nan")
    if ok.any():
        # the simulated soles (the reference's pose after a fall, never used there)
        tracks = sole_tracks(robot, np.where(ok[:, None], q_sim, ref.q), ref.fps)
        centre_w = np.stack([tracks.centers[side] for side in SIDES], axis=1)  # (T, 2, 3)
        corners = np.stack([tracks.corners[side] for side in SIDES], axis=1)  # (T, 2, 4, 3)
        # the sole's own axes from its corners (front-left, front-right, back-right, back-left)
        x_axis = corners[..., 0, :2] - corners[..., 3, :2]
        y_axis = corners[..., 0, :2] - corners[..., 1, :2]
        x_axis /= np.linalg.norm(x_axis, axis=-1, keepdims=True)
        y_axis /= np.linalg.norm(y_axis, axis=-1, keepdims=True)
        rel = sole_cop - centre_w[..., :2]
        local = np.stack([np.sum(rel * x_axis, axis=-1), np.sum(rel * y_axis, axis=-1)], -1)
        half = np.array([robot.soles[s].half_extents for s in SIDES])
        edge = np.min(half[None] - np.abs(local), axis=-1)  # (T, 2), > 0 inside
        use = loaded & np.isfinite(edge)
        if use.any():
            margin = float(1e3 * edge[use].min())
        if surfaces is not None:  # heights above the surface under each corner
            corners = corners.copy()
            corners[..., 2] -= surfaces.heights(corners)
        slip, k, f = sole_slip(corners, ref.support & ~ref.moving & ok[:, None])
        if k >= 0:
            slip_side, slip_s = SIDES[k], float(f / ref.fps)
    return {"zmp": zmp, "force": force, "sole_forces": forces, "sole_cop": sole_cop,
            "friction_ratio": friction_ratio, "cop_margin_mm": margin, "slip_mm": 1e3 * slip,
            "slip_side": slip_side, "slip_s": slip_s}


def simulate_motion(robot, motion, *, config: PhysicsConfig | None = None,
                    scene=None) -> PhysicsResult:
    """Track a robot motion in DART and judge it.

    The motion's first frame is placed on the ground (base height shifted for all frames so its
    lowest point is ``ground.start_clearance_m`` above z = 0; with a scene, its lowest sole
    corner that far above the surface under it), held for ``timing.settle_s``, then tracked;
    the last frame is held for ``timing.extra_time_s``.

    Args:
        robot: an :class:`imesh.robot.Robot`.
        motion: a :class:`imesh.core.robot_motion.RobotMotion` of this robot.
        config: PhysicsConfig.
        scene: the motion's props (:class:`imesh.scene.Scene` in the robot's world, the
            ``.scene.npz`` beside a motion ``imesh retarget --scene`` wrote): boxes in the
            DART world, their tops surfaces the controller's soles stand on; None: the floor
            alone. Ignored for a fixed base.

    Returns:
        PhysicsResult (``.metrics()`` gives the DESIGN.md physics metrics, ``.summary()`` the
        rest).

    Raises:
        ImeshError: the motion is of another robot or has other joints.
        MissingDependencyError: dartpy missing (names the install command).
        PhysicsError: the DART model does not match; a prop is not a box.
    """
    config = config or PhysicsConfig()
    if motion.robot != robot.name or tuple(motion.joint_names) != tuple(robot.joint_names):
        raise ImeshError(f"motion of robot {motion.robot!r} with {len(motion.joint_names)} "
                         f"joints cannot be simulated on robot {robot.name!r} "
                         f"({robot.dof} joints): robot or joint names differ")
    t_setup = time.perf_counter()
    if config.fixed_base:
        scene = None
    surfaces = SupportSurfaces(scene, below_m=SURFACE_BELOW_M) if scene is not None else None
    ref = build_reference(robot, motion.q, motion.fps, clearance_m=config.ground.start_clearance_m,
                          place_on_ground=not config.fixed_base,
                          contact_modes=motion.contact_modes, surfaces=surfaces)
    base_pose = np.eye(4)
    base_pose[:3, :3] = Rotation.from_quat(ref.q[0, 3:7]).as_matrix()
    base_pose[:3, 3] = ref.q[0, :3]
    sim = DartRobot(robot, config, base_pose=base_pose, scene=scene)
    skel, world = sim.skeleton, sim.world
    n, nb, dt = sim.n_dofs, sim.base_dofs, config.timing.dt
    fps = ref.fps
    settle = int(round(config.timing.settle_s / dt))
    track = int(round((ref.duration_s + config.timing.extra_time_s) / dt))

    kind = config.control.controller
    controller: WbcTracker | KinematicTracker | JointTracker
    if kind == "wbc" and nb:
        controller = WbcTracker(sim, ref, config, surfaces)
    elif kind == "kinematic":
        controller = KinematicTracker(sim, ref, config)
    else:  # spd, pid (and a welded base, which has no balance to keep: joint tracking)
        tau_ff = (feedforward(sim, ref)[0] if config.control.feedforward
                  else np.zeros((ref.n_frames, n)))
        if kind == "wbc":
            config = _joint_tracking(config)
        controller = JointTracker(sim, ref, config, tau_ff, track)
    sim.set_state(ref.q[0])  # the first frame, at rest
    setup_s = time.perf_counter() - t_setup

    # --- recording -----------------------------------------------------------------------------
    T = ref.n_frames
    frame_step = np.rint(np.arange(T) / fps / dt).astype(np.int64)  # tracking step of frame i
    frame_of_step = np.minimum(np.rint(np.arange(track + 1) * dt * fps).astype(np.int64), T - 1)
    pos_rec = np.full((T, n), np.nan)
    tau_rec = np.full((T, n), np.nan)
    ratio_rec = np.full(T, np.nan)
    sole_force = np.zeros((T, 2, 3))  # per sole: sum of contact force vectors
    sole_moment = np.zeros((T, 2, 2))  # per sole: sum of fz * (x, y)
    link_force = np.zeros(T)  # vertical force on the robot's other links (hands, knees)
    samples = np.zeros(T)
    sample_every = config.ground.contact_sample_every
    sides = _contact_sides(sim)
    links = sim.link_shape_names

    get_pos, get_vel = skel.getPositions, skel.getVelocities
    step = world.step
    collision_result = world.getLastCollisionResult
    fell, reason = False, ""
    fall_step = None
    saturated = 0
    ratio_max = 0.0
    ctrl_s = 0.0
    base_z_ref = ref.q[:, 2]
    lost = _LostReference(robot, ref, config.fall.lost_m) if nb else None
    t0 = time.perf_counter()

    # the floor under a sole the plan slides or pivots is as slippery as the plan assumed
    friction = np.where(ref.moving, config.ground.slide_friction, config.ground.friction)
    sole_friction = np.full(2, config.ground.friction)
    total = settle + track + 1
    next_frame = 0  # the next motion frame to record
    for k in range(total):
        tracking = k >= settle
        i = k - settle if tracking else 0  # tracking step index
        c0 = time.perf_counter()
        pos = get_pos()
        vel = get_vel()
        if not np.all(np.isfinite(pos)) or not np.all(np.isfinite(vel)):
            fell, reason, fall_step = True, "simulation diverged (non-finite state)", i
            break
        if nb and (abs(vel[:6]).max() > DIVERGED_SPEED or abs(pos[3:6]).max() > DIVERGED_M):
            # stop before ODE's collision space asserts (it aborts the process) on bodies
            # thrown kilometres away
            fell, fall_step = True, i
            reason = (f"simulation diverged (base speed {abs(vel[:6]).max():.0f}) at "
                      f"t = {i * dt:.2f} s")
            break
        if nb and tracking:
            mu = friction[frame_of_step[i]]
            for side in np.flatnonzero(mu != sole_friction):
                sim.set_sole_friction(SIDES[side], mu[side])
                sole_friction[side] = mu[side]
        tau, ratio = controller(k, i, tracking, pos, vel)
        if ratio != ratio:  # NaN: a non-finite state propagates into every torque
            fell, reason, fall_step = True, "simulation diverged (non-finite torque)", i
            break
        ctrl_s += time.perf_counter() - c0

        if tracking:
            if ratio > 1.0:
                saturated += 1
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
                if nb and not fell:
                    low = pos[5] < base_z_ref[f] - config.fall.height_m
                    tilt = _tilt(pos[:3], ref.q[f, 3:7])
                    off = lost(sim.q_from_positions(pos), f) if lost is not None else ""
                    if low or tilt > config.fall.tilt_rad or off:
                        fell, fall_step = True, i
                        reason = (f"base {base_z_ref[f] - pos[5]:.2f} m below the reference"
                                  if low else f"base tilted {np.degrees(tilt):.0f} deg from the "
                                  "reference" if tilt > config.fall.tilt_rad else off
                                  ) + f" at t = {i * dt:.2f} s"
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
                name1 = c.collisionObject1.getShapeFrame().getName()
                name2 = c.collisionObject2.getShapeFrame().getName()
                s = sides.get(name1, sides.get(name2))
                if s is None:
                    if name1 in links or name2 in links:
                        link_force[f] += abs(float(c.force[2]))
                    continue
                # the force on the sole, whichever object DART lists first (fz > 0)
                force = np.asarray(c.force)
                if force[2] < 0:
                    force = -force
                fz = force[2]
                sole_force[f, s] += force
                sole_moment[f, s] += fz * np.asarray(c.point)[:2]
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
    torques[ok] = tau_rec[ok][:, sim.joint_dofs]
    contact = _contact_figures(robot, ref, q_sim, ok, sole_force, sole_moment, samples,
                               config.ground.friction, surfaces)
    if ok.any():
        lastok = int(np.flatnonzero(ok)[-1])
        drift = float(np.linalg.norm(q_sim[lastok, :3] - ref.q[lastok, :3]))
        height_drift = float(np.nanmax(np.abs(q_sim[ok, 2] - ref.q[ok, 2])))
    else:
        drift = height_drift = float("nan")
    if config.fixed_base:
        drift = height_drift = 0.0
    kp_rms, kp_max, kp_worst, kp_worst_s = _keypoint_errors(robot, ref, q_sim, ok)
    tracked_steps = max(0, steps_done - settle)
    sim_time = steps_done * dt
    relaxed = (controller.controller.relaxed_steps / max(tracked_steps // controller.every, 1)
               if isinstance(controller, WbcTracker) else 0.0)
    result = PhysicsResult(
        robot=robot.name, joint_names=tuple(robot.joint_names), fps=fps, fell=fell,
        fall_reason=reason, survived_s=float(survived),
        duration_s=float(ref.duration_s + config.timing.extra_time_s),
        tracking_rms_rad=tracking_rms, torque_ratio_max=float(ratio_max),
        saturation_fraction=saturated / max(tracked_steps, 1), base_drift_m=drift,
        base_height_drift_m=height_drift, keypoint_rms_mm=kp_rms, keypoint_max_mm=kp_max,
        keypoint_worst=kp_worst, keypoint_worst_s=kp_worst_s, slip_mm=contact["slip_mm"],
        slip_side=contact["slip_side"], slip_s=contact["slip_s"],
        friction_ratio=contact["friction_ratio"],
        cop_margin_mm=contact["cop_margin_mm"], relaxed_fraction=float(relaxed),
        real_time_factor=sim_time / max(wall, 1e-9),
        wall_s=wall, controller_us_per_step=1e6 * ctrl_s / max(steps_done, 1),
        physics_us_per_step=1e6 * (wall - ctrl_s) / max(steps_done, 1),
        times_s=np.arange(T) / fps, q=q_sim, q_reference=ref.q, joint_error_rad=err,
        torques_nm=torques, torque_ratio=ratio_rec, zmp_contact_m=contact["zmp"],
        zmp_planned_m=ref.zmp_m, contact_force_n=contact["force"],
        sole_forces_n=contact["sole_forces"], sole_cop_m=contact["sole_cop"],
        link_contact_force_n=np.where(ok, link_force / np.maximum(samples, 1), np.nan),
        props=tuple(scene.names) if scene is not None else (),
        support=ref.support, ground_offset_m=ref.ground_offset_m, config=config)
    log.info("DART %s (%s, %d frames at %g fps): %s, survived %.2f of %.2f s, tracking RMS "
             "%.4f rad, key points %.1f mm RMS, torque ratio %.2f, real-time factor %.2f "
             "(setup %.2f s)", robot.name, kind, T, fps,
             f"FELL ({reason})" if fell else "did not fall", survived, ref.duration_s,
             tracking_rms, kp_rms, ratio_max, result.real_time_factor, setup_s)
    return result
