"""The ground's force in the whole-body QP: normal force and friction from the CoM acceleration.

The ground's total force is ``m (c'' - g)`` (``c'' = D c``, the evaluator's difference
operator, linearized in the CoM auxiliaries: :class:`~imesh.solve.zmp.ZmpLinearization`):

* normal force: ``min_normal g <= g + c_z'' <= max_normal g`` in the frames with a contact
  (support soles or points held on a prop's top; every contact normal is vertical): the ground
  only pushes (which also keeps the ZMP's denominator away from 0, where its linearization
  means nothing), and the support joints carry at most ``max_normal`` times the weight
  (``impact_normal`` around take-offs and landings, ``Plan.normal_max``);
* friction: ``|c_a''| <= (mu / sqrt 2) (g + c_z'')`` for a = x, y in support frames, the total
  force in the pyramid inside the friction cone (exact for the total force, so for the sole's
  force in single support);
* kinetic friction: where the only support slides, ``c_xy'' = s u`` with ``u`` the unit
  direction against the slide (``Plan.kinetic``) and ``0 <= s <= mu_k (g + c_z'')``: Coulomb's
  force of a floor whose kinetic mu is at most ``mu_k`` (a human slide carries ~0: the zombie
  walk's single-support slides need -0.2..0.14 of the normal force), never pushing along the
  slide nor across it;
* flight (no contact at all: no support sole and no point held on a prop's top,
  :attr:`~imesh.solve.plan.Plan.supported`): there is no ground, only gravity acts: the CoM is
  ballistic, ``c'' = (0, 0, -g)``,
  and the angular momentum about the CoM is conserved, ``Ld_x = Ld_y = 0`` (the rows hold the
  horizontal components the ZMP's linearization carries; ``Ld = grad k``).

All rows are elastic on the frame's ZMP slack.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .config import WholeBodyConfig
from .operators import Layout, Rows
from .plan import GRAVITY, Linearization, Plan
from .zmp import ZmpLinearization


def normal_bounds(plan: Plan, config: WholeBodyConfig) -> tuple[np.ndarray, np.ndarray]:
    """(T,) lower and upper bounds of ``c_z''`` [m/s^2] in the support frames (from
    ``ForceOptions.min_normal`` and ``Plan.normal_max`` or ``ForceOptions.max_normal``)."""
    T = len(plan.support)
    top = (np.full(T, config.forces.max_normal) if plan.normal_max is None
           else plan.normal_max)
    return (np.full(T, (config.forces.min_normal - 1.0) * GRAVITY), (top - 1.0) * GRAVITY)


def force_rows(out: Rows, lin: Linearization, plan: Plan, zl: ZmpLinearization,
               config: WholeBodyConfig, lay: Layout) -> None:
    """Normal-force rows of the support frames, friction rows (``config.forces.friction > 0``),
    kinetic friction of the slides, then the ballistic flight frames (see the module
    docstring)."""
    # the frames with any contact (soles, held points), not only the ZMP's: a frame on a
    # prop's top or hanging on the hands is not ballistic
    acc, acc_z, sup = lin.com_acceleration, zl.acc_z, plan.supported
    slack = lay.pick(lay.offset["zmp_slack"])
    vert = (acc_z + slack).tocsr()
    flight = ~sup
    n_sup = int(sup.sum())
    low, high = normal_bounds(plan, config)
    out.add(vert[sup], (low - acc[:, 2])[sup], np.full(n_sup, np.inf))
    out.add((acc_z - slack).tocsr()[sup], np.full(n_sup, -np.inf), (high - acc[:, 2])[sup])
    acc_xy = [(zl.Dacc @ aux).tocsr() for aux in (zl.cx, zl.cy)]
    if config.forces.friction > 0 and sup.any():
        mu = config.forces.friction / np.sqrt(2.0)
        for axis, acc_a in enumerate(acc_xy):
            for sign in (1.0, -1.0):
                out.add((sign * acc_a - mu * acc_z - slack).tocsr()[sup],
                        np.full(n_sup, -np.inf),
                        (mu * (GRAVITY + acc[:, 2]) - sign * acc[:, axis])[sup])
    kinetic = plan.kinetic
    kin = (np.zeros(len(sup), dtype=bool) if kinetic is None
           else np.isfinite(kinetic).all(axis=1) & sup)
    if kinetic is not None and config.forces.kinetic_friction > 0 and kin.any():
        mu_k = config.forces.kinetic_friction
        n_kin = int(kin.sum())
        ux, uy = (np.where(kin, kinetic[:, a], 0.0) for a in (0, 1))
        # along u (against the slide): 0 <= c'' . u <= mu_k (g + c_z''); across it: 0
        along = (sp.diags(ux) @ acc_xy[0] + sp.diags(uy) @ acc_xy[1]).tocsr()
        across = (sp.diags(-uy) @ acc_xy[0] + sp.diags(ux) @ acc_xy[1]).tocsr()
        along_now = ux * acc[:, 0] + uy * acc[:, 1]
        across_now = -uy * acc[:, 0] + ux * acc[:, 1]
        sl = slack.tocsr()[kin]
        out.add(along[kin] + sl, -along_now[kin], np.full(n_kin, np.inf))
        out.add((along - mu_k * acc_z).tocsr()[kin] - sl, np.full(n_kin, -np.inf),
                (mu_k * (GRAVITY + acc[:, 2]) - along_now)[kin])
        out.add(across[kin] + sl, -across_now[kin], np.full(n_kin, np.inf))
        out.add(across[kin] - sl, np.full(n_kin, -np.inf), -across_now[kin])
    if flight.any():
        n_flight = int(flight.sum())
        out.add(vert[flight], (-GRAVITY - acc[:, 2])[flight], np.full(n_flight, np.inf))
        out.add((acc_z - slack).tocsr()[flight], np.full(n_flight, -np.inf),
                (-GRAVITY - acc[:, 2])[flight])
        # ballistic horizontally, angular momentum conserved (per unit mass: m^2/s^2)
        ld = lin.angular_momentum_rate / lin.mass
        K0 = lay.offset["momentum"]
        grad_k = [(zl.grad @ lay.pick(K0 + i) / lin.mass).tocsr() for i in range(2)]
        for rows, now in ((acc_xy[0], acc[:, 0]), (acc_xy[1], acc[:, 1]),
                          (grad_k[0], ld[:, 0]), (grad_k[1], ld[:, 1])):
            out.add((rows + slack).tocsr()[flight], -now[flight], np.full(n_flight, np.inf))
            out.add((rows - slack).tocsr()[flight], np.full(n_flight, -np.inf), -now[flight])
