"""Frames the whole-body QP holds: rest at the ends of the clip, windows' fixed frames.

* rest: over the first and last ``Plan.rest_frames`` frames the world coordinates of frames t
  and t + 1 are equal (the motion starts and ends at rest: zero velocity and acceleration for
  a controller), where the window is the clip's start or end (``Plan.rest_ends``);
* held: a window of a long clip does not move its first ``Plan.fixed_frames`` frames (the
  previous window's solution) nor its last ``Plan.fixed_end_frames`` (a join window, on the
  second chain's solution; :mod:`imesh.solve.windows`): ``dq_t = 0`` as equality rows (as equal
  bounds they cost the interior point 60-250 iterations instead of 25).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .costs import world_coordinates, world_map
from .operators import Layout
from .plan import Linearization, Plan


def held_frames(plan: Plan, n_frames: int) -> np.ndarray:
    """(H,) int frames of a window that do not move: its first ``plan.fixed_frames`` and last
    ``plan.fixed_end_frames`` (:mod:`imesh.solve.windows`)."""
    frames = np.arange(n_frames)
    return frames[(frames < plan.fixed_frames) | (frames >= n_frames - plan.fixed_end_frames)]


def rest_rows(lin: Linearization, plan: Plan, q: np.ndarray, lay: Layout
              ) -> tuple[list[sp.spmatrix], list[np.ndarray]]:
    """Equalities ``S_{t+1} dq_{t+1} - S_t dq_t = y_t - y_{t+1}`` (world coordinates y,
    :func:`~imesh.solve.costs.world_coordinates`) over the rest frames at both ends."""
    T, nv = lay.n_frames, lay.nv
    eq: list[sp.spmatrix] = []
    rhs: list[np.ndarray] = []
    if plan.rest_frames > 1 and T >= 2 * plan.rest_frames:
        Rb = lin.base_rotations
        Sb = world_map(Rb, nv)
        y = world_coordinates(q, Rb)
        k = plan.rest_frames - 1
        start, end = plan.rest_ends
        for t in [*range(k if start else 0), *range(T - 1 - k, T - 1 if end else T - 1 - k)]:
            rows_now = lay.rows(np.full(nv, t), Sb[t])
            rows_next = lay.rows(np.full(nv, t + 1), Sb[t + 1])
            eq.append(rows_next - rows_now)
            rhs.append(y[t] - y[t + 1])
    return eq, rhs


def held_rows(fixed: np.ndarray, lay: Layout) -> tuple[list[sp.spmatrix], list[np.ndarray]]:
    """Equalities ``dq_t = 0`` of the held frames ``fixed``."""
    if not len(fixed):
        return [], []
    nv = lay.nv
    return ([lay.rows(np.repeat(fixed, nv), np.tile(np.eye(nv), (len(fixed), 1)))],
            [np.zeros(len(fixed) * nv)])


def drop_constant_rows(G: sp.csc_matrix, low: np.ndarray, high: np.ndarray,
                       fixed: np.ndarray, lay: Layout
                       ) -> tuple[sp.csc_matrix, np.ndarray, np.ndarray]:
    """The rows of G that touch a free frame's unknowns. Rows in the held frames' unknowns
    only are constants (their one-sided differences met by slack, at a constant price):
    without them the interior point takes 25 iterations instead of 60-250."""
    if not (len(fixed) and G.shape[0]):
        return G, low, high
    free = np.ones(lay.n_frames, dtype=bool)
    free[fixed] = False
    touches = (abs(G) @ np.repeat(free, lay.nx).astype(float)) > 0
    return G[touches], low[touches], high[touches]
