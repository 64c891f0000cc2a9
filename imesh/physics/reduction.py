"""Physics check of a designed cyclic motion in DART, the robot held in the sagittal plane.

The planar biped's URDF is loaded with a planar root joint (x, z translation, pitch about y) so
the robot cannot fall sideways, on a flat ground with friction; the heel rollers are frictionless
(free rollers carry vertical force only), the toe pads have friction. The joints follow the
designed motion with the computed torques as feed-forward plus a light PD on the joint angles
(1 kHz), for several cycles, starting from the designed state at sample 0.

dartpy is imported lazily (only here).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from ..core.checks import require_count, require_finite
from ..errors import ImeshError
from ..reduction.chain import joint_matrix, rot
from ..reduction.dynamics import PLANAR_BIPED_URDF
from .world import dartpy

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PDGains:
    """A proportional-derivative feedback on an angle.

    Attributes:
        kp: [Nm/rad] stiffness.
        kd: [Nm s/rad] damping.
    """

    kp: float
    kd: float

    def __post_init__(self) -> None:
        require_finite(self, ("kp", "kd"), positive=False)


@dataclass(frozen=True)
class DartConfig:
    """Settings of the physics check.

    Attributes:
        cycles: cycles to run.
        time_step: [s] simulation step.
        friction: friction coefficient of the toe pads and the ground (rollers: 0).
        clip_torque: saturate the total torque at the robot's limits.
        joints: PD on the joint angles, added to the designed torques.
        torso: PD on the torso pitch (the one link angle no joint measures), applied through
            the base leg's hip instead of that hip's joint PD; zero gains for joint PD only.
    """

    cycles: int = 3
    time_step: float = 1e-3
    friction: float = 0.8
    clip_torque: bool = True
    joints: PDGains = field(default_factory=lambda: PDGains(kp=30.0, kd=0.5))
    torso: PDGains = field(default_factory=lambda: PDGains(kp=30.0, kd=1.0))

    def __post_init__(self) -> None:
        require_count(self, ("cycles",))
        require_finite(self, ("time_step",), positive=True)
        require_finite(self, ("friction",), positive=False)


@dataclass
class DartReport:
    """What happened in DART.

    Attributes:
        fell: the torso dropped, tipped over or a leg/torso body touched the ground.
        survived_s: simulated time before a fall (the full time otherwise) [s].
        duration_s: time asked for [s].
        tracking_rms_rad: RMS joint-angle error over the run.
        tracking_max_rad: largest joint-angle error.
        torso_pitch_rms_rad: RMS error of the (unactuated) torso pitch.
        torque_ratio_max: largest |total torque| / limit (before saturation).
        feedback_share: RMS PD torque / RMS total torque.
        distance_m: forward travel of the torso; planned_distance_m: the design's.
        samples: time series (t, q, q_ref, torso x/z/pitch, contact force) for plots.
    """

    fell: bool
    survived_s: float
    duration_s: float
    tracking_rms_rad: float
    tracking_max_rad: float
    torso_pitch_rms_rad: float
    torque_ratio_max: float
    feedback_share: float
    distance_m: float
    planned_distance_m: float
    fall_reason: str = ""
    samples: dict = field(default_factory=dict, repr=False)

    def summary(self) -> dict:
        return {k: v for k, v in self.__dict__.items() if k != "samples"}


def planar_urdf_text(urdf_path=PLANAR_BIPED_URDF) -> str:
    """The URDF with a world link and a planar root joint (x-z plane, pitch about y)."""
    text = open(urdf_path).read()
    head = '<robot name="planar_biped">'
    if head not in text:
        raise ImeshError(f"{urdf_path}: not the planar biped URDF (no {head})")
    return text.replace(head, head + """
  <link name="world"/>
  <joint name="planar_root" type="planar">
    <parent link="world"/><child link="torso"/>
    <origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>
  </joint>""", 1)


def _periodic_spline(values: np.ndarray, period: float):
    n = values.shape[0]
    t = np.arange(n + 1) * period / n
    return CubicSpline(t, np.concatenate([values, values[:1]], axis=0), bc_type="periodic",
                       axis=0)


def _initial_state(result) -> tuple[np.ndarray, np.ndarray]:
    """DART positions/velocities (planar z, x, pitch, 6 joints) at sample 0."""
    ch = result.chain
    o = result.optimization
    phi, phid = o.phi[0], o.phid[0]
    base = int(result.schedule.base[0])
    pts = ch.chain_points(phi[None], base)[0]
    hip = pts[3]                                   # base-side hip = torso frame origin
    # velocity of the hip with the base ball fixed: sum over the chain links below it
    seg, order = ch._segments(base)
    w = rot(phi[list(order)][:3], seg[:3])          # ball->ankle, ankle->knee, knee->hip
    rates = phid[list(order)][:3]
    vhip = np.array([np.sum(w[:, 1] * rates), -np.sum(w[:, 0] * rates)])
    q = np.concatenate([[hip[1], hip[0], phi[3]], ch.joint_angles(phi)])
    qd_j = ch.joint_sign * (phid @ joint_matrix().T)
    v = np.concatenate([[vhip[1], vhip[0], phid[3]], qd_j])
    return q, v


def simulate_planar(result, config: DartConfig | None = None, urdf_path=PLANAR_BIPED_URDF
                    ) -> DartReport:
    """Run a designed motion of the planar biped in DART (see the module docstring)."""
    if result.robot != "planar_biped":
        raise ImeshError(f"the DART check runs the planar biped only (got {result.robot!r})")
    dart = dartpy()
    cfg = config or DartConfig()
    world = dart.simulation.World()
    world.setTimeStep(cfg.time_step)
    world.setGravity([0.0, 0.0, -9.81])
    # ground
    ground = dart.dynamics.Skeleton("ground")
    gj, gb = ground.createWeldJointAndBodyNodePair()
    tf = dart.math.Isometry3()
    tf.set_translation([0.0, 0.0, -0.05])
    gj.setTransformFromParentBodyNode(tf)
    sn = gb.createShapeNode(dart.dynamics.BoxShape([50.0, 2.0, 0.1]))
    sn.createVisualAspect()
    sn.createCollisionAspect()
    sn.createDynamicsAspect().setFrictionCoeff(cfg.friction)
    world.addSkeleton(ground)
    # robot
    loader = dart.utils.DartLoader()
    opts = dart.utils.DartLoader.Options()
    tiny = dart.dynamics.Inertia()
    tiny.setMass(1e-6)
    tiny.setMoment(1e-10 * np.eye(3))
    opts.mDefaultInertia = tiny
    loader.setOptions(opts)
    robot = loader.parseSkeletonString(planar_urdf_text(urdf_path), "")
    if robot is None:
        raise ImeshError(f"DART could not parse {urdf_path}")
    robot.disableSelfCollisionCheck()
    for i in range(robot.getNumBodyNodes()):
        bn = robot.getBodyNode(i)
        mu = 0.0 if bn.getName().startswith("roller") else cfg.friction
        for s in bn.getShapeNodes():
            if s.hasDynamicsAspect():
                s.getDynamicsAspect().setFrictionCoeff(mu)
    world.addSkeleton(robot)
    ch = result.chain
    o = result.optimization
    period = result.cyclic.period_s
    q0, v0 = _initial_state(result)
    robot.setPositions(q0)
    robot.setVelocities(v0)
    q_ref = _periodic_spline(result.joint_angles(), period)
    u_ref = _periodic_spline(o.torque, period)
    dq_ref = q_ref.derivative()
    limit = ch.effort
    steps = int(round(cfg.cycles * period / cfg.time_step))
    rec_every = max(1, int(round(0.01 / cfg.time_step)))
    rec: dict[str, list[Any]] = {k: [] for k in ("t", "q", "q_ref", "torso", "u_ff", "u_fb",
                                                 "grf", "contact_fz", "toe_x")}
    contact_bodies = ("toe_l", "roller_l", "toe_r", "roller_r")
    toes = [robot.getBodyNode("toe_l"), robot.getBodyNode("toe_r")]
    fell, reason = False, ""
    torso0 = q0[:3].copy()
    err2, errmax, n_err, pitch2, ratio, fb2, tot2 = 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0.0
    nonfoot = {"torso", "thigh_l", "thigh_r", "shank_l", "shank_r"}
    t = 0.0
    phi_torso = _periodic_spline(o.phi[:, 3:4], period)
    dphi_torso = phi_torso.derivative()
    for k in range(steps):
        t = k * cfg.time_step
        q = robot.getPositions()
        v = robot.getVelocities()
        qr = q_ref(t % period)
        ur = u_ref(t % period)
        fb = cfg.joints.kp * (qr - q[3:]) + cfg.joints.kd * (dq_ref(t % period) - v[3:])
        if cfg.torso.kp or cfg.torso.kd:
            k_s = int(t % period / period * result.n) % result.n
            hip = 3 * int(result.schedule.base[k_s])       # the base leg's hip joint
            et = phi_torso(t % period)[0] - q[2]
            wt = dphi_torso(t % period)[0] - v[2]
            fb[hip] = -(cfg.torso.kp * et + cfg.torso.kd * wt) * ch.joint_sign[hip]
        u = ur + fb
        ratio = max(ratio, float(np.max(np.abs(u) / limit)))
        if cfg.clip_torque:
            u = np.clip(u, -limit, limit)
        tau = np.zeros(robot.getNumDofs())
        tau[3:] = u
        robot.setForces(tau)
        world.step()
        e = qr - q[3:]
        err2 += float(np.sum(e ** 2))
        n_err += e.size
        errmax = max(errmax, float(np.max(np.abs(e))))
        pitch2 += float((phi_torso(t % period)[0] - q[2]) ** 2)
        fb2 += float(np.sum(fb ** 2))
        tot2 += float(np.sum((ur + fb) ** 2))
        res = world.getLastCollisionResult()
        hit = ""
        fz = 0.0
        per_body = np.zeros(len(contact_bodies))
        for c in res.getContacts():
            f = abs(float(np.asarray(c.force)[2]))
            fz += f
            for obj in (c.collisionObject1, c.collisionObject2):
                body = obj.getShapeFrame().getName().split("_ShapeNode")[0]
                if body in contact_bodies:
                    per_body[contact_bodies.index(body)] += f
                if any(body.startswith(b) for b in nonfoot):
                    hit = body
        if k % rec_every == 0:
            rec["t"].append(t)
            rec["q"].append(q[3:].copy())
            rec["q_ref"].append(qr)
            rec["torso"].append(q[:3].copy())
            rec["u_ff"].append(ur)
            rec["u_fb"].append(fb)
            rec["grf"].append(fz)
            rec["contact_fz"].append(per_body)
            rec["toe_x"].append([float(b.getWorldTransform().translation()[0]) for b in toes])
        if hit or q[0] < 0.5 * torso0[0] or abs(q[2]) > 1.0 or not np.all(np.isfinite(q)):
            fell = True
            reason = (f"{hit} touched the ground" if hit else
                      "torso dropped" if q[0] < 0.5 * torso0[0] else
                      "torso tipped" if abs(q[2]) > 1.0 else "non-finite state")
            break
    survived = (k + 1) * cfg.time_step
    final = robot.getPositions()
    planned = (float(result.ball_x[-1] - result.ball_x[0])
               + result.last_step_m) * cfg.cycles
    samples = {k: np.array(v) for k, v in rec.items()}
    rep = DartReport(
        fell=fell, survived_s=survived, duration_s=steps * cfg.time_step,
        tracking_rms_rad=float(np.sqrt(err2 / max(n_err, 1))), tracking_max_rad=errmax,
        torso_pitch_rms_rad=float(np.sqrt(pitch2 / max(k + 1, 1))), torque_ratio_max=ratio,
        feedback_share=float(np.sqrt(fb2 / max(tot2, 1e-12))),
        distance_m=float(final[1] - torso0[1]), planned_distance_m=planned,
        fall_reason=reason, samples=samples)
    log.info("DART: %s after %.2f s, tracking RMS %.3f rad", "fell" if fell else "walked",
             survived, rep.tracking_rms_rad)
    return rep
