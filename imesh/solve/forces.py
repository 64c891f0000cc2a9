"""The ground's force in the whole-body QP: normal force and friction from the CoM acceleration.

The ground's total force is ``m (c'' - g)`` (``c'' = D c``, the evaluator's difference
operator, linearized in the CoM auxiliaries: :class:`~imesh.solve.zmp.ZmpLinearization`):

* normal force: ``min_normal g <= g + c_z'' <= max_normal g`` in support frames: the ground
  only pushes (which also keeps the ZMP's denominator away from 0, where its linearization
  means nothing), and the support joints carry at most ``max_normal`` times the weight; in
  flight frames there is no ground: the CoM falls, ``c_z'' = -g``;
* friction: ``|c_a''| <= (mu / sqrt 2) (g + c_z'')`` for a = x, y in support frames, the total
  force in the pyramid inside the friction cone (exact for the total force, so for the sole's
  force in single support).

All rows are elastic on the frame's ZMP slack.
"""

from __future__ import annotations

import numpy as np

from .config import WholeBodyConfig
from .operators import Layout, Rows
from .plan import GRAVITY, Linearization
from .zmp import ZmpLinearization


def force_rows(out: Rows, lin: Linearization, zl: ZmpLinearization, config: WholeBodyConfig,
               lay: Layout) -> None:
    """Normal-force rows of the support frames, friction rows (``config.forces.friction > 0``), then
    the free fall of the flight frames (see the module docstring)."""
    acc, acc_z, sup = lin.com_acceleration, zl.acc_z, zl.support
    slack = lay.pick(lay.offset["zmp_slack"])
    vert = (acc_z + slack).tocsr()
    flight = ~sup
    n_sup = int(sup.sum())
    out.add(vert[sup], ((config.forces.min_normal - 1.0) * GRAVITY - acc[:, 2])[sup],
            np.full(n_sup, np.inf))
    out.add((acc_z - slack).tocsr()[sup], np.full(n_sup, -np.inf),
            ((config.forces.max_normal - 1.0) * GRAVITY - acc[:, 2])[sup])
    if config.forces.friction > 0 and sup.any():
        mu = config.forces.friction / np.sqrt(2.0)
        for axis, aux in ((0, zl.cx), (1, zl.cy)):
            acc_a = zl.Dacc @ aux
            for sign in (1.0, -1.0):
                out.add((sign * acc_a - mu * acc_z - slack).tocsr()[sup],
                        np.full(n_sup, -np.inf),
                        (mu * (GRAVITY + acc[:, 2]) - sign * acc[:, axis])[sup])
    if flight.any():
        n_flight = int(flight.sum())
        out.add(vert[flight], (-GRAVITY - acc[:, 2])[flight], np.full(n_flight, np.inf))
        out.add((acc_z - slack).tocsr()[flight], np.full(n_flight, -np.inf),
                (-GRAVITY - acc[:, 2])[flight])
