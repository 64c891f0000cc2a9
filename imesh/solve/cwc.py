"""Balance rows beyond the ZMP: the contact wrench cone in the whole-body QP.

On a frame whose contacts are not all soles on the floor (a foot on a prop's top, feet at two
heights, a hand or knee held on a top: :mod:`.touches`) the ZMP rows are replaced by the
contact wrench cone of Caron, Pham & Nakamura (RSS 2015; :mod:`imesh.balance.cwc`); on the
single-support frames of a plan on the floor the cone of the support sole scaled by
``ForceOptions.yaw_sole_scale`` about its centre is added to the ZMP rows (the ZMP says nothing
of the moment about the vertical, which one sole's friction bounds). The wrench
the contacts must supply per unit mass about the cone's reference point ``o``,

    w_t = [f_t; (c_t - o) x f_t + Ld_t / m],   f_t = c''_t - g,

stays in the cone's face form ``U w_t <= -margin`` (``E w_t = 0`` where the
contacts span less than six dimensions). The cone of a frame is built from the plan (the
support soles' corners on their footprints, the held points' anchors), so frames with the same
contact set share one (:func:`plan_cones`: one convex hull per distinct set).

Linearized in the QP's auxiliaries (the CoM update ``dc``, the centroidal angular momentum
update ``dk``; ``c'' = D c``, ``Ld = grad k`` with the evaluator's operators, as the ZMP rows
use them; the vertical ``dk_z`` is an auxiliary of plans with cones only,
:data:`imesh.solve.operators.CONE_AUXILIARIES`):

    dw_t = [dc''_t; dc_t x f_t + (c_t - o) x dc''_t + grad dk_t / m],

elastic with the frame's ZMP slack (priced as the ZMP and force rows); the merit charges the
frame's largest face value plus the margin (:func:`cone_violation`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..balance.cwc import FRICTION, WrenchCone, contact_wrench_cone, required_wrench
from ..contacts.phases import SIDES
from .operators import Layout, Rows
from .plan import Linearization, Plan

log = logging.getLogger(__name__)

#: The rows keep ``U w <= -CONE_MARGIN`` [m/s^2 per unit row]: about 5 mm of a support
#: polygon's edge at 1 g (a face of a sole's moment is ~ (m_x - l f_z) / |(1, l)|).
CONE_MARGIN = 0.05


@dataclass(frozen=True, eq=False)
class ConePlan:
    """The frames with cone rows and their cones.

    Attributes:
        frames: (F,) frames with rows.
        cone: (F,) index into ``cones`` of each.
        cones: one :class:`imesh.balance.cwc.WrenchCone` per distinct contact set.
    """

    frames: np.ndarray
    cone: np.ndarray
    cones: tuple[WrenchCone, ...]

    def window(self, start: int, stop: int) -> ConePlan | None:
        """The frames [start, stop) renumbered from 0 (None without a cone frame there)."""
        sel = (self.frames >= start) & (self.frames < stop)
        if not sel.any():
            return None
        return ConePlan(frames=self.frames[sel] - start, cone=self.cone[sel], cones=self.cones)

    def refs(self, T: int) -> np.ndarray:
        """(T, 3) the reference point of each frame's cone (0 on frames without)."""
        out = np.zeros((T, 3))
        out[self.frames] = np.array([c.ref_m for c in self.cones])[self.cone]
        return out


def plan_cones(robot, support: np.ndarray, sole_targets: np.ndarray, anchors: np.ndarray | None,
               active: np.ndarray | None, frames: np.ndarray, mu: float = FRICTION,
               sole_scale: float = 1.0) -> ConePlan | None:
    """The cones of ``frames`` from their contacts: the corners of each support sole on its
    footprint (``sole_targets`` (T, 2, 4, 4), normal the footprint's sole normal) and the held
    points' ``anchors`` (C, 3) active there (``active`` (T, C), normal up).

    Args:
        robot: the robot (its soles' rectangles).
        support: (T, 2) bool support soles.
        frames: (F,) the frames that get cone rows (each with at least one contact).
        sole_scale: the soles' rectangles scaled by this about their centres (< 1: the cone
            of a smaller sole, whose yaw moment ``mu (X + Y) f_z`` scales with it).
    """
    frames = np.asarray(frames, dtype=int)
    if not len(frames):
        return None
    T = len(support)
    C = 0 if anchors is None or active is None else len(anchors)
    anchors = np.zeros((0, 3)) if anchors is None else anchors
    active = np.zeros((T, C), dtype=bool) if active is None or not C else active
    # the contact set of a frame: its two footprint poses (NaN where not in support) and its
    # active held points; frames with equal keys share a cone
    key = np.concatenate([np.where(support[:, :, None, None], sole_targets, 0.0).reshape(T, -1),
                          np.zeros((T, 0)) if not C else active.astype(float)], axis=1)
    uniq, inverse = np.unique(np.round(key[frames], 9), axis=0, return_inverse=True)
    cones = []
    for u in range(len(uniq)):
        t = frames[np.flatnonzero(inverse == u)[0]]
        pts, normals = [], []
        for k, side in enumerate(SIDES):
            if support[t, k]:
                sole, M = robot.soles[side], sole_targets[t, k]
                local = sole.center + sole_scale * (sole.corners() - sole.center)
                pts.append(local @ M[:3, :3].T + M[:3, 3])
                normals.append(np.tile(M[:3, :3] @ sole.normal, (4, 1)))
        if C and active[t].any():
            pts.append(anchors[active[t]])
            normals.append(np.tile([0.0, 0.0, 1.0], (int(active[t].sum()), 1)))
        cones.append(contact_wrench_cone(np.concatenate(pts), np.concatenate(normals), mu=mu))
    log.info("contact wrench cone rows on %d frames, %d distinct contact sets (%s faces)",
             len(frames), len(cones), "/".join(str(len(c.faces)) for c in cones))
    return ConePlan(frames=frames, cone=np.asarray(inverse).ravel(), cones=tuple(cones))


def wrench_rows(lin: Linearization, plan: Plan, lay: Layout, grad: sp.spmatrix,
                Dacc: sp.spmatrix) -> tuple[np.ndarray, list[sp.csr_matrix]]:
    """The wrench ``w_t`` (T, 6) at the iterate about each frame's cone reference, and its
    change as six (T, N) maps of the QP's unknowns (module docstring)."""
    T = lay.n_frames
    assert plan.cones is not None  # cone_rows and cone_violation ask only plans with cones
    ref = plan.cones.refs(T)
    w = required_wrench(lin.com, lin.com_acceleration, lin.angular_momentum_rate, lin.mass, ref)
    f, r = w[:, :3], lin.com - ref
    C0, K0 = lay.offset["com"], lay.offset["momentum"]
    P = [lay.pick(C0 + i) for i in range(3)]
    D = [(Dacc @ p).tocsr() for p in P]
    Gk = [(grad @ lay.pick(off) / lin.mass).tocsr()
          for off in (K0, K0 + 1, lay.offset["momentum_z"])]
    dg = sp.diags
    dw = D + [
        dg(f[:, 2]) @ P[1] - dg(f[:, 1]) @ P[2] + dg(r[:, 1]) @ D[2] - dg(r[:, 2]) @ D[1] + Gk[0],
        dg(f[:, 0]) @ P[2] - dg(f[:, 2]) @ P[0] + dg(r[:, 2]) @ D[0] - dg(r[:, 0]) @ D[2] + Gk[1],
        dg(f[:, 1]) @ P[0] - dg(f[:, 0]) @ P[1] + dg(r[:, 0]) @ D[1] - dg(r[:, 1]) @ D[0] + Gk[2]]
    return w, [m.tocsr() for m in dw]


def cone_rows(out: Rows, lin: Linearization, plan: Plan, lay: Layout, grad: sp.spmatrix,
              Dacc: sp.spmatrix) -> None:
    """``U (w_t + dw_t) - s_t <= -CONE_MARGIN`` and ``|E (w_t + dw_t)| <= s_t`` on the cone
    frames (``s_t`` the frame's ZMP slack)."""
    cp = plan.cones
    if cp is None:
        return
    w, dw = wrench_rows(lin, plan, lay, grad, Dacc)
    slack = lay.pick(lay.offset["zmp_slack"])
    for k, cone in enumerate(cp.cones):
        tk = cp.frames[cp.cone == k]
        n = len(tk)
        stacked = sp.vstack([m[tk] for m in dw], format="csr")  # (6 n, N), component-major
        s = slack[tk]
        for U, margin, two_sided in ((cone.faces, CONE_MARGIN, False),
                                     (cone.equalities, 0.0, True)):
            if not len(U):
                continue
            G = sp.kron(sp.csr_matrix(U), sp.identity(n), format="csr") @ stacked
            now = (w[tk] @ U.T).T.ravel()  # face-major, as the kron's rows
            S = sp.vstack([s] * len(U), format="csr")
            out.add(G - S, np.full(len(now), -np.inf), -margin - now)
            if two_sided:
                out.add(G + S, -now, np.full(len(now), np.inf))


def cone_violation(lin: Linearization, plan: Plan) -> np.ndarray:
    """(T,) what each cone frame's slack has to cover at the trajectory: the largest
    ``U w_t + CONE_MARGIN`` or ``|E w_t|``, at least 0 (0 on frames without a cone)."""
    T = len(lin.com)
    out = np.zeros(T)
    cp = plan.cones
    if cp is None:
        return out
    w = required_wrench(lin.com, lin.com_acceleration, lin.angular_momentum_rate, lin.mass,
                        cp.refs(T))
    for k, cone in enumerate(cp.cones):
        tk = cp.frames[cp.cone == k]
        v = (w[tk] @ cone.faces.T).max(axis=1) + CONE_MARGIN
        if len(cone.equalities):
            v = np.maximum(v, np.abs(w[tk] @ cone.equalities.T).max(axis=1))
        out[tk] = np.maximum(v, 0.0)
    return out
