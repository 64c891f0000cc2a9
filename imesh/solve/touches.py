"""Hands and knees on prop tops in the whole-body solve: contact points held still.

Where the person's hand or knee is on a prop's top (:mod:`imesh.contacts.effectors`), one
point of the robot's link is held at an anchor on that top for the whole contact run: no skid,
and a fixed place for its force in the contact wrench cone (:mod:`.cwc`).

* **The point** (:func:`plan_contact_points`): of the collision proxies' points
  (:class:`imesh.metrics.props.ProxyPoints`) on the link carrying the effector's key point and
  the links rigidly attached to it (the G1's rubber hand on its wrist), the one nearest to the
  prop in the initializer at the run's middle frame (a sphere proxy: its centre, with the
  radius added to the anchor's height).
* **The anchor**: that point's x, y at the middle frame, pulled towards the top's centre until
  it is 2 cm inside the top's edges, at the top's height plus the prop rows' margin
  (``CollisionOptions.margin_m``, which keeps every proxy point that far out of a prop).
* **Rows**: ``|p_t + J_p dq_t - a| <= s_t`` per axis on every frame of the run (elastic, the
  frame's collision slack: :mod:`.props` prices the same slack), and the merit charges the
  frame's largest ``|p_t - a|``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..contacts.effectors import EffectorContacts
from ..contacts.phases import runs
from ..metrics.props import ProxyPoints, signed_distance
from .operators import Layout, Rows

#: How far inside a top's edges an anchor is placed [m].
EDGE_INSET_M = 0.02


@dataclass(frozen=True, eq=False)
class ContactPoints:
    """Robot points held on prop tops, one per contact run.

    Attributes:
        names: (C,) effector marker of each run.
        frames: (C,) robot frame carrying the point.
        local_m: (C, 3) the point in its frame [m].
        anchor_m: (C, 3) where it is held, in the world [m].
        prop: (C,) index of the prop.
        active: (T, C) bool frames of each run.
    """

    names: tuple[str, ...]
    frames: tuple[str, ...]
    local_m: np.ndarray
    anchor_m: np.ndarray
    prop: np.ndarray
    active: np.ndarray


def _inside_top(xy: np.ndarray, planes: np.ndarray, top: float, centre: np.ndarray
                ) -> np.ndarray:
    """(2,) ``xy`` moved along the line to the top's ``centre`` (2,) until ``EDGE_INSET_M``
    inside every side face of the prop (its planes (K, 4))."""
    for f in np.linspace(0.0, 1.0, 51):
        p = np.r_[(1 - f) * xy + f * centre, top - EDGE_INSET_M]
        if signed_distance(p, planes) <= -EDGE_INSET_M + 1e-9 or f == 1.0:
            return p[:2]
    return centre  # pragma: no cover - the loop returns at f = 1


def plan_contact_points(robot, q: np.ndarray, contacts: EffectorContacts,
                        planes: list[np.ndarray], tops_m: np.ndarray, margin_m: float
                        ) -> ContactPoints | None:
    """The held points of the effector contacts (see the module docstring).

    Args:
        robot: the robot; q: (T, nq) the initializer (with the lead frames).
        contacts: the effectors on tops, on the same T frames.
        planes: per prop (K, 4) outward face planes; tops_m: (P,) the props' top heights.
        margin_m: height kept above the top [m] (the prop rows' margin).
    """
    pts = ProxyPoints.of(robot)
    keypoints = robot.markers.keypoints
    names, frames, local, anchor, prop, active = [], [], [], [], [], []
    T = len(q)
    for i, e in enumerate(contacts.effectors):
        if e not in keypoints:
            continue
        rigid = set(robot.rigid_links(keypoints[e].frame)) | {keypoints[e].frame}
        sel = np.flatnonzero([pts.frames[o] in rigid for o in pts.owner])
        if not sel.size:
            continue
        for a, b in runs(contacts.contact[:, i]):
            k = int(contacts.prop[a, i])
            mid = (a + b) // 2
            world = pts.world(robot, q[mid:mid + 1])[0, sel]
            d = signed_distance(world, planes[k]) - pts.radius_m[sel]
            j = sel[int(np.argmin(d))]
            top = float(tops_m[k])
            xy = _inside_top(world[sel == j][0][:2], planes[k], top, _top_centre(planes[k]))
            names.append(e)
            frames.append(pts.frames[pts.owner[j]])
            local.append(pts.local_m[j])
            anchor.append(np.r_[xy, top + pts.radius_m[j] + margin_m])
            prop.append(k)
            run = np.zeros(T, dtype=bool)
            run[a:b] = True
            active.append(run)
    if not names:
        return None
    return ContactPoints(tuple(names), tuple(frames), np.array(local), np.array(anchor),
                         np.array(prop), np.stack(active, axis=1))


def _top_centre(planes: np.ndarray) -> np.ndarray:
    """(2,) the point of a convex prop's top deepest inside its side faces (planes (K, 4) with
    ``|n_z| < 0.1``): the Chebyshev centre of ``{xy : n . xy <= d}``, a 3-variable LP."""
    from scipy.optimize import linprog  # 0.08 s of imports, for scenes with props only

    side = planes[np.abs(planes[:, 2]) < 0.1]
    n, d = side[:, :2], side[:, 3]
    norm = np.linalg.norm(n, axis=1)
    res = linprog([0, 0, -1], A_ub=np.c_[n, norm], b_ub=d, bounds=[(None, None)] * 2 + [(0, None)])
    return res.x[:2] if res.success else np.zeros(2)


def contact_errors(points: np.ndarray, plan_points: ContactPoints
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(frames (N,), contacts (N,), anchor - point (N, 3) [m]) over the active samples;
    ``points`` (T, C, 3) the held points at the iterate."""
    tt, cc = np.nonzero(plan_points.active)
    return tt, cc, plan_points.anchor_m[cc] - points[tt, cc]


def touch_rows(out: Rows, points: np.ndarray, jacobians: np.ndarray, plan_points: ContactPoints,
               lay: Layout) -> None:
    """``|J_p dq_t - (a - p_t)| <= s_t`` per axis (the frame's collision slack), with the
    held points (T, C, 3) and their Jacobians (T, C, 3, nv) at the iterate."""
    tt, cc, err = contact_errors(points, plan_points)
    if not len(tt):
        return
    e = err.ravel()
    rows = lay.rows(np.repeat(tt, 3), jacobians[tt, cc].reshape(-1, lay.nv))
    slack = sp.csr_matrix((np.ones(len(e)), (np.arange(len(e)), np.repeat(
        tt * lay.nx + lay.offset["collision_slack"], 3))), shape=(len(e), lay.n))
    out.add(rows - slack, np.full(len(e), -np.inf), e)
    out.add(rows + slack, e, np.full(len(e), np.inf))


def touch_violation(points: np.ndarray, plan_points: ContactPoints) -> np.ndarray:
    """(T,) [m] each frame's largest ``|p_t - a|`` per axis over its held points (0 where none):
    what the frame's collision slack has to cover."""
    tt, _, err = contact_errors(points, plan_points)
    out = np.zeros(plan_points.active.shape[0])
    np.maximum.at(out, tt, np.abs(err).max(axis=1, initial=0.0))
    return out
