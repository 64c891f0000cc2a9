"""The QP of one whole-body SQP iteration (DESIGN.md, "Whole-body spacetime solve").

Unknowns: the tangent update ``dq_t`` (base twist in the base frame, joint increments; nv per
frame) of every frame t, ordered frame by frame, so every term couples at most frames t-2..t+2
and the QP is banded. Linearized at the current trajectory ``q_t`` with pinocchio Jacobians
(:class:`~imesh.solve.plan.Linearization`), holding the :class:`~imesh.solve.plan.Plan`.
This module assembles the terms; one module per concept builds them:

* :mod:`.config` the weights and margins, :mod:`.plan` the plan and the linearization,
  :mod:`.operators` the sparse building blocks and the unknowns' layout;
* :mod:`.costs` tracking, directions, damping and smoothness;
* :mod:`.zmp` the ZMP's linearization, support polygon and dead band; :mod:`.forces` normal
  force and friction; :mod:`.contacts` soles and ground; :mod:`.limits` joint velocity,
  acceleration, torque and position limits; :mod:`.collision` self-collision; :mod:`.holds`
  rest and held frames; :mod:`.merit` the SQP's merit of the same terms.

Objective (weights in :class:`~imesh.solve.config.WholeBodyConfig`):

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
* normal force: ``min_normal g <= g + c_z'' <= max_normal g`` (elastic; ``impact_normal``
  around take-offs and landings); in flight frames the CoM is ballistic, ``c'' = (0, 0, -g)``,
  and the horizontal angular momentum about it is conserved;
* kinetic friction: where the only support slides, the total horizontal force is
  ``kinetic_friction`` times the normal force, against the slide (elastic);
* friction: ``|c_a''| <= (mu / sqrt 2) (g + c_z'')`` for a = x, y in support frames (elastic):
  the ground's total force ``m (c'' - g)`` in the friction pyramid;
* joint torques: ``|P_t tau_t| <= (1 - torque_margin) effort`` on the frames and joints above
  70 % of it (elastic; inverse dynamics with the base wrench split between the support soles,
  the evaluator's ``torque_ratio_ref``; :mod:`.torque`);
* ZMP (cart-table with the evaluator's difference operator ``D`` = gradient of gradient):
  ``p_t = c_xy,t - (c_z,t / g) (D c)_xy,t + delta_t`` inside the support polygon shrunk by
  ``ZmpOptions.margin``, where ``delta_t`` is the multibody ZMP minus the cart-table ZMP at the
  current iterate (Nishiwaki's correction idea in joint space: at convergence the constraint
  holds for the multibody ZMP the evaluator computes);
* with props (:attr:`Plan.props`): no proxy inside a prop (:mod:`.props`), the points held on
  prop tops where the person's hands and knees rest (:mod:`.touches`), both elastic on the
  frame's collision slack; and on the frames whose contacts are not all soles on the floor,
  the contact wrench cone in place of the ZMP rows (:mod:`.cwc`, elastic on the ZMP slack).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .collision import collision_qp_rows
from .config import WholeBodyConfig
from .contacts import ground_rows, sole_rows
from .costs import add_smoothness, frame_blocks
from .cwc import cone_rows
from .forces import force_rows
from .holds import drop_constant_rows, held_frames, held_rows, rest_rows
from .limits import bounds, motion_rows, torque_rows
from .operators import Layout, Rows
from .plan import Linearization, Plan
from .qp import QpProblem
from .touches import touch_rows
from .zmp import auxiliary_rows, band_cost, band_rows, linearize_zmp, polygon_rows


def build_qp(lin: Linearization, plan: Plan, q: np.ndarray, config: WholeBodyConfig,
             elastic_speeds: bool = False, radius: np.ndarray | None = None) -> QpProblem:
    """The QP of one SQP iteration at the trajectory ``q`` (T, nq); see the module docstring.

    The terms and rows are assembled in a fixed order (the solver's path, and so the written
    motion, depends on it): objective (per-frame blocks, smoothness, ZMP band); equalities
    (CoM and momentum auxiliaries, rest, held frames); inequalities (soles, ground, joint
    velocities and accelerations, torques, ZMP polygon, ZMP band, normal force and friction,
    self-collision); bounds. ``elastic_speeds``: the velocity rows the trajectory violates are
    elastic (:func:`imesh.solve.limits.motion_rows`; the SQP's elastic mode). ``radius``
    (T, nv): the trust region of each frame and tangent coordinate (:mod:`.trust`; by default
    ``SqpOptions.trust_region`` everywhere, the base's translation at ``base_trust`` of it).

    Returns:
        QpProblem over x = (x_0, ..., x_{T-1}) with x_t = (dq_t (nv), dc_t (3), dk_t (2), s_t):
        the tangent update, the CoM update ``dc_t = J_c dq_t`` and the horizontal centroidal
        angular momentum update ``dk_t`` (auxiliaries that keep the ZMP rows sparse: written in
        dq they would couple whole 35-column blocks over 9 frames), then the slacks of the
        elastic rows (ZMP polygon, soles, ground, accelerations, ZMP band, torques,
        self-collision; each ``>= 0`` and priced linearly, an exact L1 penalty, so a
        linearization whose rows cannot be met still has a solution; at a feasible point they
        are 0). :class:`~imesh.solve.operators.Layout` names the offsets.
    """
    T = lin.points.shape[0]
    lay = Layout(n_frames=T, nv=lin.point_jacobians.shape[-1], cone=plan.cones is not None)

    # --- objective ---------------------------------------------------------------------------
    P, c = frame_blocks(lin, plan, q, config, lay)
    P, c = add_smoothness(P, c, lin, plan, q, config, lay)
    zl = linearize_zmp(lin, plan, lay)
    P, band = band_cost(P, lin, plan, zl, config, lay)

    # --- equalities: the auxiliaries, rest at both ends, held frames ---------------------------
    eq, rhs = auxiliary_rows(lin, lay)
    rest, rest_rhs = rest_rows(lin, plan, q, lay)
    fixed = held_frames(plan, T)
    held, held_rhs = held_rows(fixed, lay)
    A = sp.vstack(eq + rest + held, format="csc")
    b = np.concatenate(rhs + rest_rhs + held_rhs)

    # --- inequalities --------------------------------------------------------------------------
    rows = Rows()
    sole_rows(rows, lin, plan, lay)
    ground_rows(rows, lin, plan, config, lay)
    motion_rows(rows, plan, q, config, lay, elastic_speeds)
    torque_rows(rows, lin, config, lay)
    polygon_rows(rows, lin, plan, zl, config, lay)
    band_rows(rows, band, config)
    force_rows(rows, lin, plan, zl, config, lay)
    if lin.collision is not None and len(lin.collision.frames):
        rows.add(*collision_qp_rows(lin.collision, T, lay.nx, lay.offset["collision_slack"],
                                    config.collision.margin_m))
    if lin.props is not None and len(lin.props.frames):  # props share the collision slack
        rows.add(*collision_qp_rows(lin.props, T, lay.nx, lay.offset["collision_slack"],
                               config.collision.margin_m))
    if plan.points is not None:  # and so do the held points
        assert lin.held_points is not None and lin.held_jacobians is not None
        touch_rows(rows, lin.held_points, lin.held_jacobians, plan.points, lay)
    cone_rows(rows, lin, plan, lay, zl.grad, zl.Dacc)
    if lin.obstacles is not None and len(lin.obstacles.frames):  # and moving obstacles
        rows.add(*collision_qp_rows(lin.obstacles, T, lay.nx, lay.offset["collision_slack"],
                                    config.collision.margin_m))
    G = sp.vstack(rows.blocks, format="csc") if rows.blocks else sp.csc_matrix((0, lay.n))
    x_l, x_u = bounds(plan, q, config, lay, radius)
    P = ((P + P.T) * 0.5).tocsc()
    low = np.concatenate(rows.lower) if rows.lower else np.zeros(0)
    high = np.concatenate(rows.upper) if rows.upper else np.zeros(0)
    G, low, high = drop_constant_rows(G, low, high, fixed, lay)
    return QpProblem(P=P, c=np.asarray(c).ravel(), A=A, b=b, G=G, l=low, u=high,
                     x_l=x_l.ravel(), x_u=x_u.ravel())
