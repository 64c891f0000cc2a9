"""The nominal standing pose of a robot: robot.toml's nominal joints, ankles adjusted so that
both soles are level, the base level above the origin at the height that puts the soles on the
ground z = 0."""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import numpy as np

from ..core.skew import skew
from .config import SIDES
from .errors import RobotConfigError
from .pin import _pinocchio

if TYPE_CHECKING:  # pragma: no cover - typing only
    from .model import Robot

log = logging.getLogger(__name__)


def standing_pose(robot: Robot) -> np.ndarray:
    """(nq,) float the nominal standing pose of ``robot`` (its ``q_nominal`` is not used).

    The two joints closest to each foot (ankle pitch and roll) are turned, by Gauss-Newton on
    the sole normal, until the sole is level; the base is then lowered so that both soles are
    on z = 0.

    Raises:
        RobotConfigError: a sole cannot be levelled, the soles end at different heights, or
            the pose is outside the position limits.
    """
    pin = _pinocchio()
    cfg = robot.config
    model = robot.model
    data = robot.configuration.data
    q = np.zeros(robot.nq)
    q[6] = 1.0
    for n in robot.joint_names:
        q[7 + robot.joint_index(n)] = cfg.nominal.get(n, 0.0)
    z = np.array([0.0, 0.0, 1.0])
    for side in SIDES:
        sole = robot.soles[side]
        fid = robot.frame_id(sole.frame)
        # the two joints closest to the foot level the sole (ankle pitch and roll)
        j = model.frames[fid].parentJoint
        chain = [j, model.parents[j]]
        cols = [model.joints[k].idx_v for k in chain if k > 1]
        qcols = [model.joints[k].idx_q for k in chain if k > 1]
        for _ in range(50):
            robot.forward(q)
            n = data.oMf[fid].rotation @ sole.normal
            err = n - z
            if np.linalg.norm(err) < 1e-13:
                break
            Jw = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[3:, cols]
            dn = -skew(n) @ Jw  # d n / d theta
            step = np.linalg.lstsq(dn, -err, rcond=None)[0]
            q[qcols] += step
        else:
            raise RobotConfigError(f"cannot level the {side} sole with the ankle joints",
                                   path=cfg.path, key="nominal")
        moved = {model.names[k]: q[model.joints[k].idx_q]
                 - cfg.nominal.get(model.names[k], 0.0) for k in chain if k > 1}
        if any(abs(d) > 1e-3 for d in moved.values()):
            log.info("robot %s: nominal %s adjusted by %s rad to level the %s sole",
                     robot.name, ", ".join(moved),
                     ", ".join(f"{d:+.4f}" for d in moved.values()), side)
    robot.forward(q)
    heights = {s: robot.sole_center(None, s)[2] for s in SIDES}
    if abs(heights["left"] - heights["right"]) > 1e-6:
        raise RobotConfigError(
            f"the nominal pose puts the soles at different heights (left {heights['left']:.4f}"
            f" m, right {heights['right']:.4f} m relative to the base): use a symmetric "
            "[nominal] leg pose", path=cfg.path, key="nominal")
    q[2] = -(heights["left"] + heights["right"]) / 2
    bad = [n for i, n in enumerate(robot.joint_names)
           if not robot.q_lower[i] - 1e-9 <= q[7 + i] <= robot.q_upper[i] + 1e-9]
    if bad:
        raise RobotConfigError(f"nominal pose outside the position limits for "
                               f"{', '.join(bad)}", path=cfg.path, key="nominal")
    return q
