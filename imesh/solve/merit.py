"""The exact-penalty merit of the whole-body SQP: what a step must lower to be taken.

The QP's objective terms (:mod:`.costs`, the ZMP band of :mod:`.zmp`) evaluated on the
nonlinear trajectory, plus each elastic row's slack price times the violation its slack would
have to cover (:mod:`.contacts`, :mod:`.zmp`, :mod:`.forces`, :mod:`.limits`,
:mod:`.collision`), so the line search of :func:`imesh.solve.sqp.solve_whole_body` measures
progress as the QP prices it.
"""

from __future__ import annotations

import numpy as np

from .collision import collision_violation
from .config import WholeBodyConfig
from .contacts import clearance, sole_errors
from .costs import world_coordinates
from .cwc import cone_violation
from .forces import normal_bounds
from .plan import GRAVITY, Linearization, Plan
from .props import shared_violation
from .touches import touch_violation
from .zmp import zmp_frames


def merit(lin: Linearization, plan: Plan, q: np.ndarray, config: WholeBodyConfig,
          speeds: bool = False) -> float:
    """The exact-penalty merit of a trajectory: the QP's objective terms evaluated on the
    nonlinear trajectory (``1/2 sum w |r|^2``) plus the slack prices times the violations the
    slacks would have to cover (ZMP outside the shrunk polygon, soles off their footprints,
    swing ground points below the clearance). An SQP step is accepted when it lowers this.
    ``speeds``: the joint speeds above their margin-reduced limits are priced too, as what
    the elastic mode's speed slack covers (:func:`imesh.solve.limits.motion_rows`).
    """
    e = lin.points - plan.marker_points
    f = np.einsum("tka,tkl,tla->", e, plan.mesh_metric, e)
    if lin.axes.shape[1]:
        w = (config.costs.direction * plan.direction_weights) ** 2
        f += np.einsum("d,tda->", w, (lin.axes - plan.target_directions) ** 2)
    f += config.costs.init * np.sum((q[:, 7:] - plan.q_init[:, 7:]) ** 2)
    T = len(q)
    if T >= 3 and config.costs.accel > 0:
        y = world_coordinates(q, lin.base_rotations)
        f += config.costs.accel * np.sum((np.diff(y, 2, axis=0) * (plan.fps / 30.0) ** 2) ** 2)
    sup = plan.supported
    band = sup if plan.props is None else zmp_frames(plan)
    over = np.maximum(np.abs(lin.zmp_multibody - plan.desired_zmp)[band] - config.zmp.band_m,
                      0)
    f += np.sum(plan.zmp_weights[band][:, None] * over ** 2)
    penalty = 0.0
    hp_frame, hp_n, hp_b = plan.halfplanes
    if len(hp_frame):
        out = hp_b - np.sum(hp_n * lin.zmp_multibody[hp_frame], axis=1)
        worst = np.zeros(T)
        np.maximum.at(worst, hp_frame, out)
        penalty += config.slack.balance * np.sum(np.maximum(worst, 0.0))
    _, _, err = sole_errors(lin, plan)
    penalty += config.slack.elastic * np.sum(np.abs(err).max(axis=1, initial=0.0))
    tt, kk = np.nonzero(~plan.support)
    if len(tt):
        short = clearance(plan, config)[tt, kk] - lin.corners[tt, kk, :, 2].min(axis=1)
        worst = np.zeros(T)
        np.maximum.at(worst, tt, short)
        penalty += config.slack.elastic * np.sum(np.maximum(worst, 0.0))
    if lin.body_z.shape[1]:
        penalty += config.slack.elastic * np.sum(np.maximum(-lin.body_z.min(axis=1), 0.0))
    az = lin.com_acceleration[:, 2]
    low, high = normal_bounds(plan, config)
    fl = ~sup
    penalty += config.slack.balance * (
        np.sum(np.maximum(low[sup] - az[sup], 0.0))
        + np.sum(np.maximum(az[sup] - high[sup], 0.0))
        + (np.sum(np.maximum(np.abs(lin.com_acceleration[sup, :2]).max(axis=1)
                             - config.forces.friction / np.sqrt(2.0) * (GRAVITY + az[sup]), 0.0))
           if config.forces.friction > 0 else 0.0)
        + np.sum(np.abs(az[fl] + GRAVITY))
        + np.sum(np.abs(lin.com_acceleration[fl, :2]).max(axis=1, initial=0.0))
        + np.sum(np.abs(lin.angular_momentum_rate[fl, :2] / lin.mass).max(axis=1, initial=0.0)))
    if plan.kinetic is not None and config.forces.kinetic_friction > 0:
        kin = np.isfinite(plan.kinetic).all(axis=1) & sup
        u = plan.kinetic[kin]
        a_xy = lin.com_acceleration[kin, :2]
        along = np.sum(a_xy * u, axis=1)
        across = a_xy[:, 1] * u[:, 0] - a_xy[:, 0] * u[:, 1]
        cap = config.forces.kinetic_friction * (GRAVITY + az[kin])
        penalty += config.slack.balance * np.sum(np.maximum.reduce(
            [np.maximum(-along, 0.0), np.maximum(along - cap, 0.0), np.abs(across)]))
    if plan.cones is not None:
        penalty += config.slack.balance * np.sum(cone_violation(lin, plan))
    if lin.torques is not None:
        penalty += config.slack.balance * np.sum(lin.torques.excess(1.0 - config.margins.torque))
    over = np.abs(np.diff(q[:, 7:], 2, axis=0)) - plan.a_max * (1.0 / plan.fps) ** 2 * (
        1 - config.margins.acceleration)
    accel = np.maximum(over.max(axis=1, initial=0.0), 0.0)
    penalty += config.slack.elastic * np.sum(accel)
    if speeds:  # a frame's slack covers its speeds beyond what its accelerations took
        fast = np.abs(np.diff(q[:, 7:], 1, axis=0)) - plan.v_max / plan.fps * (
            1 - config.margins.velocity)
        shared = np.zeros(max(T - 1, 0))
        shared[:len(accel)] = accel
        penalty += config.slack.elastic * np.sum(
            np.maximum(fast.max(axis=1, initial=0.0) - shared, 0.0))
    if lin.props is not None or lin.obstacles is not None:  # one slack per frame for all
        # (imesh.solve.props, imesh.solve.obstacles) and the held points (imesh.solve.touches)
        held = (None if plan.points is None or lin.held_points is None
                else touch_violation(lin.held_points, plan.points))
        penalty += config.slack.elastic * shared_violation(lin.collision, lin.props,
                                                            config.collision.margin_m,
                                                            lin.obstacles, held)
    elif lin.collision is not None:
        penalty += config.slack.elastic * collision_violation(lin.collision,
                                                               config.collision.margin_m)
    return float(0.5 * f + penalty)
