"""Pinocchio side of a planar (sagittal) chain: lumping a model's bodies into a few links and
the dynamics of the chain rooted at a foot (Okada & Miyazaki's motion reduction,
:mod:`imesh.reduction`).

The reduction works with numbers only (:class:`imesh.reduction.chain.PlanarChain`); this module
is where those numbers come from and where the chain's equations of motion are evaluated:

- :func:`lump_urdf` and :func:`lump_robot` read a model in its zero pose (a planar biped's URDF,
  or a loaded 3D robot with every joint but the sagittal ones locked) and lump the rigid bodies
  between the given sagittal joints into one link each (mass, centre of mass and rotational
  inertia in the x-z plane, joint points and axis signs);
- :class:`RootedChain` is the chain as a pinocchio model rooted at a foot's ball by a planar
  root (x, z translation, pitch about the ball), with the mass matrix, the nonlinear effects,
  RNEA and its derivatives, and the energies in numpy terms.

Every pinocchio call of the reduction lives here; pinocchio is imported lazily (as in
:mod:`imesh.robot.model`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np

from ..core.lazy import optional
from ..errors import ImeshError


class ChainError(ImeshError):
    """A planar chain cannot be built from a robot model (missing joint, link, frame)."""


def _pin() -> ModuleType:
    return optional("pinocchio", "pip install pin", "motion reduction")


@dataclass(frozen=True, eq=False)
class LumpedLinks:
    """A model's bodies lumped into the links between its sagittal joints, in the pose lumped.

    Attributes:
        mass: (L,) [kg] link masses.
        com: (L, 2) [m] centres of mass (x, z), world.
        inertia: (L, 3, 3) [kg m^2] rotational inertia about the centre of mass, world axes.
        joint_xz: (J, 2) [m] joint axis points (x, z) of the sagittal joints, world.
        joint_sign: (J,) +1 or -1: the joint turns about +y or -y in the world.
        joint_ids: (J,) the joints' pinocchio indices.
        groups: link index -> names of the model's joints lumped into it.
    """

    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    joint_xz: np.ndarray
    joint_sign: np.ndarray
    joint_ids: list[int]
    groups: dict[int, list[str]]


def _axis_sign(pin, model, data, jid: int, name: str) -> float:
    short = model.joints[jid].shortname()
    local = {"JointModelRX": (1, 0, 0), "JointModelRY": (0, 1, 0), "JointModelRZ": (0, 0, 1)}
    if short in local:
        axis = np.array(local[short], float)
    elif "RevoluteUnaligned" in short:
        axis = np.asarray(model.joints[jid].extract().axis, float)
    else:
        raise ChainError(f"joint {name!r} is a {short}, not a revolute joint")
    world = data.oMi[jid].rotation @ axis
    if abs(abs(world[1]) - 1.0) > 1e-3:
        raise ChainError(f"joint {name!r} does not turn about the lateral axis in the zero pose "
                         f"(axis {np.round(world, 3).tolist()}): not a sagittal pitch joint")
    return float(np.sign(world[1]))


def _lump(pin, model, q0: np.ndarray, joint_names: Sequence[str], roles: Sequence[str],
          child_links: Sequence[int], link_names: Sequence[str], rest_link: int
          ) -> tuple[LumpedLinks, Any]:
    """Lump the bodies of ``model`` at ``q0``: joint k's subtree down to the next sagittal joint
    goes to link ``child_links[k]``, everything else (the root's) to ``rest_link``. Returns the
    links and the pinocchio data at ``q0`` (placements updated)."""
    data = model.createData()
    pin.forwardKinematics(model, data, q0)
    pin.updateFramePlacements(model, data)
    names = list(model.names)
    ids: list[int] = []
    for n in joint_names:
        if n not in names:
            raise ChainError(f"robot has no joint {n!r} (needed as {roles[len(ids)]}); "
                             f"joints: {', '.join(names[1:])}")
        ids.append(names.index(n))
    link_of_joint = {jid: child_links[k] for k, jid in enumerate(ids)}
    n_links = len(link_names)
    groups: dict[int, list[str]] = {k: [] for k in range(n_links)}
    inertias = [pin.Inertia.Zero() for _ in range(n_links)]
    for j in range(1, model.njoints):
        k = j
        while k != 0 and k not in link_of_joint:
            k = model.parents[k]
        link = link_of_joint.get(k, rest_link)
        inertias[link] = inertias[link] + data.oMi[j].act(model.inertias[j])
        groups[link].append(names[j])
    mass = np.array([inert.mass for inert in inertias])
    if np.any(mass <= 0):
        raise ChainError(f"a sagittal link has no mass: "
                         f"{dict(zip(link_names, mass, strict=True))}")
    com = np.array([inert.lever[[0, 2]] for inert in inertias])
    inertia = np.array([inert.inertia for inert in inertias])
    joint_xz = np.array([data.oMi[j].translation[[0, 2]] for j in ids])
    sign = np.array([_axis_sign(pin, model, data, j, n) for j, n in zip(ids, joint_names,
                                                                         strict=True)])
    return LumpedLinks(mass=mass, com=com, inertia=inertia, joint_xz=joint_xz,
                       joint_sign=sign, joint_ids=ids, groups=groups), data


def _frame_xz(model, data, name: str) -> np.ndarray:
    if not model.existFrame(name):
        raise ChainError(f"robot has no frame {name!r}")
    return np.array(data.oMf[model.getFrameId(name)].translation[[0, 2]])


@dataclass(frozen=True, eq=False)
class LumpedUrdf:
    """:func:`lump_urdf`'s result, in the URDF's neutral pose (world = the root link's frame).

    Attributes:
        links: the lumped links.
        frames: frame name -> (2,) [m] its origin (x, z).
        q_lower, q_upper, effort, velocity: (J,) the sagittal joints' limits from the URDF.
    """

    links: LumpedLinks
    frames: dict[str, np.ndarray]
    q_lower: np.ndarray
    q_upper: np.ndarray
    effort: np.ndarray
    velocity: np.ndarray


def lump_urdf(path: str, joint_names: Sequence[str], child_links: Sequence[int],
              link_names: Sequence[str], rest_link: int, frames: Sequence[str]) -> LumpedUrdf:
    """A planar biped's URDF (free-flyer root) lumped into its links at the neutral pose.

    Args:
        path: the URDF.
        joint_names: the sagittal joints.
        child_links: per joint, the link (index into ``link_names``) below it.
        link_names: the links.
        rest_link: the link that takes the root's bodies.
        frames: frames whose origins are returned (the contact points).

    Raises:
        ChainError: a missing joint or frame, a joint not about the lateral axis, a link
            without mass.
    """
    pin = _pin()
    model = pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())
    q0 = pin.neutral(model)
    links, data = _lump(pin, model, q0, joint_names, joint_names, child_links, link_names,
                        rest_link)
    points = {name: _frame_xz(model, data, name) for name in frames}
    lower, upper, effort, velocity = (np.array([model.lowerPositionLimit[model.joints[j].idx_q]
                                                for j in links.joint_ids]),
                                      np.array([model.upperPositionLimit[model.joints[j].idx_q]
                                                for j in links.joint_ids]),
                                      np.array([model.effortLimit[model.joints[j].idx_v]
                                                for j in links.joint_ids]),
                                      np.array([model.velocityLimit[model.joints[j].idx_v]
                                                for j in links.joint_ids]))
    return LumpedUrdf(links=links, frames=points, q_lower=lower, q_upper=upper, effort=effort,
                      velocity=velocity)


@dataclass(frozen=True, eq=False)
class LumpedRobot:
    """:func:`lump_robot`'s result, in the locked pose ``q0`` (base at the origin, level).

    Attributes:
        links: the lumped links.
        q0: (nq,) the pose: the robot's nominal pose with the base at the origin and every leg
            joint (between the base and a sole) at 0.
        root_xz: (2,) [m] the base joint's origin (x, z).
        soles: (2, 2, 2) [m] per side (left, right) the (x, z) of the sole rectangle's rear and
            front edge midpoints.
        top_z: [m] the highest joint origin.
        joint_q, joint_v: (J,) the sagittal joints' indices into ``q[7:]`` and ``v[6:]``.
    """

    links: LumpedLinks
    q0: np.ndarray
    root_xz: np.ndarray
    soles: np.ndarray
    top_z: float
    joint_q: np.ndarray
    joint_v: np.ndarray


def lump_robot(robot, joint_names: Sequence[str], roles: Sequence[str],
               child_links: Sequence[int], link_names: Sequence[str], rest_link: int
               ) -> LumpedRobot:
    """A loaded 3D robot (:class:`imesh.robot.Robot`) lumped into sagittal links with every
    other joint locked: the legs straight (every joint between the base and a sole at 0), the
    rest at the nominal pose.

    Args:
        robot: the robot.
        joint_names: its sagittal joints; roles: what each one is (for messages).
        child_links, link_names, rest_link: as in :func:`lump_urdf`.
    """
    pin = _pin()
    model = robot.model
    q0 = np.array(robot.q_nominal, float).copy()
    q0[:7] = [0, 0, 0, 0, 0, 0, 1]
    for side in ("left", "right"):
        q0[7 + robot.supporting_joints(robot.soles[side].frame)] = 0.0
    links, data = _lump(pin, model, q0, joint_names, roles, child_links, link_names,
                        rest_link)
    soles = []
    for s in ("left", "right"):
        sole = robot.soles[s]
        M = data.oMf[model.getFrameId(sole.frame)]
        front = M.act(sole.center + np.array([sole.half_extents[0], 0, 0]))
        back = M.act(sole.center - np.array([sole.half_extents[0], 0, 0]))
        soles.append([back[[0, 2]], front[[0, 2]]])
    jidx = [model.joints[j] for j in links.joint_ids]
    return LumpedRobot(
        links=links, q0=q0, root_xz=np.array(data.oMi[1].translation[[0, 2]]),
        soles=np.array(soles),
        top_z=max(data.oMi[j].translation[2] for j in range(1, model.njoints)),
        joint_q=np.array([j.idx_q - 7 for j in jidx]),
        joint_v=np.array([j.idx_v - 6 for j in jidx]))


def pitch_quaternion(angle: float) -> np.ndarray:
    """(4,) quaternion (x, y, z, w) of a rotation by ``angle`` [rad] about y."""
    pin = _pin()
    return pin.Quaternion(pin.utils.rotate("y", float(angle))).coeffs()


def robot_energies(robot, q: np.ndarray, q_next: np.ndarray, eps: float) -> tuple[float, float]:
    """(kinetic, potential) energy of ``robot`` at ``q`` moving towards ``q_next`` in ``eps``
    seconds (the velocity a finite difference on the configuration manifold)."""
    pin = _pin()
    v = pin.difference(robot.model, q, q_next) / eps
    data = robot.model.createData()
    return (float(pin.computeKineticEnergy(robot.model, data, q, v)),
            float(pin.computePotentialEnergy(robot.model, data, q)))


class RootedChain:
    """A planar chain as a pinocchio model rooted at a foot's ball.

    Generalized coordinates ``q = [x, z, q_0 .. q_{L-1}]``: a planar root (x, z translation)
    at the ball, then one revolute joint about y per link along the chain, ``q_0`` the first
    link's pitch about the ball and ``q_k`` the relative angle of link k.

    Args:
        ball: (2,) [m] the root point (x, z) in the zero pose.
        points: (L, 2) [m] each link's joint point towards the root (x, z), ``points[0] == ball``.
        names: (L,) the joints' names.
        mass, com, inertia: (L,), (L, 2), (L, 3, 3) the links along the chain, world (zero
            pose).

    Attributes:
        model, data: the pinocchio model and its data.
    """

    def __init__(self, ball: np.ndarray, points: Sequence[np.ndarray], names: Sequence[str],
                 mass: np.ndarray, com: np.ndarray, inertia: np.ndarray):
        pin = self.pin = _pin()
        model = pin.Model()
        jx = model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "root_x")
        jz = model.addJoint(jx, pin.JointModelPZ(), pin.SE3.Identity(), "root_z")
        parent, prev = jz, ball
        for point, name, m, c, inert in zip(points, names, mass, com, inertia, strict=True):
            d = point - prev
            placement = pin.SE3(np.eye(3), np.array([d[0], 0.0, d[1]]))
            jid = model.addJoint(parent, pin.JointModelRY(), placement, name)
            lever = c - point
            body = pin.Inertia(float(m), np.array([lever[0], 0.0, lever[1]]), np.array(inert))
            model.appendBodyToJoint(jid, body, pin.SE3.Identity())
            parent, prev = jid, point
        self.model = model
        self.data = model.createData()

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """(nv, nv) joint-space inertia matrix (CRBA, both triangles)."""
        M = self.pin.crba(self.model, self.data, q)
        return np.triu(M) + np.triu(M, 1).T

    def nonlinear_effects(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(nv,) Coriolis, centrifugal and gravity forces."""
        return self.pin.nonLinearEffects(self.model, self.data, q, v)

    def rnea(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """(nv,) inverse dynamics."""
        return self.pin.rnea(self.model, self.data, q, v, a)

    def rnea_derivatives(self, q: np.ndarray, v: np.ndarray, a: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:
        """(nv, nv) partial derivatives of the RNEA forces w.r.t. q and v."""
        dtau_dq, dtau_dv, _ = self.pin.computeRNEADerivatives(self.model, self.data, q, v, a)
        return np.asarray(dtau_dq), np.asarray(dtau_dv)

    def energies(self, q: np.ndarray, v: np.ndarray) -> tuple[float, float]:
        """(kinetic, potential) energy [J]."""
        return (float(self.pin.computeKineticEnergy(self.model, self.data, q, v)),
                float(self.pin.computePotentialEnergy(self.model, self.data, q)))
