"""What one SQP iteration works with: the plan it holds and the linearization of the iterate.

:class:`Plan` is fixed for the whole solve (targets, interaction-mesh metric, support,
footprints, support polygons, limits, which frames are held); :class:`Linearization` is
measured again at every iterate (key points, soles, CoM, ZMP and their Jacobians,
:func:`imesh.solve.sqp.linearize`). Every cost and constraint module reads these two.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..robot.capsules.obstacles import Obstacles
from .collision import CollisionLinearization
from .obstacles import ObstacleLinearization
from .props import PropLinearization
from .torque import TorqueLinearization
from .touches import ContactPoints

if TYPE_CHECKING:
    from .cwc import ConePlan

#: Gravity [m/s^2], as the evaluator's ZMP and normal force use it.
GRAVITY = 9.81


@dataclass(frozen=True, eq=False)
class Linearization:
    """Everything one SQP iteration needs at the current trajectory.

    Attributes:
        points: (T, K, 3) key points [m]; point_jacobians: (T, K, 3, nv).
        axes: (T, D, 3) world axes of the direction frames; axis_jacobians: (T, D, 3, nv)
            angular Jacobians of those frames.
        soles: (T, 2, 4, 4) sole frame poses [left, right]; sole_jacobians: (T, 2, 6, nv).
        corners: (T, 2, P, 3) [m] the feet's ground points (sole corners and the bottom of
            their collision proxies); corner_jacobians_z: (T, 2, P, nv) rows of their heights.
        body_z: (T, Q) [m] heights of the other leg proxies' points (shins, knees, ankle
            links); body_jacobians_z: (T, Q, nv) rows of their heights.
        com: (T, 3) [m]; com_jacobians: (T, 3, nv).
        com_acceleration: (T, 3) [m/s^2] and angular_momentum_rate: (T, 3) [Nm], the
            evaluator's: differences of the sampled CoM and angular momentum
            (:meth:`imesh.robot.Robot.centroidal_trajectory`).
        momentum_jacobians: (T, 3, 3, nv) derivative of the centroidal angular momentum
            ``k_t = Ag_ang(q_t) v_t`` (x, y, z) with respect to the tangent updates of the frames
            its velocity differences, ``prev(t), t, next(t)``
            (:func:`imesh.metrics.derivatives.velocity_jacobians`); mass: [kg].
        zmp_multibody: (T, 2) [m] the evaluator's multibody ZMP of the trajectory.
        base_rotations: (T, 3, 3) world rotations of the base.
        torques: the net joint torques and their working-set rows (None: not linearized).
        collision: the self-collision samples
            (:class:`imesh.solve.collision.CollisionLinearization`), or None.
        props: the samples of the robot's proxies against the scene's props
            (:class:`imesh.solve.props.PropLinearization`), or None (no props).
        held_points: (T, C, 3) [m] the points held on prop tops (:attr:`Plan.points`);
            held_jacobians: (T, C, 3, nv) their Jacobians; None without.
        obstacles: the samples of the robot's capsules against the plan's moving obstacles
            (:class:`imesh.solve.obstacles.ObstacleLinearization`), or None.
    """

    points: np.ndarray
    point_jacobians: np.ndarray
    axes: np.ndarray
    axis_jacobians: np.ndarray
    soles: np.ndarray
    sole_jacobians: np.ndarray
    corners: np.ndarray
    corner_jacobians_z: np.ndarray
    body_z: np.ndarray
    body_jacobians_z: np.ndarray
    com: np.ndarray
    com_jacobians: np.ndarray
    com_acceleration: np.ndarray
    angular_momentum_rate: np.ndarray
    momentum_jacobians: np.ndarray
    mass: float
    zmp_multibody: np.ndarray
    base_rotations: np.ndarray
    torques: TorqueLinearization | None = None
    collision: CollisionLinearization | None = None
    props: PropLinearization | None = None
    held_points: np.ndarray | None = None
    held_jacobians: np.ndarray | None = None
    obstacles: ObstacleLinearization | None = None


@dataclass(frozen=True, eq=False)
class Plan:
    """What the solve holds fixed: targets, support, footprints, limits.

    Attributes:
        marker_points: (T, K, 3) adapted marker positions of the key points [m].
        keypoint_weights: (K,) weights of the key points.
        mesh_metric: (T, K, K) ``W + w_L L_t^T L_t`` per frame.
        target_directions: (T, D, 3) unit target directions; direction_weights: (D,).
        support: (T, 2) bool planned support [left, right].
        sole_targets: (T, 2, 4, 4) footprint poses of the sole frames (NaN where not in
            support).
        halfplanes: (frame (R,), normal (R, 2), offset (R,)) of the support polygons.
        desired_zmp: (T, 2) [m].
        zmp_weights: (T,) w_z of the ZMP's band cost per frame
            (:func:`imesh.solve.zmp.band_weights`).
        q_init: (T, nq) the initializer.
        lower, upper, v_max, a_max: (n,) joint limits.
        fps: frame rate.
        rest_frames: the first and the last this many frames are held identical (the motion
            starts and ends at rest: zero velocity and acceleration for a controller); 0: free.
        clearance: (T, 2) [m] height the swing feet's ground points keep per frame (None:
            ``config.feet.clearance_m`` everywhere).
        fixed_frames: the first this many frames do not move (a window of a long clip starts
            on the previous window's solution: :mod:`imesh.solve.windows`).
        rest_ends: whether the rest rows (``rest_frames``) hold at the (start, end): a window
            has them only where it is the clip's start or end.
        q_start: (T, nq) the SQP's starting trajectory (None: ``q_init``, which stays the
            initializer the joints are pulled towards).
        fixed_end_frames: the last this many frames do not move either (the window joining
            two chains of windows solved in parallel ends on the second chain's solution:
            :mod:`imesh.solve.windows`).
        normal_max: (T,) largest total normal force per frame, times the weight (take-offs
            and landings allow more: ``ForceOptions.impact_normal``); None:
            ``config.forces.max_normal`` everywhere.
        kinetic: (T, 2) unit horizontal direction of the kinetic friction force where the only
            support slides (against the slide), NaN elsewhere; None: no slide.
        props: (P, K, 4) outward face planes ``(n, d)`` of the scene's convex props in the
            robot's world (``n . p <= d`` inside; :func:`imesh.solve.props.pad_planes`): no
            robot proxy enters them (:mod:`imesh.solve.props`); None: no props.
        points: the robot points held on prop tops where the person's hands and knees are
            on them (:mod:`imesh.solve.touches`), or None.
        cones: the frames balanced by the contact wrench cone instead of the ZMP, and their
            cones (:mod:`imesh.solve.cwc`), or None.
        obstacles: capsules moving with the frames (a partner robot's,
            :mod:`imesh.solve.obstacles`) that no capsule of the robot enters; None: none.
    """

    marker_points: np.ndarray
    keypoint_weights: np.ndarray
    mesh_metric: np.ndarray
    target_directions: np.ndarray
    direction_weights: np.ndarray
    support: np.ndarray
    sole_targets: np.ndarray
    halfplanes: tuple
    desired_zmp: np.ndarray
    zmp_weights: np.ndarray
    q_init: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    v_max: np.ndarray
    a_max: np.ndarray
    fps: float
    rest_frames: int = 0
    clearance: np.ndarray | None = None
    fixed_frames: int = 0
    rest_ends: tuple[bool, bool] = (True, True)
    q_start: np.ndarray | None = None
    fixed_end_frames: int = 0
    normal_max: np.ndarray | None = None
    kinetic: np.ndarray | None = None
    props: np.ndarray | None = None
    points: ContactPoints | None = None
    cones: ConePlan | None = None
    obstacles: Obstacles | None = None

    @property
    def supported(self) -> np.ndarray:
        """(T,) bool frames with a contact: a support foot or a held point."""
        sup = np.asarray(self.support.any(axis=1))
        return sup if self.points is None else sup | self.points.active.any(axis=1)

    @property
    def flight(self) -> np.ndarray:
        """(T,) bool frames without any contact: the body flies."""
        return ~self.supported
