"""Point contacts of hands and knees on prop tops: where the reference rests them, for the
whole-body controller of the DART check (:mod:`imesh.physics.wbc`).

A robot climbing onto a box leans on its hands (and knees) on the box's top; the plan's contact
wrench cone counts them (:mod:`imesh.solve.props`), and so must the controller that tracks it,
or it asks the soles for a wrench they cannot give (the holosoma climb on the G1: the plan's ZMP
on box2's top 84-131 mm ahead of the sole centres, whose half length is 85 mm, while the left
hand rests on box1). The contacts are found from the reference alone, with the evaluator's rule
(:mod:`imesh.metrics.cwc`), on the proxy points near the effector's key point: an effector of
``CWC_EFFECTORS`` touches when its lowest such point (a sphere's bottom, a capsule's or box's
support point, within ``REACH_M`` of the key point in the nominal pose) is within ``touch_m`` of
the top of the prop it is over. Hands and knees never count on the floor (the evaluator's rule
too). The reach keeps a knee a knee: the G1's knee link carries the shank's capsule, whose
lower end stands 13 mm above box2's top beside the ankle while the robot stands on it.
numpy and the Robot only (no dartpy).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..metrics.cwc import CWC_EFFECTORS, effector_links
from ..metrics.props import ProxyPoints
from ..scene.surfaces import SupportSurfaces

#: The reference rests an effector on a top when its lowest point is this close to it [m]
#: (the evaluator's ``imesh.metrics.cwc.TOUCH_M`` is 10 mm; the plan's held points sit within
#: it, and a point hovering 20 mm above a top carries nothing in the plan either).
TOUCH_M = 0.02
#: The proxy points of an effector's links within this distance of its key point in the
#: nominal pose stand for it [m]: a hand's surface (the G1's rubber hand reaches 0.13 m from
#: its key point, JVRC-1's fingers 0.10), a knee's (not the shank's lower end, 0.32-0.41 m).
REACH_M = 0.15


@dataclass(frozen=True, eq=False)
class PointContacts:
    """Where the reference rests hands and knees on prop tops.

    Attributes:
        effectors: (E,) effector names (``hand_l``, ...).
        frames: (E, T) the link of each effector's contact point per reference frame.
        local_m: (E, T, 3) float the point in that link's frame [m] (a sphere's centre).
        radius_m: (E, T) float the point's distance to the surface it stands for (a sphere's
            radius, 0 for surface points) [m].
        planned: (T, E) bool the reference rests the effector on a top.
    """

    effectors: tuple[str, ...]
    frames: np.ndarray
    local_m: np.ndarray
    radius_m: np.ndarray
    planned: np.ndarray

    @property
    def any(self) -> bool:
        return bool(self.planned.any())


def planned_point_contacts(robot, q: np.ndarray, surfaces: SupportSurfaces,
                           touch_m: float = TOUCH_M) -> PointContacts:
    """The reference's hand and knee contacts on prop tops (module docstring).

    Args:
        robot: the robot (its key points name the effector links).
        q: (T, nq) float reference configurations.
        surfaces: the props' tops (without props nothing is planned).
        touch_m: an effector this close to a top rests on it [m].
    """
    q = np.atleast_2d(np.asarray(q, float))
    T = len(q)
    keypoints = robot.markers.keypoints if robot.markers is not None else {}
    proxy = ProxyPoints.of(robot)
    nominal = proxy.world(robot, robot.q_nominal[None])[0]  # (N, 3)
    effectors, sels = [], []
    for e in CWC_EFFECTORS:
        if e not in keypoints:
            continue
        kp = keypoints[e]
        links = effector_links(robot, e)
        at = robot.frame_positions(robot.q_nominal, [kp.frame], np.asarray([kp.offset]))[0]
        near = np.linalg.norm(nominal - at, axis=1) - proxy.radius_m <= REACH_M
        sel = np.flatnonzero([proxy.frames[o] in links and ok
                              for o, ok in zip(proxy.owner, near, strict=True)])
        if len(sel):
            effectors.append(e)
            sels.append(sel)
    E = len(effectors)
    frames = np.empty((E, T), dtype=object)
    local = np.zeros((E, T, 3))
    radius = np.zeros((E, T))
    planned = np.zeros((T, E), dtype=bool)
    if not E or surfaces.flat:
        return PointContacts(tuple(effectors), frames, local, radius, planned)
    world = proxy.world(robot, q)  # (T, N, 3)
    link_of_point = np.asarray(proxy.frames, dtype=object)[proxy.owner]  # (N,)
    for k, sel in enumerate(sels):
        bottom = world[:, sel, 2] - proxy.radius_m[sel]  # (T, n)
        low = sel[np.argmin(bottom, axis=1)]  # (T,) the lowest point of the effector
        p = world[np.arange(T), low]
        top = surfaces.heights(p - np.array([0.0, 0.0, 1.0]) * proxy.radius_m[low, None])
        h = p[:, 2] - proxy.radius_m[low] - top
        planned[:, k] = (top > 0.0) & (np.abs(h) <= touch_m)
        frames[k] = link_of_point[low]
        local[k] = proxy.local_m[low]
        radius[k] = proxy.radius_m[low]
    return PointContacts(tuple(effectors), frames, local, radius, planned)
