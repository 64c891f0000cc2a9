"""The DART world of a robot: the same URDF and reductions as the pinocchio model, primitive
collision proxies, sole boxes and a ground box. Every dartpy call of imesh lives in
``imesh.physics``; dartpy is imported lazily.

Model: the robot's URDF with its visual and collision elements removed (meshes are never
loaded), the joints fixed by robot.toml turned into fixed joints at the angle pinocchio locks
them at, mimic tags removed (pinocchio treats every joint as independent), and DART's default
inertia for links without ``<inertial>`` set to ~0 (DART's loader would give them 1 kg): the
skeleton's mass and centre of mass equal the pinocchio model's. A link whose inertia tensor is
degenerate (a point mass: iCub's head and neck) gets a solid sphere's, so no joint has a zero
effective inertia. Collision: the robot's
primitive proxies (``Robot.collision_shapes``), except on the feet, which get one box per sole
(``GroundConfig.sole_thickness_m`` thick, its bottom face on the sole rectangle).
Self-collision is off in DART (checked separately on the URDF geometry with coal,
:mod:`imesh.metrics.collision`). The ground is a large box whose top face is z = 0, with
Coulomb friction. A scene's props (:class:`imesh.scene.Scene`, in the robot's world) are static
boxes welded to the world, with the ground's friction; a prop that is not a box is refused
(:class:`PhysicsError`): dartpy builds mesh shapes only from files it loads itself.

State conventions: DART (6.20) orders a floating base's positions as (rotation vector,
translation) and its velocities as (angular, linear) velocity in the *world* frame; pinocchio
uses (translation, quaternion xyzw) and (linear, angular) velocity in the *base* frame, and its
accelerations are the derivatives of those base-frame components. :class:`DartRobot` converts.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
from types import ModuleType

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.lazy import optional
from ..errors import ImeshError
from ..robot.inertia import regularize_inertias
from .config import PhysicsConfig

log = logging.getLogger(__name__)

#: Mass [kg] and principal moments [kg m^2] DART gives links without <inertial> (~0).
DEFAULT_MASS = 1e-9
DEFAULT_MOMENT = 1e-12
#: Half size of the ground box [m] (the robot stays within it).
GROUND_HALF_SIZE = 100.0


class PhysicsError(ImeshError):
    """The DART world cannot be built or simulated (a model mismatch, a failed step)."""


def dartpy() -> ModuleType:
    """The dartpy module (imported on first use), or a MissingDependencyError saying how to
    install it."""
    return optional("dartpy", "pip install dartpy", "the physics check")


def _rotations(q: np.ndarray) -> np.ndarray:
    """(..., 3, 3) base rotation matrices of configurations (..., nq) (quaternion xyzw)."""
    quat = np.asarray(q, dtype=float)[..., 3:7]
    return Rotation.from_quat(quat.reshape(-1, 4)).as_matrix().reshape(*quat.shape[:-1], 3, 3)


def _isometry(dart, T: np.ndarray):
    iso = dart.math.Isometry3()
    iso.set_matrix(np.asarray(T, dtype=float))
    return iso


# ----------------------------------------------------------------------------------------------
# URDF reduction


def _origin(joint: ET.Element) -> tuple[np.ndarray, np.ndarray]:
    o = joint.find("origin")
    xyz = np.zeros(3) if o is None else np.array([float(x) for x in o.get("xyz", "0 0 0").split()])
    rpy = np.zeros(3) if o is None else np.array([float(x) for x in o.get("rpy", "0 0 0").split()])
    return xyz, Rotation.from_euler("xyz", rpy).as_matrix()


def _set_origin(joint: ET.Element, xyz: np.ndarray, R: np.ndarray) -> None:
    o = joint.find("origin")
    if o is None:
        o = ET.SubElement(joint, "origin")
    o.set("xyz", " ".join(f"{x:.17g}" for x in xyz))
    o.set("rpy", " ".join(f"{x:.17g}" for x in Rotation.from_matrix(R).as_euler("xyz")))


def locked_value(robot, joint: ET.Element) -> float:
    """The angle (or offset) at which a fixed joint is locked: as imesh.robot does, the
    robot.toml nominal value, else 0 clipped to the joint's limits."""
    name = joint.get("name")
    if name in robot.config.nominal:
        return float(robot.config.nominal[name])
    limit = joint.find("limit")
    if limit is None or joint.get("type") == "continuous":
        return 0.0
    lo, hi = float(limit.get("lower", "-inf")), float(limit.get("upper", "inf"))
    return float(np.clip(0.0, lo, hi))


def reduced_urdf(robot) -> str:
    """The robot's URDF text without visual/collision elements and mimic tags, with degenerate
    link inertias made physical as in the robot's pinocchio model (:mod:`imesh.robot.inertia`)
    and the joints that robot.toml fixes turned into fixed joints at their locked value."""
    try:
        root = ET.parse(robot.urdf).getroot()
    except (ET.ParseError, OSError) as exc:
        raise PhysicsError(f"{robot.urdf}: cannot read the URDF: {exc}") from None
    for link in root.iter("link"):
        for tag in ("visual", "collision"):
            for e in link.findall(tag):
                link.remove(e)
        mass = link.find("inertial/mass")
        if mass is not None and float(mass.get("value", "0")) <= 0:
            # a frame link with a zero-mass <inertial> (iCub's *_dh_frame): DART's default
            inertial = link.find("inertial")
            assert inertial is not None  # it holds the <mass> found above
            link.remove(inertial)
    regularize_inertias(root)  # as pinocchio's model has them (imesh.robot.inertia)
    fixed = set(robot.config.fixed_joints)
    for joint in root.iter("joint"):
        for m in joint.findall("mimic"):
            joint.remove(m)
        if joint.get("name") not in fixed:
            continue
        kind = joint.get("type")
        value = locked_value(robot, joint)
        if value != 0.0 and kind in ("revolute", "continuous", "prismatic"):
            a = joint.find("axis")
            axis = np.array([1.0, 0, 0]) if a is None else np.array(
                [float(x) for x in a.get("xyz", "1 0 0").split()])
            axis /= np.linalg.norm(axis)
            xyz, R = _origin(joint)
            if kind == "prismatic":
                xyz = xyz + R @ (axis * value)
            else:
                R = R @ Rotation.from_rotvec(axis * value).as_matrix()
            _set_origin(joint, xyz, R)
        joint.set("type", "fixed")
    return ET.tostring(root, encoding="unicode")


# ----------------------------------------------------------------------------------------------
# the world


def _shape(dart, kind: str, dims: tuple[float, ...]):
    D = dart.dynamics
    if kind == "box":
        return D.BoxShape(np.asarray(dims, dtype=float))
    if kind == "sphere":
        return D.SphereShape(float(dims[0]))
    if kind == "cylinder":
        return D.CylinderShape(float(dims[0]), float(dims[1]))
    if kind == "capsule":
        return D.CapsuleShape(float(dims[0]), float(dims[1]))
    raise PhysicsError(f"unsupported collision shape kind {kind!r}")


def _add_collision(node, friction: float) -> None:
    node.createCollisionAspect()
    node.createDynamicsAspect()
    node.getDynamicsAspect().setFrictionCoeff(friction)
    node.getDynamicsAspect().setRestitutionCoeff(0.0)


class DartRobot:
    """A robot in a DART world with a ground.

    Args:
        robot: an :class:`imesh.robot.Robot`.
        config: the physics settings (fixed base, friction, soles, collision detector, dt).
        base_pose: (4, 4) float world pose of the base for ``fixed_base`` (ignored otherwise).
        scene: static props in the robot's world (boxes), or None (the ground alone; a fixed
            base has neither).

    Attributes:
        world: the dartpy World (gravity -9.81 z, time step ``config.timing.dt``).
        skeleton: the robot's dartpy Skeleton.
        ground: the ground Skeleton (None for a fixed base).
        props: the props' Skeletons, one per prop (empty without a scene or for a fixed base).
        link_shape_names: names of the robot's collision shape nodes other than the soles
            (hands, knees, ...: their contacts with the ground and the props are counted apart).
        n_dofs: DART degrees of freedom (6 + joints, or joints for a fixed base).
        base_dofs: 6 (floating base) or 0 (fixed base).
        joint_dofs: (n,) int DART DOF index of every joint of ``robot.joint_names``.
    """

    def __init__(self, robot, config: PhysicsConfig, base_pose: np.ndarray | None = None,
                 scene=None):
        dart = dartpy()
        self.dart = dart
        self.robot = robot
        self.config = config
        loader = dart.utils.DartLoader()
        options = dart.utils.DartLoaderOptions()
        inertia = dart.dynamics.Inertia()
        inertia.setMass(DEFAULT_MASS)
        inertia.setMoment(np.eye(3) * DEFAULT_MOMENT)
        options.mDefaultInertia = inertia
        if config.fixed_base:
            options.mDefaultRootJointType = dart.utils.DartLoaderRootJointType.FIXED
        loader.setOptions(options)
        skel = loader.parseSkeletonString(reduced_urdf(robot),
                                          dart.common.Uri(f"file://{robot.urdf}"))
        if skel is None:
            raise PhysicsError(f"DART cannot parse {robot.urdf}")
        self.skeleton = skel
        if config.fixed_base:
            pose = np.eye(4) if base_pose is None else np.asarray(base_pose, dtype=float)
            skel.getRootJoint().setTransformFromParentBodyNode(_isometry(dart, pose))
        self.base_dofs = 0 if config.fixed_base else 6
        self.n_dofs = int(skel.getNumDofs())
        names = [skel.getDof(i).getName() for i in range(self.n_dofs)]
        missing = [n for n in robot.joint_names if n not in names]
        extra = [n for n in names[self.base_dofs:] if n not in robot.joint_names]
        if missing or extra or self.n_dofs != self.base_dofs + robot.dof:
            raise PhysicsError(f"DART model of {robot.urdf} does not match the pinocchio model "
                               f"of robot {robot.name!r}: missing joints {missing}, extra "
                               f"{extra}")
        self.joint_dofs = np.array([names.index(n) for n in robot.joint_names], dtype=np.int64)
        mass = skel.getMass()
        if abs(mass - robot.mass) > 1e-3 * robot.mass + 1e-6 * len(names):
            log.warning("DART mass of %s is %.3f kg, pinocchio's %.3f kg", robot.name, mass,
                        robot.mass)
        self._add_shapes()
        skel.setSelfCollisionCheck(False)
        self._check_kinematics()

        world = dart.simulation.World()
        world.setGravity(np.array([0.0, 0.0, -9.81]))
        world.setTimeStep(config.timing.dt)
        detector = {
            "ode": dart.collision.OdeCollisionDetector,
            "bullet": dart.collision.BulletCollisionDetector,
            "dart": dart.collision.DARTCollisionDetector,
            "fcl": dart.collision.FCLCollisionDetector,
        }[config.ground.collision_detector]()
        world.getConstraintSolver().setCollisionDetector(detector)
        world.addSkeleton(skel)
        self.ground = None
        self.props: list = []
        if not config.fixed_base:
            self.ground = self._make_ground()
            world.addSkeleton(self.ground)
            self.props = self._make_props(scene) if scene is not None else []
            for prop in self.props:
                world.addSkeleton(prop)
        self.world = world
        # ground (and prop) contact is the only collision: a fixed base has neither
        log.debug("DART world of %s: %d DOF, %.2f kg, %d shape nodes, detector %s", robot.name,
                  self.n_dofs, mass, skel.getNumShapeNodes(), config.ground.collision_detector)

    # --- building ---------------------------------------------------------------------------

    def _add_shapes(self) -> None:
        dart, robot, cfg = self.dart, self.robot, self.config
        # the sole boxes replace every proxy of the feet (also of links welded to a sole frame,
        # such as iCub's l_foot under l_sole)
        feet = {link for s in robot.soles for link in robot.rigid_links(robot.soles[s].frame)}
        feet |= {robot.soles[s].frame for s in robot.soles} | set(robot.foot_frames.values())
        link_shapes: set[str] = set()
        for shape in robot.collision_shapes:
            if shape.frame in feet:
                continue
            body = self.skeleton.getBodyNode(shape.frame)
            if body is None:
                raise PhysicsError(f"robot {robot.name!r}: no DART body for collision shape "
                                   f"of link {shape.frame!r}")
            node = body.createShapeNode(_shape(dart, shape.kind, shape.dims))
            node.setRelativeTransform(_isometry(dart, shape.placement))
            _add_collision(node, cfg.ground.friction)
            link_shapes.add(node.getName())
        self.link_shape_names = frozenset(link_shapes)
        th = cfg.ground.sole_thickness_m
        self._sole_nodes = {}
        for side, sole in robot.soles.items():
            body = self.skeleton.getBodyNode(sole.frame)
            if body is None:
                raise PhysicsError(f"robot {robot.name!r}: no DART body for the {side} sole "
                                   f"frame {sole.frame!r}")
            n = sole.normal / np.linalg.norm(sole.normal)
            pose = np.eye(4)
            z = n
            x = np.array([1.0, 0, 0]) - n[0] * n
            x /= np.linalg.norm(x)
            pose[:3, :3] = np.column_stack([x, np.cross(z, x), z])
            pose[:3, 3] = sole.center + n * th / 2
            size = np.array([2 * sole.half_extents[0], 2 * sole.half_extents[1], th])
            node = body.createShapeNode(dart.dynamics.BoxShape(size))
            node.setRelativeTransform(_isometry(dart, pose))
            node.setName(f"{side}_sole")
            _add_collision(node, cfg.ground.friction)
            self._sole_nodes[side] = node

    def set_sole_friction(self, side: str, friction: float) -> None:
        """Set the Coulomb friction coefficient of one sole box (``"left"`` or ``"right"``)
        from the next step on. DART takes the smaller coefficient of the two shapes in a
        contact, so below the ground's it is the contact's."""
        self._sole_nodes[side].getDynamicsAspect().setFrictionCoeff(float(friction))

    def _make_ground(self):
        dart = self.dart
        ground = dart.dynamics.Skeleton("ground")
        _, body = ground.createWeldJointAndBodyNodePair()
        thick = 0.1
        node = body.createShapeNode(dart.dynamics.BoxShape(
            np.array([2 * GROUND_HALF_SIZE, 2 * GROUND_HALF_SIZE, thick])))
        pose = np.eye(4)
        pose[2, 3] = -thick / 2
        node.setRelativeTransform(_isometry(dart, pose))
        _add_collision(node, self.config.ground.friction)
        return ground

    def _make_props(self, scene) -> list:
        """One welded Skeleton per prop of ``scene`` (robot world), a box shape with the
        ground's friction; every prop is checked before any is built."""
        from ..scene.props import prop_box  # noqa: PLC0415  (numpy + trimesh, scenes only)

        if scene.frame != "robot":
            raise PhysicsError(f"the DART check needs the scene in the robot's world (the "
                               f".scene.npz 'imesh retarget --scene' writes), not the "
                               f"{scene.frame!r} frame")
        boxes = [prop_box(p) for p in scene.props]
        bad = [p.name for p, b in zip(scene.props, boxes, strict=True) if b is None]
        if bad:
            raise PhysicsError(f"the DART check takes box props; not boxes: {bad} (their "
                               "convex hulls are not six faces in three orthogonal pairs)")
        dart, out = self.dart, []
        for prop, box in zip(scene.props, boxes, strict=True):
            assert box is not None  # refused above
            skel = dart.dynamics.Skeleton(f"prop:{prop.name}")
            _, body = skel.createWeldJointAndBodyNodePair()
            node = body.createShapeNode(dart.dynamics.BoxShape(np.asarray(box.size_m, float)))
            node.setRelativeTransform(_isometry(dart, box.pose))
            node.setName(f"prop:{prop.name}")
            _add_collision(node, self.config.ground.friction)
            out.append(skel)
        log.debug("DART world: %d props (%s)", len(out), ", ".join(scene.names))
        return out

    @property
    def joint_damping(self) -> np.ndarray:
        """(n,) float viscous damping of each joint in DART [N m s/rad], in
        ``robot.joint_names`` order: the URDF's ``<dynamics damping>``, which DART applies and
        pinocchio's dynamics leave out (HRP-4C: 0.2 on every joint; a wrist of a few grams
        then barely moves under the torques a model without it computes)."""
        skel = self.skeleton
        return np.array([skel.getDof(int(i)).getDampingCoefficient() for i in self.joint_dofs])

    def _check_kinematics(self) -> None:
        """The DART skeleton must put the soles where pinocchio does (same root link, same
        joints) in the nominal pose."""
        if self.config.fixed_base:
            return  # the base is welded at the motion's pose: nothing to compare here
        q = self.robot.q_nominal
        self.set_state(q)
        for side, sole in self.robot.soles.items():
            T = self.body(sole.frame).getWorldTransform().matrix()
            err = np.abs(T - self.robot.frame_placements(q, [sole.frame])[0]).max()
            if err > 1e-6:
                raise PhysicsError(
                    f"DART and pinocchio place the {side} sole frame {sole.frame!r} of robot "
                    f"{self.robot.name!r} {err:.3g} apart in the nominal pose: the URDF's root "
                    "link is not the floating base pinocchio uses")

    # --- conversions (vectorized over leading axes) ----------------------------------------

    def positions_from_q(self, q: np.ndarray) -> np.ndarray:
        """(..., n_dofs) DART positions of pinocchio configurations (..., nq)."""
        q = np.asarray(q, dtype=float)
        out = np.zeros((*q.shape[:-1], self.n_dofs))
        if self.base_dofs:
            out[..., :3] = Rotation.from_quat(q[..., 3:7].reshape(-1, 4)).as_rotvec().reshape(
                *q.shape[:-1], 3)
            out[..., 3:6] = q[..., :3]
        out[..., self.joint_dofs] = q[..., 7:]
        return out

    def velocities_from_v(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(..., n_dofs) DART velocities of pinocchio velocities (..., nv) at configurations
        (..., nq): the base twist goes from the base frame to the world frame."""
        q, v = np.asarray(q, dtype=float), np.asarray(v, dtype=float)
        out = np.zeros((*v.shape[:-1], self.n_dofs))
        if self.base_dofs:
            R = _rotations(q)
            out[..., :3] = np.einsum("...ij,...j->...i", R, v[..., 3:6])
            out[..., 3:6] = np.einsum("...ij,...j->...i", R, v[..., :3])
        out[..., self.joint_dofs] = v[..., 6:]
        return out

    def accelerations_from_a(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """(..., n_dofs) DART accelerations (time derivatives of DART velocities) of pinocchio
        accelerations (..., nv): angular ``R dw_b``, linear ``R (dv_b + w_b x v_b)``."""
        q, v, a = (np.asarray(x, dtype=float) for x in (q, v, a))
        out = np.zeros((*a.shape[:-1], self.n_dofs))
        if self.base_dofs:
            R = _rotations(q)
            out[..., :3] = np.einsum("...ij,...j->...i", R, a[..., 3:6])
            lin = a[..., :3] + np.cross(v[..., 3:6], v[..., :3])
            out[..., 3:6] = np.einsum("...ij,...j->...i", R, lin)
        out[..., self.joint_dofs] = a[..., 6:]
        return out

    def v_from_velocities(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """(..., nv) pinocchio velocities of DART velocities (..., n_dofs) at (..., nq)."""
        q, dq = np.asarray(q, dtype=float), np.asarray(dq, dtype=float)
        out = np.zeros((*dq.shape[:-1], 6 + len(self.joint_dofs)))
        if self.base_dofs:
            R = _rotations(q)
            out[..., :3] = np.einsum("...ji,...j->...i", R, dq[..., 3:6])
            out[..., 3:6] = np.einsum("...ji,...j->...i", R, dq[..., :3])
        out[..., 6:] = dq[..., self.joint_dofs]
        return out

    def q_from_positions(self, pos: np.ndarray, base_q: np.ndarray | None = None) -> np.ndarray:
        """(..., nq) pinocchio configurations of DART positions (..., n_dofs); a fixed base
        takes the base part from ``base_q`` (7,)."""
        pos = np.asarray(pos, dtype=float)
        out = np.zeros((*pos.shape[:-1], 7 + len(self.joint_dofs)))
        if self.base_dofs:
            out[..., :3] = pos[..., 3:6]
            out[..., 3:7] = Rotation.from_rotvec(pos[..., :3].reshape(-1, 3)).as_quat().reshape(
                *pos.shape[:-1], 4)
        elif base_q is not None:
            out[..., :7] = base_q[:7]
        else:
            out[..., 6] = 1.0
        out[..., 7:] = pos[..., self.joint_dofs]
        return out

    def set_state(self, q: np.ndarray, v: np.ndarray | None = None) -> None:
        """Set the skeleton to a pinocchio configuration (nq,) and velocity (nv,)."""
        self.skeleton.setPositions(self.positions_from_q(q))
        self.skeleton.setVelocities(np.zeros(self.n_dofs) if v is None
                                    else self.velocities_from_v(q, v))

    def body(self, name: str):
        body = self.skeleton.getBodyNode(name)
        if body is None:
            raise PhysicsError(f"robot {self.robot.name!r}: no DART body {name!r}")
        return body
