"""The ZMP in the whole-body QP: its linearization, the support polygon and the dead band.

The multibody ZMP (the evaluator's) is linearized in per-frame auxiliaries, the CoM update
``dc_t = J_c dq_t`` and the update ``dk_t`` of the horizontal centroidal angular momentum
(:func:`auxiliary_rows`), so each ZMP row touches a few columns of three frames:

    p_x = c_x - N_x / Dn,   p_y = c_y - N_y / Dn,
    N_x = c_z a_x + Ld_y / m,   N_y = c_z a_y - Ld_x / m,   Dn = a_z + g,

with ``a = D c`` (``D``, the evaluator's operator: gradient of gradient), ``Ld = grad(k)`` and
``dk = Ag_ang grad(dq)`` (:class:`ZmpLinearization`). At the current iterate the rows start
from the multibody ZMP, so at convergence they hold for the ZMP the evaluator computes
(Nishiwaki's correction idea in joint space).

Rows: ``p_t`` inside the support polygon of the soles shrunk by ``ZmpOptions.margin`` (elastic,
:func:`polygon_rows`) and a cost ``w_z,t |b_t|^2`` on the excess over a dead band around the
desired ZMP, ``|p_t - p*_t| <= band + b_t`` per axis (:func:`band_cost`), its weight lower in
settled double support (:func:`band_weights`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .config import WholeBodyConfig, ZmpOptions
from .operators import Layout, Rows, gradient_operator
from .plan import GRAVITY, Linearization, Plan


@dataclass(frozen=True, eq=False)
class ZmpLinearization:
    """The ZMP and the CoM acceleration as linear maps of the QP's unknowns.

    Attributes:
        grad: (T, T) the evaluator's gradient operator; Dacc: ``grad @ grad``.
        cx, cy: (T, N) select the CoM auxiliaries' x and y of every frame.
        acc_z: (T, N) the vertical CoM acceleration's change ``Dacc dc_z``.
        Z: (2T, N) the ZMP's change, rows x_0, y_0, x_1, y_1, ...
        support: (T,) bool frames with the ZMP's dead band (:func:`zmp_frames`).
    """

    grad: sp.csr_matrix
    Dacc: sp.csr_matrix
    cx: sp.csr_matrix
    cy: sp.csr_matrix
    acc_z: sp.csr_matrix
    Z: sp.csr_matrix
    support: np.ndarray


def linearize_zmp(lin: Linearization, plan: Plan, lay: Layout) -> ZmpLinearization:
    """The ZMP's rows in the CoM and angular-momentum auxiliaries (see the module docstring)."""
    T = lay.n_frames
    h = 1.0 / plan.fps
    grad = gradient_operator(T, h)
    Dacc = (grad @ grad).tocsr()
    com, acc, ld, m = lin.com, lin.com_acceleration, lin.angular_momentum_rate, lin.mass
    cz = com[:, 2]
    Dn = acc[:, 2] + GRAVITY
    Nx = cz * acc[:, 0] + ld[:, 1] / m
    Ny = cz * acc[:, 1] - ld[:, 0] / m
    pick = lay.pick
    C0, K0 = lay.offset["com"], lay.offset["momentum"]
    cx, cy, czs, kx, ky = (pick(C0), pick(C0 + 1), pick(C0 + 2), pick(K0), pick(K0 + 1))
    dg = sp.diags
    acc_z = Dacc @ czs
    Zx = (cx - dg(acc[:, 0] / Dn) @ czs - dg(cz / Dn) @ Dacc @ cx
          - dg(1.0 / (m * Dn)) @ grad @ ky + dg(Nx / Dn ** 2) @ acc_z)
    Zy = (cy - dg(acc[:, 1] / Dn) @ czs - dg(cz / Dn) @ Dacc @ cy
          + dg(1.0 / (m * Dn)) @ grad @ kx + dg(Ny / Dn ** 2) @ acc_z)
    order = np.argsort(np.r_[2 * np.arange(T), 2 * np.arange(T) + 1], kind="stable")
    Z = sp.vstack([Zx, Zy], format="csr")[order]  # rows x_0, y_0, x_1, y_1, ...
    return ZmpLinearization(grad=grad, Dacc=Dacc, cx=cx, cy=cy, acc_z=acc_z, Z=Z,
                            support=zmp_frames(plan))


def zmp_frames(plan: Plan) -> np.ndarray:
    """(T,) bool frames with the ZMP's dead band: the supported frames; with props only those
    that have support half-planes (all supports on the floor:
    :func:`imesh.solve.sqp.floor_halfplanes`)."""
    sup = np.asarray(plan.support.any(axis=1))
    if plan.props is None:
        return sup
    has = np.zeros(len(sup), dtype=bool)
    has[plan.halfplanes[0]] = True
    return sup & has


def band_weights(support: np.ndarray, fps: float, options: ZmpOptions) -> np.ndarray:
    """(T,) w_z of every frame of a (T, 2) support plan (``Plan.zmp_weights``): ``weight`` in
    single support and in the double support within ``near_single_s`` of a single-support
    frame (lift-offs and landings), ``double_weight`` in the rest of double support."""
    n_support = np.asarray(support).sum(axis=1)
    single = np.flatnonzero(n_support == 1)
    near = n_support < 2
    if len(single):
        t = np.arange(len(n_support))
        # distance to the nearest single-support frame, from its neighbours on either side
        i = np.searchsorted(single, t)
        gap = np.minimum(np.abs(t - single[np.minimum(i, len(single) - 1)]),
                         np.abs(t - single[np.maximum(i - 1, 0)]))
        near |= gap <= options.near_single_s * fps + 1e-9
    return np.where(near, options.weight, options.double_weight)


def band_cost(P: sp.spmatrix, lin: Linearization, plan: Plan, zl: ZmpLinearization,
              config: WholeBodyConfig, lay: Layout) -> tuple[sp.spmatrix, tuple | None]:
    """P plus ``w_z,t b^2`` (``plan.zmp_weights``) on the excess b of the supported frames, and
    the rows ``|p0 + Z x - p*| <= band + b`` (per axis) as (Z rows, excess selector, p0 - p*) for
    :func:`band_rows` (None without the cost or without support)."""
    sup = zl.support
    w = plan.zmp_weights
    if not (w[sup] > 0).any():
        return P, None
    nx, B0 = lay.nx, lay.offset["band_excess"]
    rows = np.flatnonzero(np.repeat(sup, 2))
    r_z = (lin.zmp_multibody - plan.desired_zmp).ravel()[rows]
    excess = sp.csr_matrix((np.ones(len(rows)), (np.arange(len(rows)),
                                                 (rows // 2) * nx + B0 + rows % 2)),
                           shape=(len(rows), lay.n))
    diag = np.zeros(lay.n)
    diag[(np.flatnonzero(sup)[:, None] * nx + B0 + np.arange(2)).ravel()] = \
        np.repeat(w[sup], 2)
    return P + sp.diags(diag), (zl.Z[rows], excess, r_z)


def band_rows(out: Rows, band: tuple | None, config: WholeBodyConfig) -> None:
    """The dead band's two-sided rows ``-band - r <= Z x -+ b <= band - r``."""
    if band is None:
        return
    Zs, excess, r_z = band
    out.add(Zs - excess, np.full(len(r_z), -np.inf), config.zmp.band_m - r_z)
    out.add(Zs + excess, -config.zmp.band_m - r_z, np.full(len(r_z), np.inf))


def polygon_rows(out: Rows, lin: Linearization, plan: Plan, zl: ZmpLinearization,
                 config: WholeBodyConfig, lay: Layout) -> None:
    """ZMP inside the shrunk support polygons: ``n . (p0 + Z x) + s_t >= b + margin`` per
    half-plane (elastic, the ZMP slack)."""
    hp_frame, hp_n, hp_b = plan.halfplanes
    if not len(hp_frame):
        return
    T = lay.n_frames
    R = len(hp_frame)
    Nmat = sp.csr_matrix((hp_n.ravel(), (np.repeat(np.arange(R), 2),
                                          (hp_frame[:, None] * 2 + np.arange(2)).ravel())),
                         shape=(R, 2 * T))
    slack = sp.csr_matrix((np.ones(R), (np.arange(R), hp_frame * lay.nx + lay.offset["zmp_slack"])),
                          shape=(R, lay.n))
    out.add(Nmat @ zl.Z + slack,
            hp_b - np.sum(hp_n * lin.zmp_multibody[hp_frame], axis=1),
            np.full(R, np.inf))


def auxiliary_rows(lin: Linearization, lay: Layout
                   ) -> tuple[list[sp.spmatrix], list[np.ndarray]]:
    """Equalities defining the auxiliaries: ``dc_t = J_c dq_t`` and
    ``dk_t = sum_s K_ts dq_s`` over the frames ``s = prev(t), t, next(t)`` whose difference is
    ``v_t`` (``Linearization.momentum_jacobians``: x, y rows; z for the cone rows)."""
    T, nv, nx = lay.n_frames, lay.nv, lay.nx
    frames_all = np.arange(T)
    eq = [lay.rows(np.repeat(frames_all, 3), lin.com_jacobians.reshape(-1, nv))
          - lay.rows(np.repeat(frames_all, 3), np.tile(np.eye(3), (T, 1)), lay.offset["com"])]
    rhs = [np.zeros(3 * T)]
    K = lin.momentum_jacobians  # (T, 3 frames, 3 axes, nv)
    near = np.stack([np.r_[0, np.arange(T - 1)], frames_all,
                     np.r_[np.arange(1, T), T - 1]], axis=1)  # (T, 3) prev, t, next
    # repeated (t, column) entries at the ends add up (csr sums duplicates)
    rows = (2 * frames_all[:, None, None, None] + np.arange(2)[None, None, :, None]
            + 0 * np.arange(nv)) + 0 * near[:, :, None, None]
    cols = (near[:, :, None, None] * nx + np.arange(nv)) + 0 * rows
    Mk = sp.csr_matrix((K[:, :, :2].ravel(), (rows.ravel(), cols.ravel())), shape=(2 * T, lay.n))
    eq.append(lay.rows(np.repeat(frames_all, 2), np.tile(np.eye(2), (T, 1)), lay.offset["momentum"])
              - Mk)
    rhs.append(np.zeros(2 * T))
    if "momentum_z" in lay.offset:  # the cone rows' vertical momentum (imesh.solve.cwc)
        rz = np.broadcast_to(frames_all[:, None, None], (T, 3, nv))
        cz = near[:, :, None] * nx + np.arange(nv)
        Mz = sp.csr_matrix((K[:, :, 2].ravel(), (rz.ravel(), cz.ravel())), shape=(T, lay.n))
        eq.append(lay.pick(lay.offset["momentum_z"]) - Mz)
        rhs.append(np.zeros(T))
    return eq, rhs
