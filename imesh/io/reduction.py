"""The file of a motion reduction (:mod:`imesh.reduction`): one cycle of a planar robot, .npz."""

from __future__ import annotations

import os

import numpy as np

from ..errors import OptionError
from ..reduction.chain import LINKS, joint_matrix
from ..reduction.pipeline import ReductionResult
from .atomic import atomic_path


def save_reduction(path: str | os.PathLike, result: ReductionResult) -> None:
    """Write the robot motion of one cycle as .npz (atomically).

    Keys: ``robot``, ``source``, ``fps`` (samples per second of the cycle), ``period_s``,
    ``link_names`` (7,), ``joint_names`` (6,) (the robot's names), ``link_angles``,
    ``link_rates``, ``link_accelerations`` (n, 7) [rad, rad/s, rad/s^2] (absolute pitch of each
    link, 0 upright), ``joint_angles``, ``joint_velocities`` (n, 6), ``torques`` (n, 6) [Nm],
    ``base_foot`` (n,) 0 left / 1 right, ``contact_case`` (n,) 1 toe line / 2 toe point,
    ``grf_vertical`` (n, 3) [N] with ``grf_names``, ``base_ball_x`` (n,) [m],
    ``initial_link_angles``, ``human_link_angles`` (n, 7), ``J_m_history``, ``J_r_history``.
    """
    path = os.fspath(path)
    if not path.endswith(".npz"):
        raise OptionError("output file", path, "a .npz file")
    o = result.optimization
    ch = result.chain
    qd = o.phid @ (ch.joint_sign[:, None] * joint_matrix()).T
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(
            fh, robot=np.str_(result.robot), source=np.str_(result.source),
            fps=np.float64(1.0 / result.dt), period_s=np.float64(result.cyclic.period_s),
            link_names=np.array(LINKS), joint_names=np.array(ch.joint_names),
            link_angles=o.phi, link_rates=o.phid, link_accelerations=o.phidd,
            joint_angles=result.joint_angles(), joint_velocities=qd, torques=o.torque,
            base_foot=result.schedule.base, contact_case=result.schedule.case,
            grf_vertical=o.final.dyn.grf,
            grf_names=np.array(["base_ball", "base_tip", "moving_roller"]),
            base_ball_x=result.ball_x, initial_link_angles=o.initial.phi,
            human_link_angles=result.cyclic.angles,
            J_m_history=np.array([h.J_m for h in o.history]),
            J_r_history=np.array([h.J_r for h in o.history]))
