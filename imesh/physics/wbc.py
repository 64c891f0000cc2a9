"""A whole-body QP controller: what a humanoid runs to track a reference while keeping balance.

Per control step, at the measured state ``(q, v)`` (pinocchio's model of the robot, not the
simulator's), one dense QP chooses the generalized accelerations ``a`` (nv) and a contact wrench
``w_c = (f_c, m_c)`` (world axes, at the sole centre) for every sole in contact:

    min_x  sum_i W_i ||A_i x - b_i||^2 + eps ||w||^2          x = (a, w_1, ..., w_k)
    s.t.   M_b a + h_b = sum_c J_{c,b}^T w_c                  (floating-base rows of the
                                                               equation of motion)
           J_c a + Jdot_c v = -K_c J_c v                      (contact soles do not move)
           C_c R_c^T w_c <= 0                                  (contact wrench cone, below)
           |M_j a + h_j - sum_c J_{c,j}^T w_c| <= tau_max     (joint torques within the limits)

``h`` is pinocchio's ``C v + g`` plus the joints' viscous damping ``B qd`` of the simulated
robot (the URDF's ``<dynamics damping>``, which DART applies and pinocchio leaves out); DART
integrates that damping implicitly over its step ``dt`` (the damping force of a step is ``B (qd
+ a dt)``), so the joint rows use ``M_j + dt B`` for the mass matrix.
The torques ``tau = M_j a + h_j - sum_c J_{c,j}^T w_c`` are applied as they are (never clamped
afterwards: the limits are constraints). Tasks (``A_i x = b_i``, PD feedback on the reference of
:class:`imesh.physics.track.ReferenceTrack`):

- centre of mass, horizontal: divergent component of motion (capture point) feedback
  (Englsberger et al. 2015): with ``omega = sqrt(g / z_c)`` and ``xi = c + cdot / omega``,
  the commanded ZMP ``p = p_ref + (1 + k_xi / omega) (xi - xi_ref)`` and
  ``cddot = omega^2 (c - p)``, i.e. ``cddot_ref - k_xi omega e_c - (omega + k_xi) e_cdot``;
  the wrench cone then keeps the realised ZMP inside the soles. Vertical: PD.
- centroidal angular momentum about the CoM: ``Ldot = Ldot_ref + k_L (L_ref - L)`` (the
  planned multibody ZMP includes ``Ldot``: a small robot's centre of pressure moves 30 mm per
  10 N m of it);
- base orientation (angular acceleration with PD on ``log(R_ref R^T)``);
- swing soles: 6-D pose (PD on position and orientation, the reference's acceleration as
  feed-forward);
- joints: ``qdd_ref + kp (q_ref - q) + kd (qd_ref - qd)`` (posture, weakest).

Joint limits bound the accelerations (Del Prete 2018's discrete-time form, with a horizon
``h = WbcConfig.limit_horizon_s``): ``2 (q_min - q - qd h) / h^2 <= qdd <= 2 (q_max - q - qd h) /
h^2`` and ``(-qd_max - qd) / h <= qdd <= (qd_max - qd) / h``.

The contact wrench cone of a rectangular sole of half sizes X, Y with friction coefficient mu
(Caron, Pham & Nakamura 2015, eq. 11-15), in the sole frame (``f = (fx, fy, fz)``,
``m = (mx, my, mz)`` about the sole centre): ``fz >= f_min``, ``|fx|, |fy| <= mu fz``,
``|mx| <= Y fz``, ``|my| <= X fz`` (centre of pressure inside the rectangle), and
``-mu (X + Y) fz + |Y fx - mu mx| + |X fy - mu my| <= mz
<= mu (X + Y) fz - |Y fx + mu mx| - |X fy + mu my|`` (yaw). X and Y are shrunk by
``WbcConfig.cop_margin`` so that the centre of pressure stays off the edge.

A sole that the plan lifts within ``WbcConfig.toe_roll_frames`` frames, at the end of a double
support, rolls over its toe edge: its contact rows become the toe edge's linear acceleration
(3) and the angular acceleration about the sole's normal and forward axes (2); its pitch is
free, so the heel rises as its leg's posture bends the knee with the reference's. Standing on
its toe edge the sole is a line contact: its wrench stays in the cone of the front strip ``x >=
a X`` of the sole (``a = WbcConfig.toe_cop_fraction``), ``WbcConfig.toe_lateral`` of the half
width wide, in the ground's frame (z up: the friction the floor holds), about the strip's
centre (both toe corners carry it: a centre of pressure near one corner stood the sole on
that corner alone in DART, which holds no moment about the vertical, and the heel swung 7 mm
sideways). A human foot rolls over its toes while the other foot takes the weight; a sole held
flat to the last frame made the QP unload it early (1-6 N in the last 40 ms on the G1 walk) and
lose the capture point at every lift-off; a roll whose pitch followed the reference sole's
(flat until it lifts) straightened the knee in the push-off while the reference bent it, and
the swing knee lagged 0.3-0.6 rad behind after the lift-off (key points 80-112 mm off on the
JVRC-1 veer and the HRP-4C walk, 27 and 46 mm with the free pitch).

A sole is in contact when the reference plans it in support and the simulated sole is within
``WbcConfig.contact_height_m`` of the ground (of the surface under it: the floor or, in a
scene, a prop's top, :class:`imesh.scene.surfaces.SupportSurfaces`; "flat on the ground" below
is flat on that surface); a planned support whose sole is still in the air
is tracked as a swing sole aimed ``WbcConfig.landing_depth_m`` below its reference (it lands:
a PD aimed at the ground slows down as it nears it, and the reference drops its last 20 mm in
one frame, so the sole hovered a frame or two above the ground while the plan loaded it), and
a sole that leaves its support early is tracked as a swing sole too. When no
planned sole is down (the landing is late), the soles that are down stay in contact.

A hand or knee the reference rests on a prop's top (:mod:`imesh.physics.points`) is a point
contact while its simulated point is within ``contact_height_m`` of that top: a force ``f``
(3, world axes) in the friction pyramid of the top's normal (z), ``|f_x|, |f_y| <= mu f_z``,
``f_z >= 0``, its point held (``J_p a + Jdot_p v = -K_c J_p v``) and ``J_p^T f`` in the equation
of motion beside the soles' wrenches. Without them the controller asked the soles for the
wrench of a robot leaning on its hand, beyond the soles' edges.

A contact sole the plan slides or pivots (``TrackPoint.moving``) keeps only its normal
acceleration, roll and pitch as contact rows (flat on the ground); its tangential acceleration
and yaw follow the reference as a task (weighted as a swing sole). Sliding (its centre faster
than ``WbcConfig.slip_speed_m_s`` over the ground) its friction is Coulomb's kinetic force
against the measured slide ``u``: ``f_t = -mu_s f_n u``, two equality rows on its wrench, with
``mu_s`` the floor's friction under slides (``GroundConfig.slide_friction``) and the cone of
the whole ``mu_s``; slower, static friction holds it within the cone of
``friction_fraction mu_s``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..balance.cwc import sole_wrench_cone
from ..contacts.phases import SIDES
from ..core.skew import skew
from .config import WbcConfig
from .so3 import log_so3, quat_xyzw_to_matrix
from .track import ReferenceTrack, TrackPoint

if TYPE_CHECKING:
    from ..scene.surfaces import SupportSurfaces
    from .points import PointContacts

log = logging.getLogger(__name__)

GRAVITY = 9.81
SIDE_IDX = range(len(SIDES))


def _rotation_error(R_ref: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(3,) world-axis rotation vector taking ``R`` to ``R_ref`` (``log(R_ref R^T)``)."""
    return log_so3(R_ref @ R.T)


def contact_frame_rotation(normal: np.ndarray) -> np.ndarray:
    """(3, 3) rotation of a sole's contact frame in its foot frame: z the sole normal, x the foot
    frame's x made orthogonal to it."""
    n = np.asarray(normal, dtype=float)
    n = n / np.linalg.norm(n)
    x = np.array([1.0, 0.0, 0.0]) - n[0] * n
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(n, x), n])


@dataclass(frozen=True)
class ControlStep:
    """What one control step decided.

    Attributes:
        tau: (n,) float joint torques in ``robot.joint_names`` order [Nm].
        contacts: (2,) bool [left, right] soles treated as in contact.
        wrenches: (2, 6) float [left, right] contact wrenches the QP chose (world axes, at the
            sole centres; 0 off contact) [N, Nm].
        relaxed: the QP with its contact rows as constraints was infeasible within the torque
            limits and was solved with them as the heaviest task (the step is counted).
        sliding: (2,) bool [left, right] contact soles whose friction was Coulomb's kinetic
            force against their slide (planned slides and pivots that move).
        point_forces: (E, 3) float force of each hand / knee point contact
            (:class:`~imesh.physics.points.PointContacts` order; 0 off contact) [N].
    """

    tau: np.ndarray
    contacts: np.ndarray
    wrenches: np.ndarray
    relaxed: bool
    sliding: np.ndarray
    point_forces: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))


class WholeBodyController:
    """The whole-body QP controller of the DART check (see the module docstring).

    Args:
        robot: the robot (pinocchio model, soles, torque limits).
        track: the reference as functions of time.
        config: gains, weights, margins.
        friction: the ground's friction coefficient (the controller assumes
            ``config.friction_fraction`` of it).
        joint_damping: (n,) float viscous damping of the joints [N m s/rad] (the simulator's,
            from the URDF), added to the joint rows of the equation of motion; None: 0.
        time_step_s: the simulator's time step [s], over which it integrates the damping
            implicitly (below); None: the damping as an explicit force only.
        slide_friction: the friction coefficient under a sole the plan slides or pivots
            (``GroundConfig.slide_friction``); None: ``friction``.
        surfaces: the surfaces the soles stand on (a scene's prop tops); None: the floor.
        points: where the reference rests hands and knees on prop tops (point contacts);
            None: the soles alone.
    """

    def __init__(self, robot, track: ReferenceTrack, config: WbcConfig, friction: float,
                 joint_damping: np.ndarray | None = None, time_step_s: float | None = None,
                 slide_friction: float | None = None, surfaces: SupportSurfaces | None = None,
                 points: PointContacts | None = None):
        from .qp import dense_qp  # noqa: PLC0415  (the solver's import is lazy)

        self._solve = dense_qp
        self.robot = robot
        self.track = track
        self.config = config
        self.nv = robot.nv
        self.n_joints = robot.nv - 6
        self.frames = [robot.soles[s].frame for s in SIDES]
        self.centres = np.array([robot.soles[s].center for s in SIDES])
        self.contact_R = np.array([contact_frame_rotation(robot.soles[s].normal)
                                   for s in SIDES])
        mu = config.friction_fraction * friction
        keep = 1.0 - config.cop_margin
        self.cones = [sole_wrench_cone(keep * robot.soles[s].half_extents[0],
                                       keep * robot.soles[s].half_extents[1], mu)
                      for s in SIDES]
        self.half_extents = np.array([robot.soles[s].half_extents for s in SIDES])
        front = config.toe_cop_fraction
        self.strip_cones = [sole_wrench_cone(0.5 * (1.0 - front) * X, config.toe_lateral * Y, mu)
                            for X, Y in self.half_extents]
        self.strip_offsets = 0.5 * (1.0 + front) * self.half_extents[:, 0]
        # a moving sole: held (static) within the assumed fraction of the slide's friction,
        # sliding on the cone of the whole of it (its tangential force is then fixed, below)
        self.mu_slide = friction if slide_friction is None else float(slide_friction)
        self.held_cones = [sole_wrench_cone(keep * X, keep * Y,
                                            config.friction_fraction * self.mu_slide)
                           for X, Y in self.half_extents]
        self.slide_cones = [sole_wrench_cone(keep * X, keep * Y, self.mu_slide)
                            for X, Y in self.half_extents]
        self.tau_max = robot.effort_max * config.torque_fraction
        self.q_lower, self.q_upper = robot.q_lower, robot.q_upper
        self.v_max = robot.v_max
        legs = np.unique(np.concatenate([robot.supporting_joints(f) for f in self.frames]))
        self.posture_weights = np.full(self.n_joints, config.weights.upper_body)
        self.posture_weights[legs] = config.weights.joints
        self.omega = np.sqrt(GRAVITY / max(track.com_height_m, 0.1))
        self.damping = (np.zeros(self.n_joints) if joint_damping is None
                        else np.asarray(joint_damping, dtype=float))
        # DART integrates the joints' damping implicitly (the step's damping force is
        # ``B qd_next = B (qd + a dt)``): the realised acceleration of a torque is that of a
        # mass matrix ``M + dt B``. A light joint with a strong damping (iCub's wrists:
        # ``dt B / M_jj`` = 0.7-1.9) reached a third of the commanded acceleration with ``M``
        # alone, and the controller lost the arms and the torso in the settle.
        self._implicit = (time_step_s or 0.0) * self.damping
        self._accel_diag = np.diag_indices(self.nv)
        self._wrench_weights = np.repeat([config.weights.force, config.weights.moment], 3)
        self._joint_diag = (np.arange(6, self.nv), np.arange(6, self.nv))
        self._limit_rows = np.hstack([np.zeros((self.n_joints, 6)), np.eye(self.n_joints)])
        self.relaxed_steps = 0
        self.surfaces = surfaces if surfaces is not None and not surfaces.flat else None
        # (2,) height of the surface under each sole at the current step [m]
        self._surface_z = np.zeros(2)
        self.points = points if points is not None and points.any and \
            self.surfaces is not None else None
        self._n_points = 0 if points is None else len(points.effectors)
        # friction pyramid of a point force in world axes (normal z): |fx|, |fy| <= mu fz, fz >= 0
        self._pyramid = np.array([[1.0, 0.0, -mu], [-1.0, 0.0, -mu], [0.0, 1.0, -mu],
                                  [0.0, -1.0, -mu], [0.0, 0.0, -1.0]])

    # ------------------------------------------------------------------------------------------

    def contacts(self, point: TrackPoint, sole_heights: np.ndarray) -> np.ndarray:
        """(2,) bool soles in contact: planned in support and down on the ground; when no
        planned sole is down yet (a late landing), the soles that are down keep carrying the
        robot instead of leaving it in the air."""
        down = sole_heights <= self.config.contact_height_m
        planned = point.support & down
        return planned if planned.any() else down

    def contact_frames(self, poses: np.ndarray) -> np.ndarray:
        """(2, 3, 3) [left, right] contact frames in the world (z the sole normal) from the
        sole centres' poses (2, 4, 4)."""
        return poses[:, :3, :3] @ self.contact_R

    def sole_heights(self, poses: np.ndarray, frames: np.ndarray) -> np.ndarray:
        """(2,) float [left, right] lowest sole corner above the surface the sole is over [m],
        from the sole centres' poses (2, 4, 4) and their :meth:`contact_frames`; the
        surfaces' heights are kept for the contact rows of this step. The surface is the
        highest under the sole's centre or a corner: a sole landing on a box's edge with its
        centre beyond it stands on the box (the G1 on the holosoma climb seq_0, its right sole
        on box2 at robot frames 41-42)."""
        if self.surfaces is not None:
            X, Y = self.half_extents[:, 0, None], self.half_extents[:, 1, None]
            sx, sy = np.array([1.0, 1.0, -1.0, -1.0]), np.array([1.0, -1.0, -1.0, 1.0])
            corners = (poses[:, None, :3, 3] + (sx * X)[..., None] * frames[:, None, :, 0]
                       + (sy * Y)[..., None] * frames[:, None, :, 1])  # (2, 4, 3)
            points = np.concatenate([poses[:, None, :3, 3], corners], axis=1)
            self._surface_z = self.surfaces.heights(points).max(axis=1)
        return (poses[:, 2, 3] - self._surface_z
                - np.abs(frames[:, 2, 0]) * self.half_extents[:, 0]
                - np.abs(frames[:, 2, 1]) * self.half_extents[:, 1])

    def _contact_rhs(self, dyn, s: int) -> np.ndarray:
        """(6,) right-hand side of sole ``s``'s contact rows ``J a = b``: its twist damped and
        its pose driven back flat on the ground (:meth:`_flat_error`), less the drift."""
        g = self.config.gains
        return (-dyn.drifts[s] - g.contact_kd * dyn.twists[s]
                + g.contact_kp * self._flat_error(dyn.poses[s], s))

    def _sole_pd(self, dyn, point: TrackPoint, s: int, target_m: np.ndarray) -> np.ndarray:
        """(6,) acceleration [linear; angular] that takes sole ``s`` to ``target_m`` (its
        centre) and its reference orientation: PD on the pose and twist, the reference's
        acceleration as feed-forward (world axes)."""
        g = self.config.gains
        pose, twist = dyn.poses[s], dyn.twists[s]
        lin = (point.sole_acc[s] + g.sole_kp * (target_m - pose[:3, 3])
               + g.sole_kd * (point.sole_vel[s] - twist[:3]))
        ang = (point.sole_alpha[s]
               + g.sole_kp * _rotation_error(point.sole_rotations[s], pose[:3, :3])
               + g.sole_kd * (point.sole_omega[s] - twist[3:]))
        return np.concatenate([lin, ang])

    def _flat_error(self, pose: np.ndarray, s: int) -> np.ndarray:
        """(6,) how far a contact sole is from lying flat on the ground: its centre's height
        (to the surface under it, z = 0 on the floor) and its tilt (roll and pitch, to the
        same yaw level), world axes. A sole tipped onto an edge in the simulator is driven
        back flat through the contact rows."""
        R = pose[:3, :3] @ self.contact_R[s]
        yaw = np.arctan2(R[1, 0], R[0, 0])
        c, si = np.cos(yaw), np.sin(yaw)
        level = np.array([[c, -si, 0.0], [si, c, 0.0], [0.0, 0.0, 1.0]])
        err = np.zeros(6)
        err[2] = self._surface_z[s] - pose[2, 3]
        err[3:] = log_so3(level @ R.T)
        err[5] = 0.0
        return err

    def rolling(self, t: float) -> np.ndarray:
        """(2,) bool soles that roll over their toes at time ``t``: planned in support now,
        in a double support, and lifted by the plan within ``toe_roll_frames`` frames."""
        n = self.config.toe_roll_frames
        support = self.track.ref.support
        f = self.track.frame(t)
        if n == 0 or support[f].sum() != 2:
            return np.zeros(2, dtype=bool)
        ahead = np.asarray(support[f + 1:f + n + 1], dtype=bool)
        if not len(ahead):
            return np.zeros(2, dtype=bool)
        return np.logical_not(ahead.all(axis=0))

    def _toe_cone(self, s: int, Rc: np.ndarray) -> np.ndarray:
        """(16, 6) the wrench cone of sole ``s`` standing on its toe edge, for its wrench at the
        sole centre in world axes (``Rc``: its contact frame in the world): the cone of the
        front strip ``x >= a X`` (``a = toe_cop_fraction``), ``toe_lateral`` of the half width
        wide, about the strip's centre ``d`` ahead of the sole centre (``m_strip = m - d x
        f``), in the ground's frame (z up, x the sole's heading). The strip stands on the
        ground, whose normal is the world's z, not the tilted sole's: the tilted frame's
        pyramid let the toe push sideways at up to 1.06 of its normal force where the floor
        holds 1.0 (salsa A on G1 at a lift-off), and the toes slipped at the push-offs of the
        walks (G1 walk 3.6 mm, veer 4.7; 1.6 and 1.8 in the ground's frame)."""
        up = np.array([0.0, 0.0, 1.0])
        x = Rc[:, 0] - Rc[2, 0] * up
        x /= np.linalg.norm(x)
        L = np.column_stack([x, np.cross(up, x), up])
        d = Rc[:, 0] * self.strip_offsets[s]
        transform = np.zeros((6, 6))
        transform[:3, :3] = transform[3:, 3:] = L.T
        transform[3:, :3] = -L.T @ skew(d)
        return self.strip_cones[s] @ transform

    def _toe_rows(self, dyn, s: int) -> tuple[np.ndarray, np.ndarray]:
        """(5, nv) rows and (5,) right-hand side of a sole rolling over its toe edge: the
        toe-edge centre's linear acceleration 0 (with damping) and the angular acceleration
        about the sole's forward and normal axes 0; its pitch is free (the heel rises as the
        leg's posture bends the knee)."""
        g = self.config.gains
        Rc = dyn.poses[s, :3, :3] @ self.contact_R[s]  # contact frame in the world
        r = Rc[:, 0] * self.half_extents[s, 0]  # sole centre -> toe edge
        J_lin, J_ang = dyn.jacobians[s, :3], dyn.jacobians[s, 3:]
        w = dyn.twists[s, 3:]
        # classical acceleration of the toe point: a + alpha x r + omega x (omega x r)
        drift = dyn.drifts[s, :3] + np.cross(dyn.drifts[s, 3:], r) + w * (w @ r) - r * (w @ w)
        v_toe = dyn.twists[s, :3] + np.cross(w, r)
        fixed = np.stack([Rc[:, 0], Rc[:, 2]])
        # the toe's alpha x r, column by column of the angular Jacobian
        rows = np.vstack([J_lin + np.cross(J_ang.T, r).T, fixed @ J_ang])
        rhs = np.concatenate([-drift - g.contact_kd * v_toe,
                              -fixed @ dyn.drifts[s, 3:] - g.contact_kd * (fixed @ w)])
        return rows, rhs

    def slip_direction(self, dyn, s: int, frame: np.ndarray) -> np.ndarray | None:
        """(3,) unit world direction in which a sole slides over the ground (its centre's
        velocity in the contact plane), or None while it moves slower than
        ``slip_speed_m_s`` (static friction holds it; it starts to slide when the leg pushes
        it harder than the cone allows, as in the simulator). Taking the reference's
        direction before the sole moves put the force on the cone's boundary while the sole
        stood still, and the CoM lost the plan sooner (salsa A on G1 read at 60 fps exactly,
        ``slide_friction`` 0.3: at 5.60 s instead of 6.30). ``frame``: its contact frame."""
        n = frame[:, 2]
        vel = dyn.twists[s, :3]
        tangential = vel - (vel @ n) * n
        speed = float(np.linalg.norm(tangential))
        return tangential / speed if speed > self.config.slip_speed_m_s else None

    def _slide_rows(self, dyn, point: TrackPoint, s: int, frame: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """A sole the plan slides or pivots: (3, nv) rows and (3,) right-hand side that keep
        it on the ground and flat (the contact rows' normal acceleration, roll and pitch), and
        (3, nv) rows and (3,) targets of the task that moves it over the ground with its
        reference (tangential acceleration and yaw, :meth:`_sole_pd`). ``frame``: its contact
        frame (3, 3) in the world."""
        t1, t2, n = frame.T
        held, moved = np.zeros((2, 3, 6))
        held[0, :3], held[1, 3:], held[2, 3:] = n, t1, t2  # normal (linear), roll, pitch
        moved[0, :3], moved[1, :3], moved[2, 3:] = t1, t2, n  # tangential (linear), yaw
        J = dyn.jacobians[s]
        task = self._sole_pd(dyn, point, s, point.sole_positions[s]) - dyn.drifts[s]
        return held @ J, held @ self._contact_rhs(dyn, s), moved @ J, moved @ task

    def step(self, t: float, q: np.ndarray, v: np.ndarray) -> ControlStep:
        """Torques for the state (q, v) at reference time ``t``.

        Args:
            t: reference time [s] (before 0: hold the first frame; after the end: the last).
            q: (nq,) float measured configuration; v: (nv,) float velocity (pinocchio).
        """
        cfg = self.config
        nv, nj = self.nv, self.n_joints
        ref = self.track.at(t)
        f = self.track.frame(t)
        planned = self._planned_points(f)
        if planned:
            pts = self.points
            assert pts is not None  # planned points come from it
            names = [pts.frames[e, f] for e in planned]
            local = np.array([pts.local_m[e, f] for e in planned])
            dyn = self.robot.dynamics(q, v, self.frames + names,
                                      np.vstack([self.centres, local]))
        else:
            dyn = self.robot.dynamics(q, v, self.frames, self.centres)
        frames = self.contact_frames(dyn.poses[:2])
        contact = self.contacts(ref, self.sole_heights(dyn.poses[:2], frames))
        points = self._touching(dyn, planned, f)  # (p,) rows of dyn in contact
        moving = ref.moving & contact
        rolling = self.rolling(t) & contact & ~moving
        slip = [self.slip_direction(dyn, s, frames[s]) if moving[s] else None
                for s in SIDE_IDX]
        sliding = np.array([d is not None for d in slip])
        active = np.flatnonzero(contact)
        k = len(active)
        n_p = len(points)
        n = nv + 6 * k + 3 * n_p

        # --- tasks: rows J a = b with weights, summed into the Hessian's acceleration block
        # (no task weighs the wrenches): H_aa = sum_i W_i J_i^T J_i, c_a = -sum_i W_i J_i^T b_i
        H = np.zeros((n, n))
        c = np.zeros(n)
        H_aa, c_a = H[:nv, :nv], c[:nv]  # views

        def task(J: np.ndarray, b: np.ndarray, weight: float) -> None:
            WJt = weight * J.T
            H_aa[...] += WJt @ J
            c_a[...] -= WJt @ b

        g = cfg.gains
        # CoM: capture-point feedback horizontally, PD vertically
        e_c = ref.com - dyn.com_m
        e_cd = ref.com_vel - dyn.com_velocity
        om, k_xi = self.omega, g.dcm
        cdd = ref.com_acc.copy()
        cdd[:2] += k_xi * om * e_c[:2] + (om + k_xi) * e_cd[:2]
        cdd[2] += g.com_z_kp * e_c[2] + g.com_z_kd * e_cd[2]
        task(dyn.com_jacobian, cdd - dyn.com_drift, cfg.weights.com)

        # centroidal angular momentum: the planned ZMP has Ldot in it (p = c - (z cdd + Ldot^
        # / m) / g), so its rate is tracked, scaled to the CoM's units (/ m z: a ZMP shift)
        scale = 1.0 / (self.robot.mass * self.track.com_height_m)
        L = dyn.centroidal_map[3:] @ v
        Ld = ref.momentum_rate + g.momentum_kp * (ref.momentum - L)
        task(dyn.centroidal_map[3:] * scale, (Ld - dyn.centroidal_drift[3:]) * scale,
             cfg.weights.momentum)

        # base orientation (the free flyer's angular velocity in the world: R v[3:6]); its
        # Jacobian is R on the base's angular columns
        R = quat_xyzw_to_matrix(q[3:7])
        w_base = R @ v[3:6]
        alpha = (ref.base_alpha + g.base_kp * _rotation_error(ref.base_rotation, R)
                 + g.base_kd * (ref.base_omega - w_base))
        H_aa[3:6, 3:6] += cfg.weights.base * (R.T @ R)
        c_a[3:6] -= cfg.weights.base * (R.T @ alpha)

        # swing soles
        for s in np.flatnonzero(~contact):
            target = ref.sole_positions[s].copy()
            if ref.support[s]:  # a late landing: aimed at the ground, the PD would approach
                # it ever more slowly and hover at the contact height
                target[2] -= cfg.landing_depth_m
            task(dyn.jacobians[s], self._sole_pd(dyn, ref, int(s), target) - dyn.drifts[s],
                 cfg.weights.swing)

        # moving soles: over the ground with their reference (the flat rows are constraints)
        slide_rows = {}
        for s in np.flatnonzero(moving):
            rows, rhs, task_rows, task_rhs = self._slide_rows(dyn, ref, int(s), frames[s])
            slide_rows[s] = rows, rhs
            task(task_rows, task_rhs, cfg.weights.swing)

        # joints (posture, an identity Jacobian on the joint columns)
        qdd = (ref.qdd_joints + g.joint_kp * (ref.q_joints - q[7:])
               + g.joint_kd * (ref.qd_joints - v[6:]))
        H[self._joint_diag] += self.posture_weights
        c[6:nv] -= self.posture_weights * qdd
        H[self._accel_diag] += cfg.weights.acceleration
        if k:
            idx = np.arange(nv, nv + 6 * k)
            H[idx, idx] += np.tile(self._wrench_weights, k)
        if n_p:
            idx = np.arange(nv + 6 * k, n)
            H[idx, idx] += cfg.weights.force

        # --- equalities: floating-base dynamics, contacts -------------------------------------
        M, h = dyn.mass_matrix, dyn.bias.copy()
        M[self._joint_diag] += self._implicit
        h[6:] += self.damping * v[6:]  # the joints' viscous damping, as the simulator has it
        # generalized torque rows of the contact wrenches and point forces: J_c^T w_c, J_p^T f
        Jt = np.zeros((nv, 6 * k + 3 * n_p))
        E_rows, e_rows = [M[:6]], [-h[:6]]
        for j, s in enumerate(active):
            Jt[:, 6 * j:6 * j + 6] = dyn.jacobians[s].T
            if rolling[s]:
                rows, rhs = self._toe_rows(dyn, int(s))
            elif moving[s]:
                rows, rhs = slide_rows[s]
            else:
                rows, rhs = dyn.jacobians[s], self._contact_rhs(dyn, int(s))
            E_rows.append(rows)
            e_rows.append(rhs)
        for i, row in enumerate(points):  # point contacts: held where they touch
            J = dyn.jacobians[row, :3]
            Jt[:, 6 * k + 3 * i:6 * k + 3 * i + 3] = J.T
            E_rows.append(J)
            e_rows.append(-dyn.drifts[row, :3] - g.contact_kd * dyn.twists[row, :3])
        E = np.hstack([np.vstack(E_rows), np.zeros((sum(len(r) for r in E_rows), n - nv))])
        e = np.concatenate(e_rows)
        E[:6, nv:] = -Jt[:6]
        # a sliding sole's friction is Coulomb's kinetic force, against its slide ``u``:
        # ``f_t = -mu fz u`` (none across it), the wrench cone's boundary
        kinetic = []
        n_rows = len(E)  # dynamics and contact motion rows; the kinetic rows follow
        for j, s in enumerate(active):
            u = slip[s]
            if u is not None:
                normal = frames[s][:, 2]
                rows = np.zeros((2, n))
                rows[0, nv + 6 * j:nv + 6 * j + 3] = np.cross(normal, u)
                rows[1, nv + 6 * j:nv + 6 * j + 3] = u + self.mu_slide * normal
                kinetic.append(rows)
        if kinetic:
            E = np.vstack([E, *kinetic])
            e = np.concatenate([e, np.zeros(2 * len(kinetic))])

        # --- inequalities: wrench cones, torque limits ----------------------------------------
        G_rows, l_rows, u_rows = [], [], []
        for j, s in enumerate(active):
            Rc = frames[s]
            block = np.zeros((6, 6))
            block[:3, :3] = Rc.T
            block[3:, 3:] = Rc.T
            C = self.cones[s] @ block
            if rolling[s]:  # the heel is up: a line contact on the toe edge
                C = self._toe_cone(int(s), Rc)
            elif moving[s]:  # on the slide's floor: sliding, or held by static friction
                C = (self.slide_cones[s] if sliding[s] else self.held_cones[s]) @ block
            upper = np.zeros(len(C))
            upper[-1] = -cfg.min_normal_force_n
            G = np.zeros((len(C), n))
            G[:, nv + 6 * j:nv + 6 * j + 6] = C
            G_rows.append(G)
            l_rows.append(np.full(len(C), -np.inf))
            u_rows.append(upper)
        for i in range(n_p):
            G = np.zeros((len(self._pyramid), n))
            G[:, nv + 6 * k + 3 * i:nv + 6 * k + 3 * i + 3] = self._pyramid
            G_rows.append(G)
            l_rows.append(np.full(len(G), -np.inf))
            u_rows.append(np.zeros(len(G)))
        # joint position and velocity limits as acceleration bounds over the horizon
        hz = cfg.limit_horizon_s
        qj, vj = q[7:], v[6:]
        lo_a = np.maximum(2.0 * (self.q_lower - qj - vj * hz) / hz ** 2, (-self.v_max - vj) / hz)
        up_a = np.minimum(2.0 * (self.q_upper - qj - vj * hz) / hz ** 2, (self.v_max - vj) / hz)
        lo_a = np.minimum(lo_a, up_a)  # beyond a limit already: brake as hard as the other side
        Gl = np.zeros((nj, n))
        Gl[:, :nv] = self._limit_rows
        G_rows.append(Gl)
        l_rows.append(lo_a)
        u_rows.append(up_a)
        Gt = np.zeros((nj, n))
        Gt[:, :nv] = M[6:]
        Gt[:, nv:] = -Jt[6:]
        G_rows.append(Gt)
        l_rows.append(-self.tau_max - h[6:])
        u_rows.append(self.tau_max - h[6:])
        G = np.vstack(G_rows)
        lo = np.concatenate(l_rows)
        up = np.concatenate(u_rows)

        sol = self._solve(H, c, E, e, G, lo, up)
        relaxed = sol is None
        if relaxed:
            # The contact rows cannot all be met within the torque limits (a landing sole
            # still moving, a sole tipped on its edge): they become the heaviest task and the
            # torque limits stay. (Dropping the limits and clamping the torques afterwards
            # realizes other accelerations than the QP's: G1 spun off the ground at 4 rad/s.)
            self.relaxed_steps += 1
            # (the kinetic friction rows are the ground's physics: they stay)
            Ec, ec = E[6:n_rows], e[6:n_rows]
            Ek = np.vstack([E[:6], E[n_rows:]])
            ek = np.concatenate([e[:6], e[n_rows:]])
            Hs = H + cfg.weights.contact * (Ec.T @ Ec)
            cs = c - cfg.weights.contact * (Ec.T @ ec)
            sol = self._solve(Hs, cs, Ek, ek, G, lo, up)
            if sol is None:  # not even the dynamics within the limits: without them
                sol = self._solve(Hs, cs, Ek, ek, G[:-nj], lo[:-nj], up[:-nj])
        x = sol if sol is not None else np.zeros(n)
        a, w = x[:nv], x[nv:]
        # within the limits by the QP's constraints, to its tolerance (1e-6): the clip removes
        # that round-off (and clamps the torques of the rare step solved without them)
        tau = np.clip(M[6:] @ a + h[6:] - Jt[6:] @ w, -self.tau_max, self.tau_max)
        wrenches = np.zeros((2, 6))
        for j, s in enumerate(active):
            wrenches[s] = w[6 * j:6 * j + 6]
        point_forces = np.zeros((self._n_points, 3))
        for i, row in enumerate(points):
            point_forces[planned[row - 2]] = w[6 * k + 3 * i:6 * k + 3 * i + 3]
        return ControlStep(tau=tau, contacts=contact, wrenches=wrenches, relaxed=relaxed,
                           sliding=sliding, point_forces=point_forces)

    def _planned_points(self, f: int) -> list[int]:
        """Effector indices the reference rests on a prop's top at its frame ``f``."""
        if self.points is None:
            return []
        return [int(e) for e in np.flatnonzero(self.points.planned[f])]

    def _touching(self, dyn, planned: list[int], f: int) -> list[int]:
        """Rows of ``dyn`` (2 + i for the i-th planned effector at reference frame ``f``)
        whose simulated point is down on the top under it (within ``contact_height_m``)."""
        if not planned:
            return []
        pts = self.points
        assert pts is not None and self.surfaces is not None
        radius = np.array([pts.radius_m[e, f] for e in planned])
        p = dyn.poses[2:, :3, 3].copy()
        p[:, 2] -= radius
        top = self.surfaces.heights(p)
        h = p[:, 2] - top
        down = (top > 0.0) & (h <= self.config.contact_height_m)
        return [2 + int(i) for i in np.flatnonzero(down)]
