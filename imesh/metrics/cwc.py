"""Balance with any contacts: is the gravito-inertial wrench inside the contact wrench cone?

The evaluator's ZMP (:mod:`imesh.metrics.zmp`) is on the floor z = 0 and knows the soles only;
a robot standing on a box top, or with its hands on one, needs the contact wrench cone
(Caron, Pham & Nakamura, RSS 2015; :mod:`imesh.balance.cwc`). Measured from the motion alone,
without the plan that made it:

* **contacts** at every frame: each sole corner within ``touch_m`` above the surface under it
  (the floor, or the top of a prop it is over), and each proxy point
  (:class:`~imesh.metrics.props.ProxyPoints`) of a hand or knee link within ``touch_m`` above a
  prop's top; each a point contact with the surface's normal (up), friction ``mu``;
* **the wrench** the contacts must supply per unit mass, ``[c'' - g; (c - o) x (c'' - g) +
  Ld_G / m]``, with the evaluator's finite differences of q
  (:func:`imesh.metrics.derivatives.motion_derivatives`) and pinocchio's centroidal dynamics;
* **inside** when every face of the frame's cone holds within ``tolerance``; a frame without a
  contact is inside only in free fall (the required force below ``tolerance``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..balance.cwc import FRICTION, contact_wrench_cone, required_wrench
from ..contacts.phases import SIDES
from .derivatives import motion_derivatives
from .props import ProxyPoints, signed_distance

#: A sole corner or a hand / knee proxy point this close above a surface is a contact [m].
TOUCH_M = 0.010
#: Effectors besides the soles whose links can carry weight on a top.
CWC_EFFECTORS = ("hand_l", "hand_r", "knee_l", "knee_r")
#: A face value above this is outside the cone [m/s^2 per unit row] (1 mm of a lever at 1 g).
CWC_TOLERANCE = 0.01


@dataclass(frozen=True, eq=False)
class CwcBalance:
    """The contact wrench cone test per frame.

    Attributes:
        violation: (T,) largest face value of the required wrench (<= 0 inside) [m/s^2 per
            unit row]; for a frame without contact the required force's norm.
        contacts: (T,) number of contact points.
        inside: (T,) bool.
    """

    violation: np.ndarray
    contacts: np.ndarray
    inside: np.ndarray

    @property
    def fraction(self) -> float:
        """Frames inside over all frames."""
        return float(self.inside.mean()) if len(self.inside) else float("nan")

    def summary(self) -> dict:
        out = self.violation[~self.inside]
        return {"cwc_inside_fraction": self.fraction, "frames": int(len(self.inside)),
                "outside_frames": int((~self.inside).sum()),
                "no_contact_frames": int((self.contacts == 0).sum()),
                "worst_violation": float(out.max()) if len(out) else 0.0}


def effector_links(robot, effector: str) -> set[str]:
    """The links of a key point ``effector`` (``hand_l``, ...): its frame and the links rigidly
    attached to it (the proxies whose points can touch for it)."""
    frame = robot.markers.keypoints[effector].frame
    return set(robot.rigid_links(frame)) | {frame}


def _top_heights(points: np.ndarray, planes: Sequence[np.ndarray]) -> np.ndarray:
    """(...,) height of each point (..., 3) above the highest prop top it is over (the floor
    z = 0 where none): over a top when the point ``(x, y, top - 1 mm)`` is inside the prop and
    the point is no lower than 20 mm under the top."""
    best = np.full(points.shape[:-1], -np.inf)
    for pl in planes:
        up = pl[:, 2] > 0.9
        top = float((pl[up, 3] / pl[up, 2]).max())
        probe = points.copy()
        probe[..., 2] = top - 1e-3
        over = (signed_distance(probe, pl) <= 0.0) & (points[..., 2] >= top - 0.02)
        best = np.where(over, np.maximum(best, top), best)
    return best


def cwc_balance(robot, q: np.ndarray, fps: float, planes: Sequence[np.ndarray],
                touch_m: float = TOUCH_M, mu: float = FRICTION,
                tolerance: float = CWC_TOLERANCE) -> CwcBalance:
    """The contact wrench cone test of a motion among props (see the module docstring).

    Args:
        robot: the robot; q: (T, nq) its motion; fps: [1/s].
        planes: per prop, (K, 4) outward face planes in the robot's world.
    """
    q = np.asarray(q, float)
    T = len(q)
    pts = []
    soles = robot.trajectory_kinematics(q, [robot.soles[s].frame for s in SIDES]).placements
    for k, side in enumerate(SIDES):
        c = np.einsum("tij,cj->tci", soles[:, k, :3, :3], robot.soles[side].corners()) \
            + soles[:, k, None, :3, 3]
        pts.append(c)
    proxy = ProxyPoints.of(robot)
    keypoints = robot.markers.keypoints
    links: set[str] = set()
    for e in CWC_EFFECTORS:
        if e in keypoints:
            links |= effector_links(robot, e)
    sel = np.flatnonzero([proxy.frames[o] in links for o in proxy.owner])
    world = proxy.world(robot, q)[:, sel]
    world = world - np.array([0.0, 0.0, 1.0]) * proxy.radius_m[sel, None]  # sphere bottoms
    corners = np.concatenate(pts, axis=1)  # (T, 8, 3)
    top_c = np.maximum(_top_heights(corners, planes), 0.0)  # the floor under the rest
    h_c = corners[..., 2] - top_c
    top_e = _top_heights(world, planes)
    h_e = world[..., 2] - top_e  # -inf top: not over a prop (hands do not count on the floor)
    touch = np.concatenate([(h_c <= touch_m) & (h_c >= -touch_m),
                            np.isfinite(top_e) & (h_e <= touch_m) & (h_e >= -touch_m)], axis=1)
    where = np.concatenate([corners, world], axis=1)
    v, _ = motion_derivatives(q, fps)
    com, dh, _ = robot.centroidal_trajectory(q, v, fps)
    acc = dh[:, :3] / robot.mass
    violation = np.zeros(T)
    for t in range(T):  # one cone per frame: its contact set is the motion's own
        p = where[t, touch[t]]
        if not len(p):
            violation[t] = float(np.linalg.norm(acc[t] + [0.0, 0.0, 9.81]))
            continue
        cone = contact_wrench_cone(p, np.tile([0.0, 0.0, 1.0], (len(p), 1)), mu=mu)
        w = required_wrench(com[t], acc[t], dh[t, 3:], robot.mass, cone.ref_m)
        violation[t] = float(cone.violation(w))
    return CwcBalance(violation=violation, contacts=touch.sum(axis=1),
                      inside=violation <= tolerance)
