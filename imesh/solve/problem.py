"""The QP of one whole-body SQP iteration (DESIGN.md, "Whole-body spacetime solve").

Unknowns: the tangent update ``dq_t`` (base twist in the base frame, joint increments; nv per
frame) of every frame t, ordered frame by frame, so every term couples at most frames t-2..t+2
and the QP is banded. Linearized at the current trajectory ``q_t`` with pinocchio Jacobians:

Objective (weights in :class:`WholeBodyConfig`):

* interaction mesh + key points: ``sum_t e_t^T (W_t + w_L L_t^T L_t) e_t`` with
  ``e_t = X_t + J_X dq_t - M_t`` the key points' offsets from the adapted markers, ``W_t`` their
  squared weights (Nakaoka eq. 7-8) and ``L_t`` the Laplacian of the frame's interaction mesh
  over the key-point markers (Nakaoka eq. 1-2; ``E_L`` measured on the robot's key points);
* directions: ``w_d^2 |u_t - d_t - [u_t]x J_w dq_t|^2`` (the key directions of the fit);
* smoothness: ``w_a |Delta^2 y|^2`` of the world-aligned coordinates ``y`` (base position, the
  base's accumulated rotation vector, joints), second differences at 30 fps;
* ZMP: ``w_z |b_t|^2`` on the ZMP's excess over a dead band around the desired ZMP (sole
  centre, hull centre): ``|p_t - p*_t| <= band + b_t`` per axis;
* ``w_r |dq|^2`` (step damping) and ``w_i |q_j + dq_j - q_init,j|^2`` (pull to the
  initializer, joints).

Constraints:

* support soles: ``J_f dq_t = [p_F - p_f; log(R_F R_f^T)]`` (6 rows per support foot and frame);
* swing soles: every ground point of the foot ``z + J_z dq_t >= 0``;
  (both elastic: an exact L1 penalty on one slack per foot and frame keeps every linearization
  solvable; the slack vanishes where the constraints can be met);
* joints: position bounds; ``|Delta q| <= v_max dt``; ``|Delta^2 q| <= a_max dt^2`` (elastic,
  one slack per frame);
* normal force: ``min_normal g <= g + c_z'' <= max_normal g`` (elastic); in flight frames
  ``c_z'' = -g``;
* friction: ``|c_a''| <= (mu / sqrt 2) (g + c_z'')`` for a = x, y in support frames (elastic):
  the ground's total force ``m (c'' - g)`` in the friction pyramid;
* joint torques: ``|P_t tau_t| <= (1 - torque_margin) effort`` on the frames and joints above
  70 % of it (elastic; inverse dynamics with the base wrench split between the support soles,
  the evaluator's ``torque_ratio_ref``; :mod:`.torque`);
* ZMP (cart-table with the evaluator's difference operator ``D`` = gradient of gradient):
  ``p_t = c_xy,t - (c_z,t / g) (D c)_xy,t + delta_t`` inside the support polygon shrunk by
  ``zmp_margin_m``, where ``delta_t`` is the multibody ZMP minus the cart-table ZMP at the
  current iterate (Nishiwaki's correction idea in joint space: at convergence the constraint
  holds for the multibody ZMP the evaluator computes).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from ..errors import OptionError
from .qp import SOLVERS, QpProblem

if TYPE_CHECKING:
    from .collision import CollisionLinearization
    from .torque import TorqueLinearization

GRAVITY = 9.81


@dataclass(frozen=True)
class WholeBodyConfig:
    """Settings of the whole-body solve.

    Attributes:
        iterations: largest number of SQP iterations.
        step_tolerance: stop when no coordinate of the update exceeds this [m or rad] ...
        merit_tolerance: ... or when the constraints hold (soles within 1 mm, ZMP and swing
            feet within 1 mm of their bounds) and an iteration lowered the merit by less than
            this fraction.
        mesh_weight: w_L, weight of the interaction-mesh (Laplacian) energy of the key points.
        direction_weight: multiplies the key directions' weights.
        accel_weight: w_a, weight of the squared second differences (at 30 fps) of the base and
            joint coordinates [per (m or rad)^2].
        zmp_weight: w_z, weight of the squared distance of the ZMP beyond ``zmp_band_m`` from
            the desired ZMP (per axis) [1/m^2].
        zmp_band_m: a dead band around the desired ZMP [m]: a ZMP already within it costs
            nothing, so a balanced motion is left as it is.
        damping: w_r, weight of |dq|^2 in every iteration.
        init_weight: w_i, pull of the joints towards the initializer.
        zmp_margin_m: the support polygon is shrunk by this much [m].
        velocity_margin, acceleration_margin: the limits are used times (1 - margin), so the
            written motion meets them with room for rounding.
        clearance_m: swing-sole corners stay this high above the ground [m].
        swing_lift_m: over the middle third of a swing between two support phases of a foot,
            its ground points stay this high [m]: a step is a step (the evaluator, like a
            controller, tells phases apart by the sole leaving the ground).
        swing_edge_m: in every other frame of such a swing the ground points stay this high
            [m]: the sole leaves and lands flat instead of rolling over its toe or heel (the
            footprint model has no rolling contact).
        zmp_slack_weight: price of the ZMP constraints' slack per metre (an exact penalty:
            above the multipliers of a feasible problem the slack is 0 where it can be).
        elastic_weight: price per metre (or radian) of the slack of the sole and ground
            constraints: an exact penalty, so a linearization that cannot put a sole on its
            footprint at once (the initializer far from it) still has a solution that moves
            towards it; at a feasible point the slack is 0.
        min_normal: the total normal force stays above this fraction of the weight
            (``g + c_z'' >= min_normal g``): the ground cannot pull, and a tracking controller
            whose feet carry less than this at a push-off leaves the ground.
        max_normal: ... and below this fraction (``g + c_z'' <= max_normal g``): the support
            joints carry at most this times the weight (a human walk stays within about 0.7
            and 1.3).
        friction: mu of the friction cone the ground's total horizontal force stays in (the
            evaluator's ``friction_ratio_max`` uses the same mu); 0: no friction rows.
        torque_margin: the net joint torques (inverse dynamics, the base wrench split between
            the support soles as the evaluator's ``torque_ratio_ref``) stay within
            ``1 - torque_margin`` of the effort limits (elastic rows, :mod:`.torque`); 1: no
            torque rows.
        trust_region: largest change of any base or joint coordinate in one iteration [m or
            rad], so the linearization stays valid.
        base_trust: the base translation's region is this fraction of ``trust_region`` [m].
        initial_lowpass_hz: cut-off of the low-pass applied to the initial fit before the
            solve [Hz] (:func:`imesh.solve.initial.smooth_initializer`).
        solver: QP solver, one of :data:`imesh.solve.qp.SOLVERS`.
        qp_tolerance: absolute tolerance of each QP solve.
        self_collision: keep the robot's capsules apart (docs/collision.md): every checked
            pair closer than ``collision_activation_m`` gets a row ``d + J dq >= margin``.
        collision_margin_m: the signed distance the capsules keep [m].
        collision_activation_m: pairs closer than this at the iterate get a row [m].
    """

    iterations: int = 20
    step_tolerance: float = 1e-4
    merit_tolerance: float = 3e-2
    mesh_weight: float = 1.0
    direction_weight: float = 1.0
    accel_weight: float = 3.0
    zmp_weight: float = 10.0
    zmp_band_m: float = 0.015
    damping: float = 1e-3
    init_weight: float = 1e-2
    zmp_margin_m: float = 0.01
    velocity_margin: float = 1e-3
    acceleration_margin: float = 1e-3
    clearance_m: float = 0.0
    swing_lift_m: float = 0.03
    swing_edge_m: float = 0.02
    zmp_slack_weight: float = 1e3
    elastic_weight: float = 1e4
    min_normal: float = 0.7
    max_normal: float = 1.3
    friction: float = 0.7
    torque_margin: float = 0.05
    trust_region: float = 0.3
    base_trust: float = 0.2
    initial_lowpass_hz: float = 4.0
    solver: str = "piqp"
    qp_tolerance: float = 1e-7
    self_collision: bool = True
    collision_margin_m: float = 0.005
    collision_activation_m: float = 0.02

    def __post_init__(self) -> None:
        if not (isinstance(self.iterations, int) and self.iterations >= 1):
            raise OptionError("iterations", self.iterations, "an integer >= 1")
        for name in ("step_tolerance", "qp_tolerance", "merit_tolerance"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise OptionError(name, getattr(self, name), "a positive number")
        for name in ("mesh_weight", "direction_weight", "accel_weight", "zmp_weight", "damping",
                     "init_weight", "zmp_margin_m", "velocity_margin", "acceleration_margin",
                     "clearance_m", "swing_lift_m", "swing_edge_m", "zmp_slack_weight",
                     "elastic_weight", "zmp_band_m", "trust_region", "initial_lowpass_hz",
                     "base_trust", "min_normal", "max_normal", "friction", "torque_margin",
                     "collision_activation_m"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise OptionError(name, value, "a non-negative number")
        if self.torque_margin > 1:
            raise OptionError("torque_margin", self.torque_margin, "a number in [0, 1]")
        if self.max_normal < self.min_normal:
            raise OptionError("max_normal", self.max_normal,
                              f"a number >= min_normal ({self.min_normal})")
        if self.solver not in SOLVERS:
            raise OptionError("solver", self.solver, SOLVERS)


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
        com_acceleration: (T, 3) [m/s^2] and angular_momentum_rate: (T, 3) [Nm] from
            pinocchio with the evaluator's finite-difference velocities and accelerations.
        centroidal_angular: (T, 2, nv) x, y rows of the centroidal momentum matrix's angular
            part; mass: [kg].
        zmp_multibody: (T, 2) [m] the evaluator's multibody ZMP of the trajectory.
        base_rotations: (T, 3, 3) world rotations of the base.
        torques: the net joint torques and their working-set rows (None: not linearized).
        collision: the self-collision samples
            (:class:`imesh.solve.collision.CollisionLinearization`), or None.
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
    centroidal_angular: np.ndarray
    mass: float
    zmp_multibody: np.ndarray
    base_rotations: np.ndarray
    torques: TorqueLinearization | None = None
    collision: CollisionLinearization | None = None


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
        q_init: (T, nq) the initializer.
        lower, upper, v_max, a_max: (n,) joint limits.
        fps: frame rate.
        rest_frames: the first and the last this many frames are held identical (the motion
            starts and ends at rest: zero velocity and acceleration for a controller); 0: free.
        clearance: (T, 2) [m] height the swing feet's ground points keep per frame (None:
            ``config.clearance_m`` everywhere).
        fixed_frames: the first this many frames do not move (a window of a long clip starts
            on the previous window's solution: :mod:`imesh.solve.windows`).
        rest_ends: whether the rest rows (``rest_frames``) hold at the (start, end): a window
            has them only where it is the clip's start or end.
        q_start: (T, nq) the SQP's starting trajectory (None: ``q_init``, which stays the
            initializer the joints are pulled towards).
        fixed_end_frames: the last this many frames do not move either (the window joining
            two chains of windows solved in parallel ends on the second chain's solution:
            :mod:`imesh.solve.windows`).
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


def held_frames(plan: Plan, n_frames: int) -> np.ndarray:
    """(H,) int frames of a window that do not move: its first ``plan.fixed_frames`` and last
    ``plan.fixed_end_frames`` (:mod:`imesh.solve.windows`)."""
    frames = np.arange(n_frames)
    return frames[(frames < plan.fixed_frames) | (frames >= n_frames - plan.fixed_end_frames)]


def gradient_operator(n: int, h: float) -> sp.csr_matrix:
    """(n, n) sparse matrix of ``numpy.gradient`` with spacing h (central inside, one-sided
    first order at the ends), so ``D @ x == np.gradient(x, h)``."""
    if n < 2:
        return sp.csr_matrix((n, n))
    rows = np.r_[0, 0, np.repeat(np.arange(1, n - 1), 2), n - 1, n - 1]
    cols = np.r_[0, 1, np.stack([np.arange(0, n - 2), np.arange(2, n)], 1).ravel(), n - 2, n - 1]
    vals = np.r_[-1.0, 1.0, np.tile([-0.5, 0.5], n - 2), -1.0, 1.0] / h
    return sp.csr_matrix((vals, (rows, cols)), shape=(n, n))


def difference_operator(n: int, order: int) -> sp.csr_matrix:
    """((n - order), n) sparse forward difference of the given order (1 or 2)."""
    stencil = {1: [-1.0, 1.0], 2: [1.0, -2.0, 1.0]}[order]
    m = n - order
    rows = np.repeat(np.arange(m), len(stencil))
    cols = (np.arange(m)[:, None] + np.arange(len(stencil))).ravel()
    return sp.csr_matrix((np.tile(stencil, m), (rows, cols)), shape=(m, n))


def block_diagonal(blocks: np.ndarray) -> sp.csr_matrix:
    """(T*r, T*c) sparse block diagonal of dense blocks (T, r, c), from index arrays."""
    T, r, c = blocks.shape
    rows = (np.arange(T)[:, None, None] * r + np.arange(r)[None, :, None]) + 0 * np.arange(c)
    cols = (np.arange(T)[:, None, None] * c + np.arange(c)[None, None, :]) + 0 * rows
    return sp.csr_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())), shape=(T * r, T * c))


def _rows_at(frames: np.ndarray, rows: np.ndarray, stride: int, n_frames: int,
             first: int = 0) -> sp.csr_matrix:
    """(R, T*stride) sparse matrix whose row r is ``rows[r]`` (w,) at the columns
    ``frames[r] * stride + first + [0, w)``."""
    R, w = rows.shape
    cols = frames[:, None] * stride + first + np.arange(w)
    return sp.csr_matrix((rows.ravel(), (np.repeat(np.arange(R), w), cols.ravel())),
                         shape=(R, n_frames * stride))


def _log3(R: np.ndarray) -> np.ndarray:
    """(N, 3) rotation vectors of rotation matrices (N, 3, 3)."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(R).as_rotvec()


def world_map(rotations: np.ndarray, nv: int) -> np.ndarray:
    """(T, nv, nv) maps of a tangent update (base twist in the base frame, joints) to the change
    of :func:`world_coordinates`: ``blockdiag(R_t, R_t, I)``."""
    out = np.zeros((len(rotations), nv, nv))
    out[:, :3, :3] = rotations
    out[:, 3:6, 3:6] = rotations
    out[:, np.arange(6, nv), np.arange(6, nv)] = 1.0
    return out


def world_coordinates(q: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """(T, nv) coordinates whose second differences measure accelerations: base position,
    the base's accumulated world rotation vector, joints."""
    T = len(q)
    steps = _log3(rotations[1:] @ np.transpose(rotations[:-1], (0, 2, 1)))  # world increments
    phi = np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)]) if T else np.zeros((0, 3))
    return np.concatenate([q[:, :3], phi, q[:, 7:]], axis=1)


def build_qp(lin: Linearization, plan: Plan, q: np.ndarray, config: WholeBodyConfig
             ) -> QpProblem:
    """The QP of one SQP iteration at the trajectory ``q`` (T, nq); see the module docstring.

    Returns:
        QpProblem over x = (x_0, ..., x_{T-1}) with x_t = (dq_t (nv), dc_t (3), dk_t (2), s_t):
        the tangent update, the CoM update ``dc_t = J_c dq_t`` and the horizontal centroidal
        angular momentum update ``dk_t`` (auxiliaries that keep the ZMP rows sparse: written in
        dq they would couple whole 35-column blocks over 9 frames), then the slacks of the
        elastic rows (ZMP polygon, soles, ground, accelerations, ZMP band, torques,
        self-collision; each ``>= 0`` and priced linearly, an exact L1 penalty, so a
        linearization whose rows cannot be met still has a solution; at a feasible point they
        are 0).
    """
    T, K = lin.points.shape[:2]
    nv = lin.point_jacobians.shape[-1]
    nx = nv + 14
    n_j = nv - 6
    N = T * nx
    h = 1.0 / plan.fps
    # offsets in a frame's block: dc, dk, the ZMP slack, the two soles' slacks, the ground's
    # and the acceleration rows'
    # and the acceleration rows', then the ZMP's excess over its dead band (x, y)
    # then the torque rows' and the self-collision rows' slacks
    C0, K0, S0, F0, G0, A0, B0, Q0, X0 = (nv, nv + 3, nv + 5, nv + 6, nv + 8, nv + 9, nv + 10,
                                          nv + 12, nv + 13)

    # --- per-frame blocks: key points + interaction mesh, directions, damping ------------------
    Jp = lin.point_jacobians.reshape(T, K, 3 * nv)
    e = lin.points - plan.marker_points  # (T, K, 3)
    GJ = np.matmul(plan.mesh_metric, Jp).reshape(T, K * 3, nv)
    Jflat = lin.point_jacobians.reshape(T, K * 3, nv)
    H = np.zeros((T, nx, nx))
    g = np.zeros((T, nx))
    H[:, :nv, :nv] = np.matmul(np.transpose(Jflat, (0, 2, 1)), GJ)
    Ge = np.matmul(plan.mesh_metric, e).reshape(T, K * 3)
    g[:, :nv] = np.einsum("tri,tr->ti", Jflat, Ge)
    if lin.axes.shape[1]:
        u = lin.axes
        Jw = lin.axis_jacobians  # (T, D, 3, nv): du = omega x u = -u x omega
        Ad = -np.cross(u[..., None, :], np.swapaxes(Jw, -1, -2)).swapaxes(-1, -2)
        w = (config.direction_weight * plan.direction_weights) ** 2
        r = u - plan.target_directions
        H[:, :nv, :nv] += np.einsum("tdan,d,tdam->tnm", Ad, w, Ad)
        g[:, :nv] += np.einsum("tdan,d,tda->tn", Ad, w, r)
    H[:, np.arange(nv), np.arange(nv)] += config.damping
    H[:, np.arange(6, nv), np.arange(6, nv)] += config.init_weight
    g[:, 6:nv] += config.init_weight * (q[:, 7:] - plan.q_init[:, 7:])
    g[:, S0] = config.zmp_slack_weight
    g[:, F0:F0 + 2] = config.elastic_weight
    g[:, G0] = config.elastic_weight
    g[:, A0] = config.elastic_weight
    g[:, Q0] = config.zmp_slack_weight
    g[:, X0] = config.elastic_weight
    P = block_diagonal(H)
    c = g.ravel()

    # --- smoothness: second differences of world-aligned coordinates -------------------------
    if T >= 3 and config.accel_weight > 0:
        Rb = lin.base_rotations
        S = np.zeros((T, nv, nx))
        S[:, :, :nv] = world_map(Rb, nv)
        scale = (plan.fps / 30.0) ** 2
        D2 = sp.kron(difference_operator(T, 2), sp.identity(nv), format="csr") * scale
        A_s = D2 @ block_diagonal(S)
        r_s = D2 @ world_coordinates(q, Rb).ravel()
        P = P + config.accel_weight * (A_s.T @ A_s)
        c = c + config.accel_weight * (A_s.T @ r_s)

    # --- ZMP: the multibody ZMP linearized in the CoM and angular-momentum auxiliaries -------
    # p_x = c_x - N_x / Dn, p_y = c_y - N_y / Dn with N_x = c_z a_x + Ld_y / m,
    # N_y = c_z a_y - Ld_x / m, Dn = a_z + g; a = Dacc c (the evaluator's operator: gradient of
    # gradient), Ld = grad(k) with k the centroidal angular momentum, dk = Ag_ang grad(dq).
    grad = gradient_operator(T, h)
    Dacc = (grad @ grad).tocsr()
    com, acc, ld, m = lin.com, lin.com_acceleration, lin.angular_momentum_rate, lin.mass
    cz = com[:, 2]
    Dn = acc[:, 2] + GRAVITY
    Nx = cz * acc[:, 0] + ld[:, 1] / m
    Ny = cz * acc[:, 1] - ld[:, 0] / m

    def pick(offset: int) -> sp.csr_matrix:  # (T, N) selects one auxiliary of every frame
        return sp.csr_matrix((np.ones(T), (np.arange(T), np.arange(T) * nx + offset)),
                             shape=(T, N))

    cx, cy, czs, kx, ky = (pick(C0), pick(C0 + 1), pick(C0 + 2), pick(K0), pick(K0 + 1))
    dg = sp.diags
    acc_z = Dacc @ czs
    Zx = (cx - dg(acc[:, 0] / Dn) @ czs - dg(cz / Dn) @ Dacc @ cx
          - dg(1.0 / (m * Dn)) @ grad @ ky + dg(Nx / Dn ** 2) @ acc_z)
    Zy = (cy - dg(acc[:, 1] / Dn) @ czs - dg(cz / Dn) @ Dacc @ cy
          + dg(1.0 / (m * Dn)) @ grad @ kx + dg(Ny / Dn ** 2) @ acc_z)
    order = np.argsort(np.r_[2 * np.arange(T), 2 * np.arange(T) + 1], kind="stable")
    Z = sp.vstack([Zx, Zy], format="csr")[order]  # rows x_0, y_0, x_1, y_1, ...
    p0 = lin.zmp_multibody
    sup = plan.support.any(axis=1)
    band_rows = None
    if config.zmp_weight > 0 and sup.any():
        # |p0 + Z x - p*| <= band + b (per axis), cost w_z b^2 on the excess b
        rows = np.flatnonzero(np.repeat(sup, 2))
        r_z = (p0 - plan.desired_zmp).ravel()[rows]
        excess = sp.csr_matrix((np.ones(len(rows)), (np.arange(len(rows)),
                                                     (rows // 2) * nx + B0 + rows % 2)),
                               shape=(len(rows), N))
        band_rows = (Z[rows], excess, r_z)
        diag = np.zeros(N)
        diag[(np.flatnonzero(sup)[:, None] * nx + B0 + np.arange(2)).ravel()] = config.zmp_weight
        P = P + sp.diags(diag)

    # --- equalities: CoM auxiliaries; support soles on their footprints -----------------------
    frames_all = np.arange(T)
    eq = [_rows_at(np.repeat(frames_all, 3), lin.com_jacobians.reshape(-1, nv), nx, T)
          - _rows_at(np.repeat(frames_all, 3), np.tile(np.eye(3), (T, 1)), nx, T, C0)]
    rhs = [np.zeros(3 * T)]
    # dk_t = Ag_ang,t (x, y rows) sum_s grad_ts dq_s  (velocity perturbation of frame t)
    gc = grad.tocoo()
    vals = gc.data[:, None, None] * lin.centroidal_angular[gc.row]  # (nnz, 2, nv)
    rows = (2 * gc.row[:, None, None] + np.arange(2)[None, :, None]) + 0 * np.arange(nv)
    cols = (gc.col[:, None, None] * nx + np.arange(nv)[None, None, :]) + 0 * rows
    Mk = sp.csr_matrix((vals.ravel(), (rows.ravel(), cols.ravel())), shape=(2 * T, N))
    eq.append(_rows_at(np.repeat(frames_all, 2), np.tile(np.eye(2), (T, 1)), nx, T, K0) - Mk)
    rhs.append(np.zeros(2 * T))
    # rest at both ends: world coordinates of frames t and t+1 equal (first and last frames)
    if plan.rest_frames > 1 and T >= 2 * plan.rest_frames:
        Rb = lin.base_rotations
        Sb = world_map(Rb, nv)
        y = world_coordinates(q, Rb)
        k = plan.rest_frames - 1
        start, end = plan.rest_ends
        for t in [*range(k if start else 0), *range(T - 1 - k, T - 1 if end else T - 1 - k)]:
            rows_now = _rows_at(np.full(nv, t), Sb[t], nx, T)
            rows_next = _rows_at(np.full(nv, t + 1), Sb[t + 1], nx, T)
            eq.append(rows_next - rows_now)
            rhs.append(y[t] - y[t + 1])
    # frames held at the previous window's (and a join window's last at the next chain's)
    # solution: dq_t = 0 as equality rows (as equal bounds they cost the interior point
    # 60-250 iterations instead of 25)
    fixed = held_frames(plan, T)
    if len(fixed):
        eq.append(_rows_at(np.repeat(fixed, nv), np.tile(np.eye(nv), (len(fixed), 1)), nx, T))
        rhs.append(np.zeros(len(fixed) * nv))
    A = sp.vstack(eq, format="csc")
    b = np.concatenate(rhs)

    # --- inequalities --------------------------------------------------------------------------
    G_blocks, lo, hi = [], [], []
    # support soles on their footprints, elastic: |J_f dq_t - e_t| <= s_f,t (each of 6 rows)
    ts, ks, err = sole_errors(lin, plan)
    if len(ts):
        e = err.ravel()
        rows = _rows_at(np.repeat(ts, 6), lin.sole_jacobians[ts, ks].reshape(-1, nv), nx, T)
        slack = sp.csr_matrix((np.ones(len(e)), (np.arange(len(e)),
                                                 np.repeat(ts * nx + F0 + ks, 6))),
                              shape=(len(e), N))
        G_blocks += [rows - slack, rows + slack]
        lo += [np.full(len(e), -np.inf), e]
        hi += [e, np.full(len(e), np.inf)]
    # swing-sole corners above the ground
    tt, kk = np.nonzero(~plan.support)
    if len(tt):
        z = lin.corners[tt, kk, :, 2].ravel()
        n_pts = lin.corners.shape[2]
        clear = _clearance(plan, config)[tt, kk]
        G_blocks.append(_rows_at(np.repeat(tt, n_pts),
                                 lin.corner_jacobians_z[tt, kk].reshape(-1, nv), nx, T)
                        + _rows_at(np.repeat(tt, n_pts), np.ones((len(z), 1)), nx, T, G0))
        lo.append(np.repeat(clear, n_pts) - z)
        hi.append(np.full(len(z), np.inf))
    # the other leg proxies' points near the ground stay above it (elastic, the ground slack)
    tb, qb = np.nonzero(lin.body_z < 0.05)
    if len(tb):
        rows = lin.body_jacobians_z[tb, qb]
        G_blocks.append(_rows_at(tb, rows, nx, T)
                        + _rows_at(tb, np.ones((len(tb), 1)), nx, T, G0))
        lo.append(-lin.body_z[tb, qb])
        hi.append(np.full(len(tb), np.inf))
    # joint velocity and acceleration
    sel = sp.csr_matrix((np.ones(T * n_j), (np.arange(T * n_j),
                                             (np.arange(T)[:, None] * nx + 6
                                              + np.arange(n_j)).ravel())), shape=(T * n_j, N))
    qj = q[:, 7:]
    for n_diff, limit, margin in ((1, plan.v_max * h, config.velocity_margin),
                                  (2, plan.a_max * h * h, config.acceleration_margin)):
        if T <= n_diff:
            continue
        D = sp.kron(difference_operator(T, n_diff), sp.identity(n_j), format="csr") @ sel
        lim = np.tile(limit * (1 - margin), T - n_diff)
        d = np.diff(qj, n=n_diff, axis=0).ravel()
        finite = np.isfinite(lim)
        if n_diff == 2:  # elastic (one slack per frame): the lead-in's start from rest
            centre = np.repeat(np.arange(1, T - 1), n_j)
            slack = _rows_at(centre, np.ones((len(centre), 1)), nx, T, A0)
            G_blocks += [(D - slack)[finite], (D + slack)[finite]]
            lo += [np.full(int(finite.sum()), -np.inf), (-lim - d)[finite]]
            hi += [(lim - d)[finite], np.full(int(finite.sum()), np.inf)]
            continue
        G_blocks.append(D[finite])
        lo.append((-lim - d)[finite])
        hi.append((lim - d)[finite])
    # net joint torques within the effort limits on the working set (ratio units, elastic:
    # |r + C dq| <= 1 - margin + s_t), :mod:`.torque`
    trq = lin.torques
    if trq is not None and len(trq.frames):
        R, W = trq.columns.shape
        rows = sp.csr_matrix((trq.coefficients.ravel(),
                              (np.repeat(np.arange(R), W * nv),
                               (trq.columns[:, :, None] * nx + np.arange(nv)).ravel())),
                             shape=(R, N))
        slack = sp.csr_matrix((np.ones(R), (np.arange(R), trq.frames * nx + Q0)), shape=(R, N))
        r0 = trq.values
        bound = 1.0 - config.torque_margin
        G_blocks += [rows - slack, rows + slack]
        lo += [np.full(R, -np.inf), -bound - r0]
        hi += [bound - r0, np.full(R, np.inf)]
    # ZMP inside the shrunk support polygons: n . (p0 + Z x) + s_t >= b + margin
    hp_frame, hp_n, hp_b = plan.halfplanes
    if len(hp_frame):
        R = len(hp_frame)
        Nmat = sp.csr_matrix((hp_n.ravel(), (np.repeat(np.arange(R), 2),
                                              (hp_frame[:, None] * 2 + np.arange(2)).ravel())),
                             shape=(R, 2 * T))
        slack = sp.csr_matrix((np.ones(R), (np.arange(R), hp_frame * nx + S0)), shape=(R, N))
        G_blocks.append(Nmat @ Z + slack)
        lo.append(hp_b + config.zmp_margin_m - np.sum(hp_n * p0[hp_frame], axis=1))
        hi.append(np.full(R, np.inf))
    if band_rows is not None:
        Zs, excess, r_z = band_rows
        G_blocks += [Zs - excess, Zs + excess]
        lo += [np.full(len(r_z), -np.inf), -config.zmp_band_m - r_z]
        hi += [config.zmp_band_m - r_z, np.full(len(r_z), np.inf)]
    # the ground only pushes: normal force m (g + c_z'') >= min_normal m g (also keeps the
    # ZMP's denominator away from 0, where its linearization means nothing); in flight there is
    # no ground: the CoM falls, c_z'' = -g. Both elastic.
    vert = (acc_z + pick(S0)).tocsr()
    flight = ~sup
    G_blocks += [vert[sup], (acc_z - pick(S0)).tocsr()[sup]]
    lo += [((config.min_normal - 1.0) * GRAVITY - acc[:, 2])[sup],
           np.full(int(sup.sum()), -np.inf)]
    hi += [np.full(int(sup.sum()), np.inf),
           ((config.max_normal - 1.0) * GRAVITY - acc[:, 2])[sup]]
    # friction: the ground's horizontal force m c_xy'' within the cone of its normal force,
    # |c_a''| <= mu' (g + c_z'') per horizontal axis (mu' = mu / sqrt 2, the pyramid inside the
    # cone); exact for the total force, so for the sole's force in single support (elastic)
    if config.friction > 0 and sup.any():
        mu = config.friction / np.sqrt(2.0)
        n_sup = int(sup.sum())
        for axis, aux in ((0, cx), (1, cy)):
            acc_a = Dacc @ aux
            for sign in (1.0, -1.0):
                G_blocks.append((sign * acc_a - mu * acc_z - pick(S0)).tocsr()[sup])
                lo.append(np.full(n_sup, -np.inf))
                hi.append((mu * (GRAVITY + acc[:, 2]) - sign * acc[:, axis])[sup])
    if flight.any():
        down = (acc_z - pick(S0)).tocsr()[flight]
        G_blocks += [vert[flight], down]
        lo += [(-GRAVITY - acc[:, 2])[flight], np.full(int(flight.sum()), -np.inf)]
        hi += [np.full(int(flight.sum()), np.inf), (-GRAVITY - acc[:, 2])[flight]]
    if lin.collision is not None and len(lin.collision.frames):
        from .collision import collision_qp_rows

        rows, low, high = collision_qp_rows(lin.collision, T, nx, X0, config.collision_margin_m)
        G_blocks.append(rows)
        lo.append(low)
        hi.append(high)
    G = sp.vstack(G_blocks, format="csc") if G_blocks else sp.csc_matrix((0, N))
    # bounds: joint positions, a trust region on the update, slack >= 0
    x_l = np.full((T, nx), -np.inf)
    x_u = np.full((T, nx), np.inf)
    x_l[:, :nv], x_u[:, :nv] = -config.trust_region, config.trust_region
    # the base's translation moves every link: its vertical second difference enters the ZMP's
    # denominator (g + c_z''), so it gets a tighter region
    x_l[:, :3], x_u[:, :3] = -config.trust_region * config.base_trust, \
        config.trust_region * config.base_trust
    x_l[:, 6:nv] = np.maximum(plan.lower - qj, -config.trust_region)
    x_u[:, 6:nv] = np.minimum(plan.upper - qj, config.trust_region)
    x_l[:, S0:] = 0.0
    P = ((P + P.T) * 0.5).tocsc()
    low = np.concatenate(lo) if lo else np.zeros(0)
    high = np.concatenate(hi) if hi else np.zeros(0)
    if len(fixed) and G.shape[0]:
        # rows in the fixed frames' unknowns only are constants (their one-sided differences
        # met by slack, at a constant price): without them the interior point takes 25
        # iterations instead of 60-250
        free = np.ones(T, dtype=bool)
        free[fixed] = False
        touches = (abs(G) @ np.repeat(free, nx).astype(float)) > 0
        G, low, high = G[touches], low[touches], high[touches]
    return QpProblem(P=P, c=np.asarray(c).ravel(), A=A, b=b, G=G, l=low, u=high,
                     x_l=x_l.ravel(), x_u=x_u.ravel())


def sole_errors(lin: Linearization, plan: Plan) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each support sole is off its footprint.

    Returns:
        (frames (N,), feet (N,), errors (N, 6)) over the support samples: ``[p_F - p_f,
        log(R_F R_f^T)]``, the world translation [m] and rotation vector [rad] that would put
        the sole frame on its footprint (the right-hand side of the sole rows).
    """
    tt, kk = np.nonzero(plan.support)
    cur, tgt = lin.soles[tt, kk], plan.sole_targets[tt, kk]
    dp = tgt[:, :3, 3] - cur[:, :3, 3]
    dr = _log3(tgt[:, :3, :3] @ np.transpose(cur[:, :3, :3], (0, 2, 1))) if len(tt) \
        else np.zeros((0, 3))
    return tt, kk, np.concatenate([dp, dr], axis=1)


def _clearance(plan: Plan, config: WholeBodyConfig) -> np.ndarray:
    if plan.clearance is not None:
        return plan.clearance
    return np.full(plan.support.shape, config.clearance_m)


def merit(lin: Linearization, plan: Plan, q: np.ndarray, config: WholeBodyConfig) -> float:
    """The exact-penalty merit of a trajectory: the QP's objective terms evaluated on the
    nonlinear trajectory (``1/2 sum w |r|^2``) plus the slack prices times the violations the
    slacks would have to cover (ZMP outside the shrunk polygon, soles off their footprints,
    swing ground points below the clearance). An SQP step is accepted when it lowers this.
    """
    e = lin.points - plan.marker_points
    f = np.einsum("tka,tkl,tla->", e, plan.mesh_metric, e)
    if lin.axes.shape[1]:
        w = (config.direction_weight * plan.direction_weights) ** 2
        f += np.einsum("d,tda->", w, (lin.axes - plan.target_directions) ** 2)
    f += config.init_weight * np.sum((q[:, 7:] - plan.q_init[:, 7:]) ** 2)
    T = len(q)
    if T >= 3 and config.accel_weight > 0:
        y = world_coordinates(q, lin.base_rotations)
        f += config.accel_weight * np.sum((np.diff(y, 2, axis=0) * (plan.fps / 30.0) ** 2) ** 2)
    sup = plan.support.any(axis=1)
    over = np.maximum(np.abs(lin.zmp_multibody - plan.desired_zmp)[sup] - config.zmp_band_m, 0)
    f += config.zmp_weight * np.sum(over ** 2)
    penalty = 0.0
    hp_frame, hp_n, hp_b = plan.halfplanes
    if len(hp_frame):
        out = hp_b + config.zmp_margin_m - np.sum(hp_n * lin.zmp_multibody[hp_frame], axis=1)
        worst = np.zeros(T)
        np.maximum.at(worst, hp_frame, out)
        penalty += config.zmp_slack_weight * np.sum(np.maximum(worst, 0.0))
    _, _, err = sole_errors(lin, plan)
    penalty += config.elastic_weight * np.sum(np.abs(err).max(axis=1, initial=0.0))
    tt, kk = np.nonzero(~plan.support)
    if len(tt):
        short = _clearance(plan, config)[tt, kk] - lin.corners[tt, kk, :, 2].min(axis=1)
        worst = np.zeros(T)
        np.maximum.at(worst, tt, short)
        penalty += config.elastic_weight * np.sum(np.maximum(worst, 0.0))
    if lin.body_z.shape[1]:
        penalty += config.elastic_weight * np.sum(np.maximum(-lin.body_z.min(axis=1), 0.0))
    az = lin.com_acceleration[:, 2]
    penalty += config.zmp_slack_weight * (
        np.sum(np.maximum((config.min_normal - 1.0) * GRAVITY - az[sup], 0.0))
        + np.sum(np.maximum(az[sup] - (config.max_normal - 1.0) * GRAVITY, 0.0))
        + (np.sum(np.maximum(np.abs(lin.com_acceleration[sup, :2]).max(axis=1)
                             - config.friction / np.sqrt(2.0) * (GRAVITY + az[sup]), 0.0))
           if config.friction > 0 else 0.0)
        + np.sum(np.abs(az[~sup] + GRAVITY)))
    if lin.torques is not None:
        penalty += config.zmp_slack_weight * np.sum(lin.torques.excess(1.0 - config.torque_margin))
    over = np.abs(np.diff(q[:, 7:], 2, axis=0)) - plan.a_max * (1.0 / plan.fps) ** 2 * (
        1 - config.acceleration_margin)
    penalty += config.elastic_weight * np.sum(np.maximum(over.max(axis=1, initial=0.0), 0.0))
    if lin.collision is not None:
        from .collision import collision_violation

        penalty += config.elastic_weight * collision_violation(lin.collision,
                                                               config.collision_margin_m)
    return float(0.5 * f + penalty)
