"""The whole-body spacetime solve: sequential QP over all frames in joint space.

``plan_whole_body`` fixes what the solve holds (targets, interaction mesh of the key points,
support, footprints, polygons, desired ZMP, limits); ``solve_whole_body`` linearizes the robot
at the current trajectory (:meth:`imesh.robot.Robot.trajectory_kinematics`), builds one banded
QP (:func:`imesh.solve.problem.build_qp`), solves it (:func:`imesh.solve.qp.solve_qp`) and
moves every frame by its update, until the update is below tolerance. The
:class:`WholeBodySolution` carries the residuals of every iteration measured on the nonlinear
trajectory, so a result can be checked.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..contacts.effectors import EffectorContacts
from ..contacts.phases import SIDES, runs
from ..core.limits import JointLimits
from ..errors import QpInfeasibleError, SolverError
from ..fit.targets import CompiledTargets
from ..mesh.interaction import build_interaction_mesh
from ..metrics.derivatives import motion_derivatives, velocity_jacobians
from ..metrics.props import ProxyPoints
from ..metrics.zmp import desired_zmp, multibody_zmp
from ..robot.capsules.hulls import BodyHulls
from ..robot.capsules.obstacles import Obstacles
from .collision import (
    HullShift,
    colliding_frames,
    collision_violation,
    linearize_collisions,
    refresh_hull_shift,
)
from .config import WholeBodyConfig
from .contacts import sole_errors
from .cwc import cone_violation, plan_cones
from .footprints import (
    Footprint,
    footprint_tracks,
    hold_poses,
    place_under_zmp,
    plan_footprints,
    raised,
    split_pivots,
    support_halfplanes,
)
from .holds import held_frames
from .merit import merit
from .obstacles import linearize_obstacles
from .plan import GRAVITY, Linearization, Plan
from .problem import build_qp
from .props import linearize_props, shared_violation
from .qp import solve_qp
from .torque import linearize_torques
from .touches import ContactPoints, plan_contact_points, touch_violation
from .trust import TrustRegion
from .zmp import band_weights

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class IterationReport:
    """Residuals of one SQP iterate, measured on the nonlinear trajectory.

    Attributes:
        step: largest |dq| of the update that led here [m or rad].
        sole_error_m: largest distance of a support sole frame from its footprint [m].
        sole_error_rad: largest rotation of a support sole frame from its footprint [rad].
        lowest_swing_m: lowest swing-sole corner [m].
        zmp_outside_m: largest distance of the multibody ZMP outside its shrunk polygon [m].
        velocity_ratio, acceleration_ratio: largest |velocity| / limit, |acceleration| / limit.
        keypoint_rms_m: RMS key-point distance to the adapted markers [m].
        qp_seconds, qp_iterations: the QP's wall time and iterations.
    """

    step: float
    sole_error_m: float
    sole_error_rad: float
    lowest_swing_m: float
    zmp_outside_m: float
    velocity_ratio: float
    acceleration_ratio: float
    keypoint_rms_m: float
    qp_seconds: float
    qp_iterations: int


@dataclass(frozen=True, eq=False)
class WholeBodySolution:
    """Result of :func:`solve_whole_body`.

    Attributes:
        q: (T, nq) float the solved trajectory.
        footprints: the planned footprints.
        plan: what the solve held fixed.
        history: one IterationReport per iterate (0 = the initializer).
        converged: the last update was below ``step_tolerance``.
        seconds: wall time [s] split into ``linearize``, ``build``, ``qp``, ``total``.
        config: the settings used.
    """

    q: np.ndarray
    footprints: list[Footprint]
    plan: Plan
    history: list[IterationReport]
    converged: bool
    seconds: dict
    config: WholeBodyConfig

    def report(self) -> dict:
        last = self.history[-1]
        return {"iterations": len(self.history) - 1, "converged": self.converged,
                "footprints": len(self.footprints),
                "sole_error_mm": 1e3 * last.sole_error_m,
                "sole_error_deg": float(np.degrees(last.sole_error_rad)),
                "lowest_swing_mm": 1e3 * last.lowest_swing_m,
                "zmp_outside_mm": 1e3 * last.zmp_outside_m,
                "velocity_ratio": last.velocity_ratio,
                "acceleration_ratio": last.acceleration_ratio,
                "keypoint_rms_mm": 1e3 * last.keypoint_rms_m,
                "seconds": dict(self.seconds)}


class _Frames:
    """The robot frames one linearization asks for, and where each target finds its frame."""

    def __init__(self, robot, targets: CompiledTargets, config: WholeBodyConfig | None = None,
                 props: np.ndarray | None = None, support: np.ndarray | None = None,
                 held: ContactPoints | None = None,
                 obstacles: Obstacles | None = None):
        soles = [robot.frame_id(robot.soles[s].frame) for s in SIDES]
        ids = list(dict.fromkeys(list(targets.kp_frame_ids) + list(targets.dir_frame_ids)
                                 + soles + [robot.frame_id(robot.waist_frame)]))
        self.ids = ids
        self.kp = np.array([ids.index(f) for f in targets.kp_frame_ids], dtype=int)
        self.dirs = np.array([ids.index(f) for f in targets.dir_frame_ids], dtype=int)
        self.soles = np.array([ids.index(f) for f in soles], dtype=int)
        self.kp_offsets = targets.kp_offsets
        self.dir_axes = targets.dir_axes
        self.sole_corners = foot_ground_points(robot)  # (2, P, 3)
        frames, points = leg_ground_points(robot)
        for f in dict.fromkeys(frames):
            if f not in ids:
                ids.append(f)
        self.ids = ids
        self.body = np.array([ids.index(f) for f in frames], dtype=int)
        self.body_points = points
        # self-collision: the capsules' frames (imesh.solve.collision)
        self.capsules = None
        self.capsule_frames = np.zeros(0, dtype=int)
        self.collision_activation = 0.0
        self.hulls: BodyHulls | None = None
        if config is not None and config.collision.enabled and robot.config.collision.in_solve:
            self.capsules = robot.capsule_model()
            cf = [robot.frame_id(f) for f in self.capsules.frames]
            ids += [f for f in dict.fromkeys(cf) if f not in ids]
            self.capsule_frames = np.array([ids.index(f) for f in cf], dtype=int)
            self.collision_activation = config.collision.self_activation_m
            # the rows' distances are the bodies' convex hulls' where the capsules come close
            # (imesh.solve.collision.linearize_collisions)
            self.hulls = self.capsules.body_hulls()
        # props (imesh.solve.props): the capsules of every body but the feet, whose ground
        # points stand in for them (skipped in their support frames)
        self.props = None
        if props is not None and config is not None and support is not None:
            model = self.capsules if self.capsules is not None else robot.capsule_model()
            cf = [robot.frame_id(f) for f in model.frames]
            ids += [f for f in dict.fromkeys(cf) if f not in ids]
            self.prop_model = model
            self.prop_capsule_frames = np.array([ids.index(f) for f in cf], dtype=int)
            feet = {robot.soles[s].frame for s in SIDES}
            self.prop_capsule_skip = np.array([c.frame in feet for c in model.capsules])
            # and the evaluator's proxy points (imesh.metrics.props) off the feet: the capsules
            # do not enclose every collision shape (the G1's rubber hands)
            pts = ProxyPoints.of(robot)
            keep = np.array([pts.frames[o] not in feet for o in pts.owner])
            pf = [robot.frame_id(f) for f in pts.frames]
            ids += [f for f in dict.fromkeys(pf) if f not in ids]
            self.prop_points_local = pts.local_m[keep]
            self.prop_points_owner = np.array([ids.index(pf[o]) for o in pts.owner[keep]],
                                              dtype=int)
            self.prop_points_radius = pts.radius_m[keep]
            self.prop_support = np.asarray(support, dtype=bool)
            self.prop_activation = config.collision.activation_m
            self.props = props
        # points held on prop tops (imesh.solve.touches)
        self.held = None
        if held is not None:
            hf = [robot.frame_id(f) for f in held.frames]
            ids += [f for f in dict.fromkeys(hf) if f not in ids]
            self.held = np.array([ids.index(f) for f in hf], dtype=int)
            self.held_local = held.local_m
        # moving obstacles (imesh.solve.obstacles): every capsule, the feet's too (a partner's
        # foot is no floor)
        self.obstacles = None
        if obstacles is not None and config is not None:
            model = self.capsules if self.capsules is not None else robot.capsule_model()
            cf = [robot.frame_id(f) for f in model.frames]
            ids += [f for f in dict.fromkeys(cf) if f not in ids]
            self.obstacle_model = model
            self.obstacle_frames = np.array([ids.index(f) for f in cf], dtype=int)
            self.obstacle_activation = config.collision.activation_m
            self.obstacles = obstacles


def leg_ground_points(robot, below: float = 0.4) -> tuple[list[int], np.ndarray]:
    """Points of the collision proxies that can reach the ground other than the soles' own:
    every support point (in its frame) of the proxies on frames other than the sole frames
    whose lowest point in the nominal pose is below ``below`` times the base height (shins,
    knees, ankle links). Returns (frame index per point, (Q, 3) points in their frames)."""
    soles = {robot.soles[s].frame for s in SIDES}
    q0 = robot.q_nominal
    frames, points = [], []
    for shape in robot.collision_shapes:
        if shape.frame in soles:
            continue
        pts = shape.support_points(n_circle=8)
        M = robot.frame_placements(q0, [shape.frame])[0]
        if (pts @ M[:3, :3].T + M[:3, 3])[:, 2].min() > below * q0[2]:
            continue
        frames += [robot.frame_id(shape.frame)] * len(pts)
        points.append(pts)
    return frames, (np.concatenate(points) if points else np.zeros((0, 3)))


def foot_ground_points(robot, band_m: float = 0.005) -> np.ndarray:
    """(2, P, 3) points of each foot [left, right], in its sole frame, that must stay above the
    ground in swing: the sole corners and the bottom (within ``band_m`` of the lowest, along
    the sole normal) support points of the collision proxies on the sole frame (a proxy larger
    than the sole rectangle would otherwise dip into the ground when the foot pitches)."""
    out = []
    for side in SIDES:
        sole = robot.soles[side]
        pts = [sole.corners()]
        for shape in robot.collision_shapes:
            if shape.frame == sole.frame:
                sp_ = shape.support_points(n_circle=8)
                height = sp_ @ sole.normal
                pts.append(sp_[height <= height.min() + band_m])
        out.append(np.concatenate(pts))
    n = max(len(p) for p in out)
    return np.stack([np.concatenate([p, np.repeat(p[-1:], n - len(p), axis=0)]) for p in out])


def _cross_rows(J: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``[r]x^T``-style lever: (..., 3, nv) angular Jacobian rows -> ``-(r x J)`` so that
    ``J_point = J_origin + (J_omega x r)`` column-wise, with r (..., 3)."""
    return -np.cross(r[..., None, :], np.swapaxes(J, -1, -2)).swapaxes(-1, -2)


def linearize(robot, q: np.ndarray, frames: _Frames, fps: float,
              support: np.ndarray | None = None, torque_limit: float = 1.0,
              hull_shift: HullShift | None = None) -> Linearization:
    """Key points, directions, soles, CoM and their Jacobians at every frame of ``q``; with the
    planned ``support`` (T, 2) also the net joint torques and the rows of those above 70 % of
    ``torque_limit`` (a fraction of the effort limits, :mod:`.torque`). ``hull_shift``: the
    self-collision distances' hull shift to keep (a line search's trial point; default:
    evaluated at ``q``, :func:`imesh.solve.collision.linearize_collisions`)."""
    kin = robot.trajectory_kinematics(q, frames.ids)
    M, J = kin.placements, kin.jacobians
    R, p = M[..., :3, :3], M[..., :3, 3]
    # key points: origin + R offset; J_p = J_o + J_omega x (R offset)
    lever = np.einsum("tkij,kj->tki", R[:, frames.kp], frames.kp_offsets)
    points = p[:, frames.kp] + lever
    jk = J[:, frames.kp]
    point_j = jk[:, :, :3] + _cross_rows(jk[:, :, 3:], lever)
    axes = np.einsum("tdij,dj->tdi", R[:, frames.dirs], frames.dir_axes)
    soles = M[:, frames.soles]
    js = J[:, frames.soles]  # (T, 2, 6, nv)
    lever_c = np.einsum("tsij,scj->tsci", soles[..., :3, :3], frames.sole_corners)
    corners = soles[:, :, None, :3, 3] + lever_c
    # height rows of the corner Jacobians: J_o,z + (J_omega x r)_z
    jw = js[:, :, None, 3:]  # (T, 2, 1, 3, nv)
    cz = js[:, :, None, 2] + (jw[..., 0, :] * lever_c[..., 1:2] - jw[..., 1, :] * lever_c[..., 0:1])
    # other leg proxies' points: heights and their Jacobian rows
    lever_b = np.einsum("tqij,qj->tqi", R[:, frames.body], frames.body_points)
    body_z = p[:, frames.body, 2] + lever_b[..., 2]
    jb = J[:, frames.body]
    body_jz = jb[:, :, 2] + (jb[:, :, 3] * lever_b[..., 1:2] - jb[:, :, 4] * lever_b[..., 0:1])
    v, a = motion_derivatives(q, fps)
    com, dh, ag = robot.centroidal_trajectory(q, v, fps)
    m = robot.mass
    acc, ld = dh[:, :3] / m, dh[:, 3:]
    dv_dq = velocity_jacobians(q, fps)  # the momentum's rows and the torques' share it
    # k_t = Ag_ang(q_t) v_t moves with the velocity's frames and with q_t itself
    kj = np.einsum("tan,tsnm->tsam", ag[:, 3:], dv_dq)
    kj[:, 1] += robot.momentum_jacobians(q, v)[:, 3:]
    zmp = multibody_zmp(com, dh, m)
    rot = _base_rotations(q)
    torques = None
    if support is not None:
        torques = linearize_torques(robot, q, v, a, fps, support, soles, js, torque_limit,
                                    dv_dq)
    collision = None
    if frames.capsules is not None:
        collision = linearize_collisions(frames.capsules, M[:, frames.capsule_frames],
                                         J[:, frames.capsule_frames],
                                         frames.collision_activation, frames.hulls,
                                         hull_shift)
    prop_lin = None
    if frames.props is not None:
        model = frames.prop_model
        Mc = M[:, frames.prop_capsule_frames][:, model.frame_index]  # (T, C, 4, 4)
        Jc = J[:, frames.prop_capsule_frames][:, model.frame_index]
        T, n_pts = len(q), corners.shape[2]
        # point proxies: the feet's ground points (frames 0, 1 of the stacked Jacobians), then
        # the evaluator's proxy points of the other links
        own = frames.prop_points_owner
        Mo = M[:, own]
        pts = np.concatenate([corners.reshape(T, -1, 3),
                              np.einsum("tnij,nj->tni", Mo[..., :3, :3], frames.prop_points_local)
                              + Mo[..., :3, 3]], axis=1)
        origin = np.concatenate([np.repeat(soles[:, :, :3, 3], n_pts, axis=1), Mo[..., :3, 3]],
                                axis=1)
        jac = np.concatenate([js, J], axis=1)  # (T, 2 + F, 6, nv)
        owner = np.r_[np.repeat([0, 1], n_pts), 2 + own]
        skip = np.concatenate([np.repeat(frames.prop_support, n_pts, axis=1),
                               np.zeros((T, len(own)), dtype=bool)], axis=1)
        prop_lin = linearize_props(
            frames.props, model.world_segments(M[:, frames.prop_capsule_frames]), model.radius,
            Mc[..., :3, 3], Jc, np.broadcast_to(frames.prop_capsule_skip, (T, len(model.radius))),
            pts, origin, jac, skip, frames.prop_activation, point_owner=owner,
            point_radius=np.r_[np.zeros(2 * n_pts), frames.prop_points_radius])
    held = held_j = None
    if frames.held is not None:
        Mh, Jh = M[:, frames.held], J[:, frames.held]
        lever_h = np.einsum("tcij,cj->tci", Mh[..., :3, :3], frames.held_local)
        held = Mh[..., :3, 3] + lever_h
        held_j = Jh[:, :, :3] + _cross_rows(Jh[:, :, 3:], lever_h)
    obstacle_lin = None
    if frames.obstacles is not None:
        obstacle_lin = linearize_obstacles(frames.obstacle_model, M[:, frames.obstacle_frames],
                                           J[:, frames.obstacle_frames], frames.obstacles,
                                           frames.obstacle_activation)
    return Linearization(points=points, point_jacobians=point_j, axes=axes,
                         axis_jacobians=J[:, frames.dirs, 3:], soles=soles, sole_jacobians=js,
                         corners=corners, corner_jacobians_z=cz, body_z=body_z,
                         body_jacobians_z=body_jz, com=kin.com,
                         com_jacobians=kin.com_jacobians, com_acceleration=acc,
                         angular_momentum_rate=ld, momentum_jacobians=kj, mass=m,
                         zmp_multibody=zmp,
                         base_rotations=rot, torques=torques, collision=collision,
                         props=prop_lin, held_points=held, held_jacobians=held_j,
                         obstacles=obstacle_lin)


#: A frame whose ZMP is within this of the CoM's ground projection is quasi-static [m]
#: (:func:`~imesh.solve.footprints.place_under_zmp` judges the feet by those).
QUASI_STATIC_M = 0.05


def stance_width(robot) -> float:
    """[m] distance between the sole centres in the robot's nominal pose."""
    M = robot.frame_placements(robot.q_nominal, [robot.soles[s].frame for s in SIDES])
    c = [M[k, :3, :3] @ robot.soles[s].center + M[k, :3, 3] for k, s in enumerate(SIDES)]
    return float(np.linalg.norm(c[0][:2] - c[1][:2]))


def _base_rotations(q: np.ndarray) -> np.ndarray:
    return Rotation.from_quat(q[:, 3:7]).as_matrix()  # scipy and pinocchio: x, y, z, w


def keypoint_laplacians(marker_points: np.ndarray) -> np.ndarray:
    """(T, K, K) dense Laplacian L_t of each frame's interaction mesh over the key-point
    markers (:func:`imesh.mesh.interaction.build_interaction_mesh`, inverse-distance
    weights)."""
    T, K, _ = marker_points.shape
    out = np.zeros((T, K, K))
    # in blocks of frames (each frame's mesh is its own): at once, a 30-minute clip's meshes
    # took 1 GB
    for a in range(0, T, LAPLACIAN_BLOCK_FRAMES):
        lap = build_interaction_mesh(marker_points[a:a + LAPLACIAN_BLOCK_FRAMES]).laplacian.tocoo()
        out[a + lap.row // K, lap.row % K, lap.col % K] = lap.data
    return out


#: Frames whose interaction meshes :func:`keypoint_laplacians` builds at a time.
LAPLACIAN_BLOCK_FRAMES = 2048


def swing_clearance(support: np.ndarray, base_m: float, lift_m: float, edge_m: float,
                    lift_off_m: float) -> np.ndarray:
    """(T, 2) [m] clearance of each foot's ground points: in every swing between two support
    phases of that foot ``edge_m`` (the foot leaves and lands flat: a sole is on the ground or
    clearly off it, never rolling on an edge), ``lift_m`` over its middle third and
    ``lift_off_m`` in its first frame (a gradual lift-off); ``base_m`` elsewhere."""
    out = np.full(support.shape, base_m, dtype=float)
    for k in range(support.shape[1]):
        for a, b in runs(~support[:, k]):
            if a > 0 and b < len(support):
                third = (b - a) // 3
                out[a:b, k] = max(edge_m, base_m)
                out[a + third:b - third, k] = max(lift_m, base_m)
                out[a, k] = max(lift_off_m, base_m)
    return out


def impact_normal(flight: np.ndarray, fps: float, normal: float, impact: float,
                  impact_s: float) -> np.ndarray:
    """(T,) largest normal force per frame, times the weight: ``impact`` within ``impact_s``
    before a take-off and after a landing of a flight phase (``flight`` (T,) bool), ``normal``
    elsewhere."""
    out = np.full(len(flight), normal)
    n = int(round(impact_s * fps))
    for a, b in runs(flight):
        out[max(a - n, 0):b + n] = impact
    return out


def kinetic_directions(footprints: list[Footprint], support: np.ndarray, fps: float,
                       min_speed: float = 0.1) -> np.ndarray:
    """(T, 2) unit direction of the kinetic friction force (against the slide of the sliding
    sole centre) in the frames whose only support slides faster than ``min_speed`` [m/s]; NaN
    elsewhere (a planted foot's static friction, a pivot turning in place)."""
    T = len(support)
    centre = np.full((T, 2, 2), np.nan)
    slides = np.zeros((T, 2), dtype=bool)
    for f in footprints:
        k = SIDES.index(f.side)
        centre[f.start:f.stop, k] = f.center_m[:2]
        slides[f.start:f.stop, k] |= f.sliding
    out = np.full((T, 2), np.nan)
    only = support.sum(axis=1) == 1
    for k in range(2):
        for a, b in runs(slides[:, k]):
            if b - a < 2:
                continue
            v = np.gradient(centre[a:b, k], 1.0 / fps, axis=0)
            speed = np.linalg.norm(v, axis=1)
            sel = (speed > min_speed) & only[a:b] & support[a:b, k]
            out[a:b][sel] = -v[sel] / speed[sel, None]
    return out


def plan_whole_body(robot, q_init: np.ndarray, markers: np.ndarray, targets: CompiledTargets,
                    support: np.ndarray, fps: float, limits: JointLimits,
                    config: WholeBodyConfig,
                    transition_s: float = 0.1, rest_frames: int = 3,
                    sliding: np.ndarray | None = None, support_heights: np.ndarray | None = None,
                    props: np.ndarray | None = None,
                    effectors: EffectorContacts | None = None,
                    inferred: np.ndarray | None = None) -> tuple[Plan, list[Footprint]]:
    """Fix the targets, mesh, support, footprints and limits of a whole-body solve.

    Args:
        robot: the robot.
        q_init: (T, nq) initial trajectory (within the joint limits).
        markers: (T, M, 3) adapted markers (the fit's markers, ``targets`` index them).
        targets: key points and directions compiled against ``markers``.
        support: (T, 2) bool [left, right] planned support (sliding and planted feet); frames
            without are flight (ballistic, :mod:`.forces`).
        fps: frame rate [1/s].
        limits: the (n,) joint limits (e.g. :func:`imesh.fit.limits.joint_limits`).
        config: WholeBodyConfig.
        transition_s: blending of the desired ZMP between phases (as the evaluator's).
        rest_frames: the first and last this many frames are held identical (start and end
            at rest); 0: free.
        sliding: (T, 2) bool support frames whose sole slides or pivots along the ground
            (one footprint per frame, :func:`~imesh.solve.footprints.plan_footprints`); None:
            none.
        support_heights: (T, 2) [m] height of each foot's support surface (a prop's top, 0:
            the floor; :func:`imesh.contacts.surfaces.phase_heights`): each footprint is level
            at the median over its frames, and frames with a support above the floor get no
            ZMP rows (the ZMP is the evaluator's, on z = 0; docs/terrain.md). None: the floor.
        props: (P, K, 4) the props' face planes (:attr:`Plan.props`), or None.
        effectors: (T frames) the person's hands and knees on prop tops
            (:func:`imesh.contacts.effectors.detect_effector_contacts`, padded to the lead
            frames): held points on the tops (:mod:`.touches`). With props, every supported
            frame that is not all soles on the floor is balanced by the contact wrench cone
            (:mod:`.cwc`) instead of the ZMP.
        inferred: (T, 2) bool support frames whose foot holds still where it last stood
            (``Contacts.inferred``: the person's foot in the air while it carries the body): the
            footprints and the pivot test take the sole pose of the foot's support frame next
            to them, turned by the base's turn beyond a leg's twist (a pirouette on the ball of
            the foot: :func:`~imesh.solve.footprints.hold_poses`). None: none.
    """
    T = len(q_init)
    frames = _Frames(robot, targets)
    kin = robot.trajectory_kinematics(q_init, [frames.ids[i] for i in frames.soles])
    support = np.asarray(support, dtype=bool)
    base = _base_rotations(q_init)
    base_yaw = np.arctan2(base[:, 1, 0], base[:, 0, 0])
    poses = {s: (kin.placements[:, k] if inferred is None
                 else hold_poses(kin.placements[:, k], support[:, k], inferred[:, k],
                                 base_yaw))
             for k, s in enumerate(SIDES)}
    sliding = (np.zeros_like(support) if sliding is None
               else np.asarray(sliding, dtype=bool) & support)
    # planted runs that pivot or slide in the fit become re-steps, or pivots where the other
    # foot cannot carry a re-step; detected slides stay slides
    pivots = np.zeros_like(support)
    support = split_pivots(robot, poses, support & ~sliding, fps, pivots=pivots) | sliding
    if pivots.any():
        log.info("planted frames that turn or slide in the fit without a re-step: %s (left), "
                 "%s (right): planned as pivots", runs(pivots[:, 0]), runs(pivots[:, 1]))
    sliding = sliding | (pivots & support)
    footprints = plan_footprints(robot, poses, support, load=config.forces.max_normal,
                                 margin=config.zmp.margin, sliding=sliding,
                                 reach_m=config.feet.slide_reach_m,
                                 slide_step_m=config.feet.slide_speed_m_s / fps)
    # on a prop's top the z = 0 ZMP is not the ZMP of the support (and a foot moved under it
    # can leave the top): those plans keep the person's footprints
    on_props = support_heights is not None and bool((support_heights[support] > 1e-3).any())
    if on_props:
        log.info("supports on a prop's top: footprints not moved under the ZMP")
    if not on_props and (config.feet.under_zmp == "all"
                         or (config.feet.under_zmp == "slides" and sliding.any())):
        v, _ = motion_derivatives(q_init, fps)
        com, dh, _ = robot.centroidal_trajectory(q_init, v, fps)
        zmp = multibody_zmp(com, dh, robot.mass)
        footprints, moved = place_under_zmp(
            footprints, support, zmp, max(1, int(round(0.1 * fps))), int(round(0.2 * fps)),
            stance_width(robot), only_slides=config.feet.under_zmp == "slides",
            static=np.linalg.norm(zmp - com[:, :2], axis=1) <= QUASI_STATIC_M)
        for m_ in moved:
            log.info("%s footprint over frames [%d, %d) moved by (%.0f, %.0f) mm under the ZMP "
                     "it carries alone", m_["side"], *m_["frames"], *(1e3 * m_["shift_m"]))
    halfplanes = None
    if support_heights is not None:
        footprints = [raised(f, float(np.median(support_heights[f.start:f.stop,
                                                                SIDES.index(f.side)])))
                      for f in footprints]
        halfplanes = floor_halfplanes(footprints, support)
    points = None
    if effectors is not None and props is not None and effectors.contact.any():
        points = plan_contact_points(robot, q_init, effectors, list(props), prop_tops(props),
                                     config.collision.margin_m)
    held = np.zeros(T, dtype=bool) if points is None else np.asarray(points.active.any(axis=1))
    flight = np.logical_not(support.any(axis=1) | held)
    sole_targets = np.full((T, 2, 4, 4), np.nan)
    for f in footprints:
        sole_targets[f.start:f.stop, SIDES.index(f.side)] = f.frame_pose
    cones = None
    if props is not None and halfplanes is not None:
        # the ZMP where every contact is a sole on the floor, the cone everywhere else
        keep = ~held[halfplanes[0]]
        halfplanes = tuple(h[keep] for h in halfplanes)
        zmp = np.zeros(T, dtype=bool)
        zmp[halfplanes[0]] = True
        cones = plan_cones(robot, support, sole_targets,
                           None if points is None else points.anchor_m,
                           None if points is None else points.active,
                           np.flatnonzero(~flight & ~zmp))
    elif props is None and config.forces.yaw_sole_scale > 0:
        # one sole on the floor holds a yaw moment of at most mu (X + Y) f_z: the cone of the
        # sole scaled by yaw_sole_scale keeps the plan's inside it (the ZMP rows stay)
        single = np.flatnonzero(support.sum(axis=1) == 1)
        if len(single):
            cones = plan_cones(robot, support, sole_targets, None, None, single,
                               sole_scale=config.forces.yaw_sole_scale)
    tracks = footprint_tracks(footprints, T, fps)
    kp_markers = markers[:, targets.kp_markers]
    lap = keypoint_laplacians(kp_markers)
    w2 = targets.kp_weights ** 2
    metric = np.einsum("tji,tjk->tik", lap, lap) * config.costs.mesh
    metric[:, np.arange(len(w2)), np.arange(len(w2))] += w2
    d = markers[:, targets.dir_to] - markers[:, targets.dir_from]
    d /= np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-12)
    plan = Plan(marker_points=kp_markers, keypoint_weights=targets.kp_weights,
                mesh_metric=metric, target_directions=d, direction_weights=targets.dir_weights,
                support=np.asarray(support, dtype=bool), sole_targets=sole_targets,
                halfplanes=(support_halfplanes(footprints, support) if halfplanes is None
                            else halfplanes),
                desired_zmp=desired_zmp(tracks, support, transition_s),
                zmp_weights=band_weights(support, fps, config.zmp), q_init=q_init,
                lower=limits.lower, upper=limits.upper, v_max=limits.v_max,
                a_max=limits.a_max, fps=fps,
                rest_frames=rest_frames,
                clearance=swing_clearance(support, config.feet.clearance_m,
                                          config.feet.swing_lift_m, config.feet.swing_edge_m,
                                          config.feet.lift_off_m),
                normal_max=(impact_normal(flight, fps, config.forces.max_normal,
                                          config.forces.impact_normal, config.forces.impact_s)
                            if flight.any() else None),
                kinetic=(kinetic_directions(footprints, support, fps) if sliding.any()
                         else None), props=props, points=points, cones=cones)
    return plan, footprints


def prop_tops(planes: np.ndarray) -> np.ndarray:
    """(P,) [m] the top height of each prop (P, K, 4): its highest upward face."""
    up = planes[..., 2] > 0.9
    return np.where(up, planes[..., 3] / np.where(up, planes[..., 2], 1.0), -np.inf).max(axis=1)


def floor_halfplanes(footprints: list[Footprint], support: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`~imesh.solve.footprints.support_halfplanes` of the frames whose support
    footprints are all on the floor (within 1 mm of z = 0): the ZMP rows hold only there (the
    multibody ZMP of the evaluator is on z = 0; feet on a prop's top, or at two heights, would
    need the contact wrench cone)."""
    raised_ = np.zeros(len(support), dtype=bool)
    for f in footprints:
        if abs(f.center_m[2]) > 1e-3:
            raised_[f.start:f.stop] = True
    frame, n, b = support_halfplanes(footprints, support)
    keep = ~raised_[frame]
    return frame[keep], n[keep], b[keep]


def _report(lin: Linearization, plan: Plan, q: np.ndarray, step: float, qp_seconds: float,
            qp_iterations: int) -> IterationReport:
    sup = plan.support
    _, _, err = sole_errors(lin, plan)
    pos_err = np.linalg.norm(err[:, :3], axis=1).max(initial=0.0)
    ang = np.linalg.norm(err[:, 3:], axis=1).max(initial=0.0)  # |log R| is the angle
    sw_t, sw_k = np.nonzero(~sup)
    lowest = lin.corners[sw_t, sw_k, :, 2].min(initial=np.inf)
    hp_frame, hp_n, hp_b = plan.halfplanes
    outside = (hp_b - np.sum(hp_n * lin.zmp_multibody[hp_frame], axis=1))
    # a window's first two (fixed) frames have one-sided differences: their ZMP is the
    # previous window's business (and a join window's last two the next chain's)
    outside = outside[(hp_frame >= min(plan.fixed_frames, 2))
                      & (hp_frame < len(q) - min(plan.fixed_end_frames, 2))]
    # distance outside a convex polygon >= largest violated half-plane distance
    zmp_out = float(np.maximum(outside, 0).max(initial=0.0))
    qj = q[:, 7:]
    h = 1.0 / plan.fps
    vel = (np.abs(np.diff(qj, axis=0)) / (plan.v_max * h)).max(initial=0.0)
    acc = (np.abs(np.diff(qj, 2, axis=0)) / (plan.a_max * h * h)).max(initial=0.0)
    rms = float(np.sqrt(np.mean(np.sum((lin.points - plan.marker_points) ** 2, axis=-1))))
    return IterationReport(step=step, sole_error_m=float(pos_err), sole_error_rad=float(ang),
                           lowest_swing_m=float(lowest), zmp_outside_m=zmp_out,
                           velocity_ratio=float(vel), acceleration_ratio=float(acc),
                           keypoint_rms_m=rms, qp_seconds=qp_seconds,
                           qp_iterations=qp_iterations)


def _settled(lin: Linearization, plan: Plan, r: IterationReport, config: WholeBodyConfig,
             use: float | None = None, zmp_m: float = 0.0) -> bool:
    """Every other constraint the evaluator scores also holds at the iterate: joint velocities
    and accelerations within their limits, no self-collision distance more than 1 mm inside
    its margin, no torque more than 0.1 % of its limit above the margin-reduced limit, no
    cone row more than 1e-3 above its margin. With ``use`` (``SqpOptions.margin_use``): the
    speeds, accelerations and torques may take that fraction of their margins, and the cone
    rows ``g zmp_m`` more (a cone row of ``g d`` is a centre of pressure ``d`` beyond its face
    at 1 g, the distance the ZMP rows may use)."""
    m = config.margins
    v_cap, a_cap = ((1.0, 1.0) if use is None else
                    (1.0 - (1.0 - use) * m.velocity, 1.0 - (1.0 - use) * m.acceleration))
    use = use or 0.0
    if r.velocity_ratio > v_cap + 1e-6 or r.acceleration_ratio > a_cap + 1e-6:
        return False
    T = len(lin.points)
    if any(colliding_frames(d, T, config.collision.margin_m).any()
           for d in (lin.collision, lin.props, lin.obstacles)):
        return False
    if plan.points is not None and lin.held_points is not None and \
            touch_violation(lin.held_points, plan.points).max() > 1e-3:
        return False
    if plan.cones is not None and cone_violation(lin, plan).max() > 1e-3 + GRAVITY * zmp_m:
        return False
    return lin.torques is None or lin.torques.excess(1.0 - config.margins.torque).max(
        initial=0.0) <= 1e-3 + use * config.margins.torque


def _violation(lin: Linearization, config: WholeBodyConfig) -> float:
    """The self-collision (and prop) shortfalls a step may not deepen."""
    if lin.props is None and lin.obstacles is None:
        return collision_violation(lin.collision, config.collision.margin_m)
    return shared_violation(lin.collision, lin.props, config.collision.margin_m,
                            lin.obstacles)


def solve_whole_body(robot, plan: Plan, footprints: list[Footprint], targets: CompiledTargets,
                     config: WholeBodyConfig | None = None,
                     progress: Callable[[int, int], None] | None = None) -> WholeBodySolution:
    """Sequential QP from ``plan.q_init`` (see the module docstring).

    ``progress(iteration, n)`` is called after every SQP iteration, n the largest number of
    iterations (``config.sqp.iterations``, or ``contact_iterations`` with cone rows or flight
    frames; the solve may stop earlier).

    Raises:
        SolverError: a QP failed (infeasible linearization, non-finite result).
    """
    config = config or WholeBodyConfig()
    frames = _Frames(robot, targets, config, props=plan.props, support=plan.support,
                     held=plan.points, obstacles=plan.obstacles)
    q = (plan.q_init if plan.q_start is None else plan.q_start).copy()
    seconds = {"linearize": 0.0, "build": 0.0, "qp": 0.0}
    t_all = time.perf_counter()
    t0 = time.perf_counter()
    # torque rows unless the margin is 1 (the whole limit given up)
    support = plan.support if config.margins.torque < 1 else None
    lin = linearize(robot, q, frames, plan.fps, support, 1.0 - config.margins.torque)
    seconds["linearize"] += time.perf_counter() - t0
    history = [_report(lin, plan, q, 0.0, 0.0, 0)]
    converged = False
    T, nv = len(q), robot.nv
    # elastic mode (as SNOPT's): once a QP turns out infeasible, the speed rows the iterate
    # violates get a slack and the merit prices them
    elastic = False
    phi = merit(lin, plan, q, config)
    # the trust region: a radius per frame and coordinate, as fractions of their nominal
    # values (imesh.solve.trust)
    region = TrustRegion.start(config.sqp, len(q), robot.nv)
    # the floor's single-support yaw cones (ForceOptions.yaw_sole_scale) are not contacts the
    # plan has to find: only prop contacts and flight get contact_iterations
    prop_cones = plan.props is not None and plan.cones is not None
    unknown_contacts = prop_cones or bool(plan.flight.any())
    n_iter = config.sqp.contact_iterations if unknown_contacts else config.sqp.iterations
    # SqpOptions.contact_gain is measured on flight; a climb's cones keep the whole budget
    flight_only = unknown_contacts and not prop_cones
    # the distance the ZMP margin keeps from the soles' edges (the footprints are the robot's
    # sole rectangles): margin times their smallest half size; a stop may use margin_use of it
    zmp_use = config.sqp.margin_use * config.zmp.margin * min(
        min(robot.soles[s].half_extents) for s in SIDES)

    # once one of PIQP's runs stalls on a QP of this solve, the later QPs start at the run
    # that converged: their linearizations share the scaling that stalled it (iCub: every
    # first attempt stalled at its 80-iteration limit, 5-6 s of a 10-30 s QP; the JVRC-1
    # veer's first QPs needed the third run, after 180 iterations of the first two)
    first_attempt = 0

    def solve(qp, it: int):
        nonlocal first_attempt
        try:
            # a window's QP (fixed first frames): PIQP's duality-gap test stalls there
            sol = solve_qp(qp, config.sqp.solver, config.sqp.qp_tolerance,
                           gap_check=plan.fixed_frames == 0 and plan.fixed_end_frames == 0,
                           first_attempt=first_attempt)
            first_attempt = max(first_attempt, sol.attempt)
            return sol
        except QpInfeasibleError:
            raise  # certified: Clarabel would spend a minute to say so too
        except SolverError as exc:
            if config.sqp.solver == "clarabel":
                raise SolverError(f"whole-body solve, iteration {it + 1}: {exc}",
                                  residual=exc.residual) from None
            # PIQP stalls on some badly scaled linearizations where Clarabel's homogeneous
            # embedding still converges (measured: docs/wholebody.md)
            log.info("whole-body iteration %d: %s; retrying with clarabel", it + 1, exc)
            return solve_qp(qp, "clarabel", config.sqp.qp_tolerance)

    for it in range(n_iter):
        t0 = time.perf_counter()
        radius = region.capped(colliding_frames(lin.collision, T, config.collision.margin_m),
                               config.sqp.collision_trust)
        qp = build_qp(lin, plan, q, config, elastic_speeds=elastic, radius=radius)
        seconds["build"] += time.perf_counter() - t0
        try:
            sol = solve(qp, it)
        except SolverError as exc:
            if elastic:
                raise
            # no step meets the hard rows within the trust region: the initializer runs a
            # joint faster than its margin-reduced speed limit over a longer sweep than one
            # step can undo (the CMU 07_05 walk on JVRC-1)
            log.info("whole-body iteration %d: %s; elastic speed rows from here on", it + 1,
                     exc)
            elastic = True
            phi = merit(lin, plan, q, config, speeds=True)
            sol = solve(build_qp(lin, plan, q, config, elastic_speeds=True, radius=radius),
                        it)
        seconds["qp"] += sol.seconds
        dq = sol.x.reshape(T, -1)[:, :nv].copy()
        # held frames: their equality rows hold to the QP's tolerance; keep them exact, so
        # windows meet their neighbours' solutions bit for bit
        dq[held_frames(plan, T)] = 0.0
        # backtracking on the exact-penalty merit: the linearized ZMP and rotations are only
        # valid near q, and a full step far from a feasible point can make things worse
        t0 = time.perf_counter()
        for alpha in (1.0, 0.5, 0.25, 0.125):
            q_new = np.array([robot.integrate(q[t], alpha * dq[t]) for t in range(T)])
            lin_new = linearize(robot, q_new, frames, plan.fps, support,
                                1.0 - config.margins.torque,
                                None if lin.collision is None else lin.collision.shift)
            phi_new = merit(lin_new, plan, q_new, config, speeds=elastic)
            # a step may not deepen the self-collisions, whatever else it gains: a long step
            # can carry a hand through a body, where the distance's gradient then points
            # through (G1 walk: a wrist stuck 70 mm inside the hip, marker RMS 47 -> 58 mm)
            deeper = _violation(lin_new, config) > _violation(lin, config) + 1e-6
            if phi_new < phi and not deeper:
                break
            phi_new = max(phi_new, phi) if deeper else phi_new
        seconds["linearize"] += time.perf_counter() - t0
        step = float(alpha * np.abs(dq).max())
        if progress is not None:
            progress(it + 1, n_iter)
        # past the plain budget, a plan with flight goes on only while it is still finding its
        # contacts: its merit falling fast (the 60 s dance's windows with two 2-frame
        # flights lowered theirs by 3-5 % per iteration from the 20th to the 40th: twice the
        # time for what the windows without flight leave after 20)
        slow = (flight_only and it + 1 >= config.sqp.iterations
                and phi - min(phi_new, phi) < config.sqp.contact_gain * phi)
        if phi_new >= phi:  # no decrease along the step: a smaller trust region next time
            region = region.shrink()
            log.info("whole-body iteration %d: no merit decrease (%.6g >= %.6g); trust region "
                     "%.3g", it + 1, phi_new, phi, region.largest)
            if region.largest < config.sqp.step_tolerance:
                converged = True
                break
            if slow:
                log.info("whole-body solve stopped after iteration %d: past %d iterations "
                         "without a merit decrease", it + 1, config.sqp.iterations)
                break
            continue
        gain = phi - phi_new
        q, lin, phi = q_new, lin_new, phi_new
        if frames.hulls is not None and frames.capsules is not None and \
                lin.collision is not None:
            # the accepted point's own hull shift (the step was judged with the last one's)
            lin = dataclasses.replace(lin, collision=refresh_hull_shift(
                lin.collision, frames.capsules, frames.hulls))
            phi = merit(lin, plan, q, config, speeds=elastic)
        history.append(_report(lin, plan, q, step, sol.seconds, sol.iterations))
        r = history[-1]
        log.info("whole-body iteration %d: step %.2e (alpha %.3g), merit %.6g, soles %.2f mm / "
                 "%.3f deg, swing low %.1f mm, ZMP outside %.1f mm, v %.3f a %.3f of limits, "
                 "key points %.1f mm RMS, QP %.2f s (%d it)", it + 1, step, alpha, phi,
                 1e3 * r.sole_error_m, np.degrees(r.sole_error_rad), 1e3 * r.lowest_swing_m,
                 1e3 * r.zmp_outside_m, r.velocity_ratio, r.acceleration_ratio,
                 1e3 * r.keypoint_rms_m, sol.seconds, sol.iterations)
        clear = r.lowest_swing_m > config.feet.clearance_m - 1e-3
        placed = r.sole_error_m < 1e-3 and clear
        feasible = placed and r.zmp_outside_m < 1e-3
        region = region.follow(dq, alpha, r.sole_error_m, clear)
        # the key points' change against the previous accepted iterate
        kept = abs(r.keypoint_rms_m - history[-2].keypoint_rms_m) < \
            config.sqp.keypoint_change * history[-2].keypoint_rms_m
        rule = ("step" if step < config.sqp.step_tolerance else
                "merit" if feasible and gain < config.sqp.merit_tolerance * phi else
                "settled" if step < config.sqp.settled_step and feasible
                and _settled(lin, plan, r, config) else
                "margins" if placed and kept and r.zmp_outside_m <= zmp_use
                and _settled(lin, plan, r, config, config.sqp.margin_use, zmp_use) else None)
        if rule is not None:
            log.info("whole-body solve stopped after iteration %d (SqpOptions rule: %s)",
                     it + 1, rule)
            converged = True
            break
        if slow:
            log.info("whole-body solve stopped after iteration %d: past %d iterations, the "
                     "merit fell by %.1f %% (SqpOptions.contact_gain %.0f %%)", it + 1,
                     config.sqp.iterations, 100.0 * gain / (phi + gain),
                     100.0 * config.sqp.contact_gain)
            break
    seconds["total"] = time.perf_counter() - t_all
    return WholeBodySolution(q=q, footprints=footprints, plan=plan, history=history,
                             converged=converged, seconds=seconds, config=config)
