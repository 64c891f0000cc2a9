"""Joint limits in the whole-body QP: positions, velocities, accelerations, torques.

* positions: bounds on the update, intersected with a trust region (:func:`bounds`);
* velocities: ``|Delta q| <= (1 - margin) v_max dt``;
* accelerations: ``|Delta^2 q| <= (1 - margin) a_max dt^2``, elastic (one slack per frame: the
  lead-in starts from rest, :mod:`.lead`);
* torques: ``|P_t tau_t| <= (1 - torque_margin) effort`` on the working set of frames and
  joints above 70 % of it, in ratio units, elastic (:mod:`.torque`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .config import WholeBodyConfig
from .operators import Layout, Rows, difference_operator
from .plan import Linearization, Plan
from .trust import nominal_radii


def motion_rows(out: Rows, plan: Plan, q: np.ndarray, config: WholeBodyConfig,
                lay: Layout, elastic_speeds: bool = False) -> None:
    """Joint velocity rows, then the elastic joint acceleration rows (limits that are
    infinite get no row).

    With ``elastic_speeds`` (the SQP's elastic mode, after a QP it built was infeasible) the
    velocity rows the trajectory violates get the acceleration rows' slack of their last
    frame: an initializer faster than the margin-reduced limit over more frames than the
    trust region lets one step undo (the CMU 07_05 walk on JVRC-1, an elbow at 1.7 times 0.7
    of its speed limit over a sweep) has no step within hard rows. A row the trajectory meets
    stays hard (the step dq = 0 meets it)."""
    T, nx = lay.n_frames, lay.nx
    n_j = lay.nv - 6
    h = 1.0 / plan.fps
    sel = sp.csr_matrix((np.ones(T * n_j), (np.arange(T * n_j),
                                             (np.arange(T)[:, None] * nx + 6
                                              + np.arange(n_j)).ravel())), shape=(T * n_j, lay.n))
    qj = q[:, 7:]
    for n_diff, limit, margin in ((1, plan.v_max * h, config.margins.velocity),
                                  (2, plan.a_max * h * h, config.margins.acceleration)):
        if T <= n_diff:
            continue
        D = sp.kron(difference_operator(T, n_diff), sp.identity(n_j), format="csr") @ sel
        lim = np.tile(limit * (1 - margin), T - n_diff)
        d = np.diff(qj, n=n_diff, axis=0).ravel()
        finite = np.isfinite(lim)
        # elastic rows share the slack of the difference's last frame (a speed) or centre (an
        # acceleration), one per frame: every acceleration row (the lead-in's start from
        # rest), and in the elastic mode the speed rows the trajectory violates
        if n_diff == 2:
            soft = finite
        else:
            soft = finite & (np.abs(d) > lim) if elastic_speeds else np.zeros_like(finite)
        hard = finite & ~soft
        if soft.any():
            at = np.repeat(np.arange(1, T - n_diff + 1), n_j)
            slack = lay.rows(at, np.ones((len(at), 1)), lay.offset["accel_slack"])
            out.add((D - slack)[soft], np.full(int(soft.sum()), -np.inf), (lim - d)[soft])
            out.add((D + slack)[soft], (-lim - d)[soft], np.full(int(soft.sum()), np.inf))
        if hard.any():
            out.add(D[hard], (-lim - d)[hard], (lim - d)[hard])


def torque_rows(out: Rows, lin: Linearization, config: WholeBodyConfig, lay: Layout) -> None:
    """Net joint torques within the effort limits on the working set (ratio units, elastic:
    ``|r + C dq| <= 1 - margin + s_t``; nothing without torque linearization)."""
    trq = lin.torques
    if trq is None or not len(trq.frames):
        return
    nv, nx = lay.nv, lay.nx
    R, W = trq.columns.shape
    rows = sp.csr_matrix((trq.coefficients.ravel(),
                          (np.repeat(np.arange(R), W * nv),
                           (trq.columns[:, :, None] * nx + np.arange(nv)).ravel())),
                         shape=(R, lay.n))
    first = lay.offset["torque_slack"]
    slack = sp.csr_matrix((np.ones(R), (np.arange(R), trq.frames * nx + first)),
                          shape=(R, lay.n))
    r0 = trq.values
    bound = 1.0 - config.margins.torque
    out.add(rows - slack, np.full(R, -np.inf), bound - r0)
    out.add(rows + slack, -bound - r0, np.full(R, np.inf))


def bounds(plan: Plan, q: np.ndarray, config: WholeBodyConfig, lay: Layout,
           radius: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(x_l, x_u) (T, nx): joint positions, a trust region on the update, slacks >= 0.

    ``radius`` (T, nv): the trust region of each frame and tangent coordinate [m or rad]
    (:mod:`.trust`); by default :func:`imesh.solve.trust.nominal_radii` in every frame.
    """
    T, nv, nx = lay.n_frames, lay.nv, lay.nx
    if radius is None:
        radius = np.broadcast_to(nominal_radii(config.sqp, nv), (T, nv))
    qj = q[:, 7:]
    x_l = np.full((T, nx), -np.inf)
    x_u = np.full((T, nx), np.inf)
    x_l[:, :nv], x_u[:, :nv] = -radius, radius
    x_l[:, 6:nv] = np.maximum(plan.lower - qj, -radius[:, 6:])
    x_u[:, 6:nv] = np.minimum(plan.upper - qj, radius[:, 6:])
    x_l[:, lay.offset["zmp_slack"]:lay.offset["collision_slack"] + 1] = 0.0
    return x_l, x_u
