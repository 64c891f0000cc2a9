"""The whole method on a clip: capture -> cyclic motion -> contact schedule -> optimization.

``reduce_motion(motion, robot)`` runs Okada & Miyazaki's motion design for one robot and returns a
:class:`ReductionResult` with the report of ``imesh reduce`` (:meth:`ReductionResult.report`);
``save_reduction`` writes the motion (.npz, atomically).
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..core.motion import MarkerMotion
from ..errors import OptionError
from ..robot import ROBOTS_DIR, Robot, load_robot, load_robot_config, robot_names
from .capture import SagittalCapture, sagittal_capture
from .chain import JOINTS, PlanarChain
from .config import ReductionConfig
from .contact import ContactSchedule, contact_schedule
from .cyclic import CyclicMotion, make_cyclic
from .dynamics import ChainDynamics, chain_from_robot, planar_biped_chain
from .optimize import MotionOptimizer
from .result import IterationRecord, OptimizationResult

log = logging.getLogger(__name__)

#: Robots ``imesh reduce`` knows: the project's planar biped and 3D robots of robots/.
PLANAR_ROBOT = "planar_biped"


@dataclass(frozen=True)
class CycleConfig:
    """How the clip becomes the initial cyclic motion and the contact schedule.

    Attributes:
        samples: samples per cycle (None: the clip's frames per cycle).
        harmonics: harmonics kept by the FFT step of the cyclic processing.
        time_scale: period multiplier (1: the human timing).
        moving_angle: toe-up angle beta of the sliding foot [rad].
        transition_fraction: quintic foot-angle transitions, fraction of a half cycle.
    """

    samples: int | None = None
    harmonics: int = 10
    time_scale: float = 1.0
    moving_angle: float = 0.17
    transition_fraction: float = 0.3


@dataclass(frozen=True, eq=False)
class ReductionResult:
    """A robot motion designed from a clip, with everything needed to check it.

    Attributes:
        robot: robot name.
        chain: the robot's sagittal chain.
        capture: the clip in the sagittal plane (human IK).
        cyclic: the human cyclic motion.
        schedule: contact schedule.
        optimization: the optimization result (angles, torques, histories).
        ball_x: (n,) world x of the base foot's ball per sample (the robot walks forward).
        seconds: wall time of the whole method [s].
        source: the clip.
        last_step_m: the step at the end of the cycle, from the last sample's base ball to the
            next cycle's first base ball [m] (:func:`ball_positions`).
    """

    robot: str
    chain: PlanarChain
    capture: SagittalCapture
    cyclic: CyclicMotion
    schedule: ContactSchedule
    optimization: OptimizationResult
    ball_x: np.ndarray
    seconds: float
    source: str
    last_step_m: float = 0.0

    @property
    def dt(self) -> float:
        return self.cyclic.dt

    @property
    def n(self) -> int:
        return self.cyclic.n

    def joint_angles(self) -> np.ndarray:
        return self.chain.joint_angles(self.optimization.phi)

    def report(self) -> dict:
        """The ``imesh reduce --json`` report (keys of the command-line contract first)."""
        opt = self.optimization
        fin, ini = opt.final, opt.initial
        grf = np.where(fin.dyn.grf_active, fin.dyn.grf, np.nan)
        q = self.joint_angles()
        ang_viol = int(np.sum(self.chain.joint_limits_violated(q)))
        tq_viol = int(np.sum(np.abs(opt.torque) > self.chain.effort + 1e-9))
        # inverse dynamics of the final trajectory (RNEA), as a cross-check of the forces
        dyn = ChainDynamics(self.chain)
        u_id, lam_id = dyn.inverse(opt.phi, opt.phid, opt.phidd, self.schedule.base,
                                   self.schedule.case, torque_ref=opt.torque)
        friction = np.abs(fin.dyn.lam[:, 0]) / np.maximum(fin.dyn.lam[:, 1], 1e-9)
        step = float(self.ball_x[-1] - self.ball_x[0])
        rep = {
            "J_m_initial": ini.J_m,
            "J_m_final": fin.J_m,
            "J_r_final": fin.J_r,
            "min_vertical_grf_N": float(np.nanmin(grf)),
            "angle_violations": ang_viol,
            "torque_violations": tq_viol,
            "closure_error_mm": float(1e3 * np.max(np.abs(fin.y))),
            "iterations": len(opt.history) - 1,
            "seconds": self.seconds,
            # more evidence
            "robot": self.robot,
            "source": self.source,
            "J_r_initial": ini.J_r,
            "J_m_reduction": ini.J_m / max(fin.J_m, 1e-300),
            "E_initial": ini.E,
            "E_final": fin.E,
            "converged": opt.converged,
            "optimization_seconds": opt.seconds,
            "rank": opt.config.subspace.rank,
            "method": opt.config.solver.method,
            "pca_explained": None if opt.basis is None else opt.basis.explained(),
            "pca_singular_values": None if opt.basis is None else
            opt.basis.singular_values.tolist(),
            "closure_error_initial_mm": float(1e3 * np.max(np.abs(ini.y))),
            "change_from_human_rms_deg": float(np.degrees(np.sqrt(np.mean(
                (opt.phi[:, 1:6] - ini.phi[:, 1:6]) ** 2)))),
            "step_error_mm": float(1e3 * np.max(np.abs(fin.step))),
            "slip_at_switch_m_s": float(np.max(np.abs(fin.slip))),
            "acc_residual_rms_rad_s2": float(np.sqrt(np.mean(fin.residual ** 2))),
            "torque_max_Nm": np.abs(opt.torque).max(axis=0).tolist(),
            "torque_limit_Nm": self.chain.effort.tolist(),
            "joint_range_rad": [q.min(axis=0).tolist(), q.max(axis=0).tolist()],
            "joint_limits_rad": [self.chain.q_lower.tolist(), self.chain.q_upper.tolist()],
            "grf_min_by_contact_N": {k: float(np.nanmin(grf[:, i]))
                                     for i, k in enumerate(("base_ball", "base_tip",
                                                            "moving_roller"))},
            "torque_inverse_dynamics_median_diff_Nm": float(np.median(np.abs(u_id - opt.torque))),
            "friction_ratio_max": float(np.max(friction)),
            "period_s": self.cyclic.period_s,
            "samples": self.n,
            "stride_m": step + self.last_step_m,
            "cyclic": self.cyclic.report.as_dict(),
            "ik_rms_mm": 1e3 * self.capture.ik_rms_m,
            "out_of_plane_rms_mm": 1e3 * self.capture.out_of_plane_rms_m,
            "contact": {"switch_sample": int(self.schedule.switches[1]),
                        "transition_samples": self.schedule.transition,
                        "pad_angle_deg": np.degrees(self.schedule.pad_angle).tolist(),
                        "moving_angle_deg": float(np.degrees(self.schedule.moving_angle))},
            "history": [h.__dict__ for h in opt.history],
            "chain": {"mass_kg": self.chain.total_mass, "height_m": self.chain.height,
                      "source": self.chain.source},
        }
        return rep


def resolve_chain(robot: str | PlanarChain | Robot) -> tuple[str, PlanarChain]:
    """A robot name (planar_biped, or a robot of robots/ such as jvrc1), a PlanarChain or a
    loaded Robot, as (name, chain)."""
    if isinstance(robot, PlanarChain):
        return robot.name, robot
    if isinstance(robot, str):
        if robot == PLANAR_ROBOT:
            return robot, planar_biped_chain()
        if robot.endswith(".urdf"):
            return os.path.basename(robot), planar_biped_chain(robot)
        known = sagittal_robots()
        if robot not in known and not os.path.exists(robot):
            raise OptionError("robot", robot, [PLANAR_ROBOT, *known, "a planar biped .urdf"])
        robot = load_robot(robot)
    return robot.name, chain_from_robot(robot)


def sagittal_robots() -> list[str]:
    """The robots of robots/ whose robot.toml names their sagittal joints (``[sagittal]``)."""
    return [n for n in robot_names()
            if load_robot_config(ROBOTS_DIR / n / "robot.toml").sagittal_joints]


def ball_positions(chain: PlanarChain, phi: np.ndarray, schedule: ContactSchedule
                   ) -> tuple[np.ndarray, float]:
    """World x of the base ball per sample over one cycle starting at 0, and the step taken at
    the end of the cycle (to the next cycle's first base ball)."""
    n = phi.shape[0]
    x = np.zeros(n)
    pts = chain.points_world(phi, schedule.base, np.zeros(n))
    cur = 0.0
    last = 0.0
    for k in range(n):
        if k > 0 and schedule.base[k] != schedule.base[k - 1]:
            side = "lr"[schedule.base[k]]
            cur = cur + pts[f"ball_{side}"][k - 1, 0]
        x[k] = cur
    side = "lr"[schedule.base[0]]
    last = pts[f"ball_{side}"][n - 1, 0]
    return x, float(last)


def reduce_motion(motion: MarkerMotion, robot: str | PlanarChain | Robot = PLANAR_ROBOT,
                  config: ReductionConfig | None = None, cycle: CycleConfig | None = None,
                  progress: Callable[[IterationRecord], None] | None = None
                  ) -> ReductionResult:
    """Design a dynamically consistent cyclic robot motion from a human walking clip.

    Args:
        motion: the clip (any format imesh reads).
        robot: "planar_biped", a robot of robots/ with known sagittal joints ("jvrc1", "g1"),
            a PlanarChain or a loaded Robot.
        config: optimization settings.
        cycle: cyclic processing and contact schedule settings.
        progress: called after every iteration.
    """
    t0 = time.perf_counter()
    config = config or ReductionConfig()
    cycle = cycle or CycleConfig()
    name, chain = resolve_chain(robot)
    cap = sagittal_capture(motion)
    cyc = make_cyclic(cap, n=cycle.samples, harmonics=cycle.harmonics,
                      time_scale=cycle.time_scale)
    if not 0 < cycle.moving_angle < 0.6:
        raise OptionError("moving-foot angle [rad]", cycle.moving_angle, "(0, 0.6)")
    sched = contact_schedule(cyc.n, cyc.left_toe_off, chain.pad_angle, cycle.moving_angle,
                             cycle.transition_fraction)
    opt = MotionOptimizer(chain, sched, cyc.angles, cyc.dt, config)
    res = opt.run(progress)
    ball_x, last = ball_positions(chain, res.phi, sched)
    seconds = time.perf_counter() - t0
    log.info("%s on %s: J_m %.3g -> %.3g in %d iterations (%.1f s)", motion.source, name,
             res.initial.J_m, res.final.J_m, len(res.history) - 1, seconds)
    return ReductionResult(robot=name, chain=chain, capture=cap, cyclic=cyc, schedule=sched,
                           optimization=res, ball_x=ball_x, seconds=seconds,
                           source=motion.source, last_step_m=last)


#: Keys of the .npz written by save_reduction.
NPZ_KEYS = ("robot", "source", "fps", "period_s", "link_names", "joint_names", "link_angles",
            "link_rates", "link_accelerations", "joint_angles", "joint_velocities",
            "torques", "base_foot", "contact_case", "grf_vertical", "grf_names", "base_ball_x",
            "initial_link_angles", "human_link_angles", "J_m_history", "J_r_history")


__all__ = ["CycleConfig", "ReductionResult", "reduce_motion", "JOINTS",
           "resolve_chain", "ball_positions", "sagittal_robots"]
