"""The feet in the whole-body QP: soles on their footprints, everything else above the ground.

* support soles: ``J_f dq_t = [p_F - p_f; log(R_F R_f^T)]`` (6 rows per support foot and frame,
  :func:`sole_errors`): the sole frame keeps its phase's footprint (:mod:`.footprints`);
* swing soles: every ground point of the foot ``z + J_z dq_t >= clearance_t``
  (:func:`clearance`: higher in the middle of a step, :func:`imesh.solve.sqp.swing_clearance`);
* the other leg proxies' points near the ground (shins, knees, ankle links) stay above it.

All elastic: an exact L1 penalty on one slack per foot and frame (the soles) or per frame (the
ground) keeps every linearization solvable; the slack vanishes where the rows can be met.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .config import WholeBodyConfig
from .operators import Layout, Rows, log3
from .plan import Linearization, Plan


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
    dr = log3(tgt[:, :3, :3] @ np.transpose(cur[:, :3, :3], (0, 2, 1))) if len(tt) \
        else np.zeros((0, 3))
    return tt, kk, np.concatenate([dp, dr], axis=1)


def clearance(plan: Plan, config: WholeBodyConfig) -> np.ndarray:
    """(T, 2) [m] height the swing feet's ground points keep: ``plan.clearance``, or
    ``config.feet.clearance_m`` everywhere."""
    if plan.clearance is not None:
        return plan.clearance
    return np.full(plan.support.shape, config.feet.clearance_m)


def sole_rows(out: Rows, lin: Linearization, plan: Plan, lay: Layout) -> None:
    """Support soles on their footprints, elastic: ``|J_f dq_t - e_t| <= s_f,t`` (each of the
    6 rows, one slack per foot and frame)."""
    ts, ks, err = sole_errors(lin, plan)
    if not len(ts):
        return
    nv = lay.nv
    e = err.ravel()
    rows = lay.rows(np.repeat(ts, 6), lin.sole_jacobians[ts, ks].reshape(-1, nv))
    first = lay.offset["sole_slack"]
    slack = sp.csr_matrix((np.ones(len(e)), (np.arange(len(e)),
                                             np.repeat(ts * lay.nx + first + ks, 6))),
                          shape=(len(e), lay.n))
    out.add(rows - slack, np.full(len(e), -np.inf), e)
    out.add(rows + slack, e, np.full(len(e), np.inf))


def ground_rows(out: Rows, lin: Linearization, plan: Plan, config: WholeBodyConfig,
                lay: Layout) -> None:
    """Swing feet's ground points above their clearance, then the other leg proxies' points
    below 5 cm above the ground (elastic, the frame's ground slack)."""
    nv, ground = lay.nv, lay.offset["ground_slack"]
    tt, kk = np.nonzero(~plan.support)
    if len(tt):
        z = lin.corners[tt, kk, :, 2].ravel()
        n_pts = lin.corners.shape[2]
        clear = clearance(plan, config)[tt, kk]
        out.add(lay.rows(np.repeat(tt, n_pts), lin.corner_jacobians_z[tt, kk].reshape(-1, nv))
                + lay.rows(np.repeat(tt, n_pts), np.ones((len(z), 1)), ground),
                np.repeat(clear, n_pts) - z, np.full(len(z), np.inf))
    tb, qb = np.nonzero(lin.body_z < 0.05)
    if len(tb):
        rows = lin.body_jacobians_z[tb, qb]
        out.add(lay.rows(tb, rows) + lay.rows(tb, np.ones((len(tb), 1)), ground),
                -lin.body_z[tb, qb], np.full(len(tb), np.inf))
