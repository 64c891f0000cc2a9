"""The robot: a reduced pinocchio model with a free-flyer root, limits, soles, nominal pose and
collision proxies, behind a small numpy API (:class:`Robot`), and :func:`load_robot`.

Every pinocchio call of imesh lives in ``imesh.robot``; pinocchio is imported lazily
(:func:`imesh.robot.pin._pinocchio`), so importing imesh works without it. The Robot delegates:

- :mod:`imesh.robot.build`: URDF -> reduced pinocchio model, limits, soles, proxies (once per
  files, kept by :func:`load_robot`);
- :mod:`imesh.robot.configuration`: FK, Jacobians, CoM, ZMP, inverse dynamics at one
  configuration, with an explicit record of the configuration its data holds;
- :mod:`imesh.robot.trajectory`: the same along a (T, nq) trajectory;
- :mod:`imesh.robot.standing`: the nominal standing pose;
- :mod:`imesh.robot.capsules`: the self-collision capsules.

Configuration vector ``q``: ``[x, y, z, qx, qy, qz, qw, joints...]`` (pinocchio free-flyer order,
base position in the world, base orientation as a unit quaternion), then one angle [rad] per
actuated joint in ``Robot.joint_names`` order. Velocity ``v`` (nv = nq - 1): base linear and
angular velocity expressed in the *base* frame (pinocchio's convention), then joint rates.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..core.cache import cache_enabled
from . import model_cache
from .build import (
    BuiltModel,
    build_model,
    derive_soles_and_proxies,
    load_geometry,
    resolve_urdf,
)
from .capsules.model import CapsuleModel
from .collision import CollisionShape
from .config import RobotConfig, SoleRectangle, load_robot_config
from .configuration import Configuration
from .dynamics import Dynamics
from .errors import RobotConfigError, closest_first
from .markers_config import MarkerConfig, load_markers_config
from .pin import _pinocchio, find_frame, frame_names
from .registry import resolve_robot_toml
from .standing import standing_pose
from .trajectory import TrajectoryData, TrajectoryKinematics

log = logging.getLogger(__name__)

#: Frames as names or indices: a sequence, or an int array of indices.
FrameRefs = Sequence[int | str] | np.ndarray

#: The robot of ``load_robot(None)`` and of the command line without --robot.
DEFAULT_ROBOT = "jvrc1"

#: Built models by (robot.toml, its mtime, markers.toml mtime, URDF, its mtime): loading a
#: robot again (every CLI stage, every test) reuses the URDF parse and the proxy fits.
_CACHE: dict[tuple, BuiltModel] = {}


def _mtime(path: Path | None) -> int:
    return path.stat().st_mtime_ns if path is not None and path.exists() else 0


def _complete(built: BuiltModel) -> None:
    """Complete a built model with the nominal pose (which needs a Robot to compute)."""
    built.q_nominal = standing_pose(Robot(built))


def _build(config: RobotConfig, markers: MarkerConfig | None, urdf: Path,
           package_dirs: list[str]) -> BuiltModel:
    """:func:`imesh.robot.build.build_model` completed with the nominal pose; what comes from
    the meshes is read from the robot cache when it holds these files
    (:mod:`imesh.robot.model_cache`), else computed and stored there. The pinocchio model
    itself is always built from the URDF (10 ms)."""
    built = build_model(config, markers, urdf, package_dirs, geometry=False)
    key = model_cache.robot_key(config, urdf, package_dirs) if cache_enabled() else ""
    built.cache_key = key
    cached = model_cache.read_robot(key, built) if key else None
    if cached is not None:
        built.q_nominal = cached.q_nominal
        built.soles, built.shapes = cached.soles, cached.shapes
        log.debug("robot %s: soles, proxies and nominal pose read from the robot cache",
                  config.name)
        return built
    built.geometry = load_geometry(built.full, urdf, package_dirs)
    built.soles, built.shapes = derive_soles_and_proxies(config, built.full, built.geometry)
    _complete(built)
    if key:
        model_cache.write_robot(key, built)
    return built


def load_robot(name_or_toml: str | os.PathLike | None = None,
               urdf: str | os.PathLike | None = None) -> Robot:
    """Load a robot: its configuration, its reduced pinocchio model, soles, proxies, nominal pose.

    Args:
        name_or_toml: a robot name (a folder of ``robots/``: see :func:`list_robots`), a robot
            folder, or a path to a robot.toml. None: with ``urdf``, a configuration generated
            from the URDF alone (:func:`imesh.robot.generate_files.generate_for_urdf`, cached);
            without, :data:`DEFAULT_ROBOT`.
        urdf: the model file for robots whose model the user provides (``source = "user"`` in
            robot.toml, e.g. hrp4c); for other robots it replaces the packaged file.

    Returns:
        A Robot with its own pinocchio Data (the model is shared with other Robots loaded from
        the same files: do not modify it).

    Raises:
        RobotConfigError: unknown robot (listing the valid names), missing ``urdf`` argument,
            package not installed (with the install command), invalid configuration (naming the
            key and listing valid options), URDF that does not parse (naming the file and the
            parser message).
        ImeshError: pinocchio is not installed.
    """
    if name_or_toml is None:
        if urdf is None:
            name_or_toml = DEFAULT_ROBOT
        else:
            from .generate_files import generate_for_urdf  # scipy.optimize: only here

            name_or_toml = generate_for_urdf(urdf)
    toml = resolve_robot_toml(name_or_toml)
    config = load_robot_config(toml)
    markers = load_markers_config(config.markers_path) if config.markers_path else None
    _pinocchio()
    path, package_dirs = resolve_urdf(config, urdf)
    key = (str(toml.resolve()), _mtime(toml), _mtime(config.markers_path), str(path.resolve()),
           _mtime(path))
    built = _CACHE.get(key)
    if built is None:
        built = _build(config, markers, path, package_dirs)
        _CACHE[key] = built
        log.info("loaded robot %s from %s: %d DOF, %.1f kg, %d collision proxies",
                 config.name, path, built.model.nv - 6, Robot(built).mass, len(built.shapes))
    return Robot(built)




class Robot:
    """A humanoid robot model (see the module docstring for q and v).

    Per-configuration getters take ``q`` (nq,) or None. They read :attr:`configuration`, which
    records the configuration its pinocchio Data holds: a getter called with that same ``q``
    (or with None) reuses the data instead of recomputing, and :meth:`forward` computes
    placements and Jacobians for several getters at once (see
    :class:`imesh.robot.configuration.Configuration`). Trajectory methods use a Data of their
    own and leave :attr:`configuration` as it is.

    Attributes:
        name: robot name.
        config: the robot.toml content.
        markers: the markers.toml content (keypoints, directions, arrangement), or None.
        urdf: the URDF file loaded.
        model: pinocchio.Model with a free-flyer root, reduced (fixed joints removed).
        configuration: the pinocchio Data of this Robot at its current configuration.
        nq: configuration size (7 + DOF).
        nv: velocity size (6 + DOF).
        joint_names: actuated joints in ``q[7:]`` order.
        q_lower: (nq-7,) float [rad] lower position limits.
        q_upper: (nq-7,) float [rad] upper position limits.
        v_max: (nv-6,) float [rad/s] velocity limits (URDF, or robot.toml override).
        a_max: (nv-6,) float [rad/s^2] acceleration limits (robot.toml; default 20).
        effort_max: (nv-6,) float [Nm] torque limits.
        q_nominal: (nq,) float nominal standing pose, both soles flat on z = 0, base above the
            origin (x = y = 0) with level orientation.
        mass: [kg] total mass.
        soles: ``"left"``/``"right"`` -> SoleRectangle.
        waist_frame: the waist (root link) frame name.
        foot_frames: ``"left"``/``"right"`` -> foot frame name.
        collision_shapes: primitive proxies (frame, kind, dims, placement in frame): the
            ground check and DART (self-collision is scored on the URDF geometry with the
            capsules, :meth:`capsule_model`).
    """

    def __init__(self, built: BuiltModel):
        self._pin = _pinocchio()
        self._built = built
        self.config: RobotConfig = built.config
        self.name: str = built.config.name
        self.markers: MarkerConfig | None = built.markers
        self.urdf: Path = built.urdf
        self.model = built.model
        self.configuration = Configuration(self.model, self.name)
        self._trajectory = TrajectoryData(self.model)
        self.nq: int = int(self.model.nq)
        self.nv: int = int(self.model.nv)
        self.joint_names: tuple[str, ...] = tuple(self.model.names)[2:]
        self.q_lower = built.q_lower.copy()
        self.q_upper = built.q_upper.copy()
        self.v_max = built.v_max.copy()
        self.a_max = built.a_max.copy()
        self.effort_max = built.effort_max.copy()
        self.q_nominal = built.q_nominal.copy()
        self.mass: float = self.configuration.mass
        self.soles: dict[str, SoleRectangle] = dict(built.soles)
        self.waist_frame: str = built.config.waist_frame
        self.foot_frames: dict[str, str] = dict(built.config.foot_frames)
        self.collision_shapes: list[CollisionShape] = list(built.shapes)
        self._frame_cache: dict[str, int] = {}

    def __repr__(self) -> str:
        return (f"Robot({self.name!r}, dof={self.nv - 6}, mass={self.mass:.1f} kg, "
                f"urdf={str(self.urdf)!r})")

    # --- names -----------------------------------------------------------------------------

    @property
    def dof(self) -> int:
        """Number of actuated joints."""
        return self.nv - 6

    @property
    def frame_names(self) -> list[str]:
        """Every frame name of the reduced model (links, joints, fixed frames)."""
        return frame_names(self.model)

    def frame_id(self, name: str) -> int:
        """The pinocchio frame index of a frame (link frames preferred over joint frames).

        Raises:
            RobotConfigError: unknown frame, listing the valid names (closest first).
        """
        idx = self._frame_cache.get(name)
        if idx is None:
            idx = find_frame(self.model, name)
            if idx < 0:
                raise RobotConfigError(f"robot {self.name!r} has no frame {name!r}", key="frame",
                                       valid=closest_first(name, self.frame_names))
            self._frame_cache[name] = idx
        return idx

    def joint_index(self, name: str) -> int:
        """Index of an actuated joint in ``q[7:]`` (and ``v[6:]``, limits arrays).

        Raises:
            RobotConfigError: unknown or fixed joint, listing the actuated joints.
        """
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise RobotConfigError(f"robot {self.name!r} has no actuated joint {name!r}",
                                   key="joint",
                                   valid=closest_first(name, self.joint_names)) from None

    def rigid_links(self, frame: int | str) -> list[str]:
        """The links rigidly attached to a frame (the link bodies on its parent joint), e.g.
        ``l_foot`` for iCub's sole frame ``l_sole``."""
        pin, model = self._pin, self.model
        j = model.frames[self._ids([frame])[0]].parentJoint
        return [f.name for f in model.frames
                if f.parentJoint == j and f.type == pin.FrameType.BODY]

    def supporting_joints(self, frame: int | str) -> np.ndarray:
        """(k,) int indices into ``q[7:]`` of the actuated joints between the base and a frame,
        from the base outwards (a leg's chain for a sole frame)."""
        model = self.model
        j = model.frames[self._ids([frame])[0]].parentJoint
        return np.array([model.joints[k].idx_q - 7 for k in model.supports[j] if k > 1],
                        dtype=np.int64)

    def keypoint_arrays(self) -> tuple[tuple[str, ...], np.ndarray, np.ndarray, np.ndarray]:
        """The markers.toml keypoints as arrays, ready for frame_positions/point_jacobians.

        Returns:
            (names, frame_ids (K,) int, offsets (K, 3) float [m], weights (K,) float), in the
            order of ``markers.keypoints`` (surviving standard markers, then added markers).

        Raises:
            RobotConfigError: the robot has no markers.toml.
        """
        if self.markers is None:
            raise RobotConfigError(f"robot {self.name!r} has no markers.toml beside its "
                                   "robot.toml", path=self.config.path)
        kp = self.markers.keypoints
        return (tuple(kp), np.array([self.frame_id(k.frame) for k in kp.values()], dtype=int),
                np.array([k.offset for k in kp.values()], dtype=float).reshape(-1, 3),
                np.array([k.weight for k in kp.values()], dtype=float))

    def _ids(self, frames: FrameRefs) -> list[int]:
        return [self.frame_id(f) if isinstance(f, str) else int(f) for f in frames]

    # --- one configuration (delegated to self.configuration) -------------------------------

    def _check_q(self, q) -> np.ndarray:
        return self.configuration.check(q)

    def forward(self, q) -> None:
        """Forward kinematics and joint Jacobians at ``q`` (the getters then accept q=None, and
        getters called with this same ``q`` reuse the result instead of recomputing).

        Args:
            q: (nq,) float configuration.
        """
        self.configuration.forward(q)

    def frame_placements(self, q, frames: FrameRefs) -> np.ndarray:
        """(F, 4, 4) float world poses of frames.

        Args:
            q: (nq,) configuration, or None to reuse the last one.
            frames: frame indices (or names).
        """
        return self.configuration.frame_placements(q, self._ids(frames))

    def frame_positions(self, q, frames: FrameRefs,
                        offsets: np.ndarray | None = None) -> np.ndarray:
        """(F, 3) float [m] world positions of points fixed in frames.

        Args:
            q: (nq,) configuration, or None to reuse the last forward().
            frames: F frame indices (or names).
            offsets: (F, 3) float [m] point positions in their frames; None = frame origins.
        """
        return self.configuration.frame_positions(q, self._ids(frames), offsets)

    def frame_rotations(self, q, frames: FrameRefs) -> np.ndarray:
        """(F, 3, 3) float world rotations of frames (columns = frame axes in the world)."""
        return self.configuration.frame_rotations(q, self._ids(frames))

    def point_jacobians(self, q, frames: FrameRefs,
                        offsets: np.ndarray | None = None) -> np.ndarray:
        """(F, 3, nv) float world-aligned linear Jacobians of points fixed in frames.

        ``d p_world = J @ v`` for a velocity ``v`` in pinocchio's convention, so a finite step
        ``integrate(q, eps * dv)`` moves the point by ``eps * J @ dv`` to first order. The
        arguments are those of :meth:`frame_positions`.
        """
        return self.configuration.point_jacobians(q, self._ids(frames), offsets)

    def frame_jacobians(self, q, frames: FrameRefs) -> np.ndarray:
        """(F, 6, nv) float world-aligned Jacobians of frames: rows 0-2 the frame origin's
        linear velocity, rows 3-5 the angular velocity (one pinocchio call per frame, where
        :meth:`point_jacobians` and :meth:`frame_angular_jacobians` make one each)."""
        return self.configuration.frame_jacobians(q, self._ids(frames))

    def frame_angular_jacobians(self, q, frames: FrameRefs) -> np.ndarray:
        """(F, 3, nv) float world angular-velocity Jacobians of frames (``omega = J @ v``)."""
        return self.configuration.frame_angular_jacobians(q, self._ids(frames))

    def com(self, q=None) -> np.ndarray:
        """(3,) float [m] world centre of mass (q None: the last configuration)."""
        return self.configuration.com(q)

    def com_jacobian(self, q=None) -> np.ndarray:
        """(3, nv) float Jacobian of the centre of mass (q None: the last configuration)."""
        return self.configuration.com_jacobian(q)

    def zmp(self, q, v, a, ground_z: float = 0.0) -> np.ndarray:
        """(2,) float [m] multibody ZMP (x, y) on the plane z = ``ground_z``
        (:meth:`imesh.robot.configuration.Configuration.zmp`).

        Args:
            q: (nq,) configuration; v: (nv,) velocity; a: (nv,) acceleration (pinocchio
            convention, base twist in the base frame).
        """
        return self.configuration.zmp(q, v, a, ground_z)

    def inverse_dynamics(self, q, v, a) -> np.ndarray:
        """(nv,) float generalized forces ``M(q) a + C(q, v) v + g(q) + B qd`` (recursive
        Newton-Euler plus the URDF's joint damping ``B``; pinocchio convention: the first 6 rows
        are the wrench the free-flyer needs, in the base frame, the rest joint torques [Nm])."""
        return self.configuration.inverse_dynamics(q, v, a)

    def dynamics(self, q, v, frames: FrameRefs, offsets: np.ndarray) -> Dynamics:
        """Equation-of-motion terms (``M``, ``h``) and the Jacobians and drifts of the CoM and of
        points fixed in frames, at the state (q, v), in one pinocchio pass
        (:meth:`imesh.robot.configuration.Configuration.dynamics`).

        Args:
            q: (nq,) configuration; v: (nv,) velocity (pinocchio convention).
            frames: F frame indices (or names).
            offsets: (F, 3) float [m] points in those frames.
        """
        return self.configuration.dynamics(q, v, self._ids(frames), offsets)

    def integrate(self, q, dv) -> np.ndarray:
        """(nq,) ``q (+) dv``: move the configuration by the tangent vector ``dv`` (nv,)."""
        return np.asarray(self._pin.integrate(self.model, self._check_q(q),
                                              np.asarray(dv, dtype=float)))

    def difference(self, q0, q1) -> np.ndarray:
        """(nv,) tangent vector ``dv`` with ``integrate(q0, dv) == q1``."""
        return np.asarray(self._pin.difference(self.model, self._check_q(q0),
                                               self._check_q(q1)))

    # --- trajectories (delegated to imesh.robot.trajectory, on a Data of their own) ---------

    def trajectory_kinematics(self, q: np.ndarray, frames: FrameRefs
                              ) -> TrajectoryKinematics:
        """Placements and world-aligned Jacobians of frames, CoM and its Jacobian, at every
        configuration of a trajectory (:meth:`imesh.robot.trajectory.TrajectoryData.kinematics`).

        Args:
            q: (T, nq) float configurations.
            frames: F frame indices (or names).
        """
        return self._trajectory.kinematics(q, self._ids(frames))

    def centroidal_trajectory(self, q: np.ndarray, v: np.ndarray, fps: float
                              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(com (T, 3) [m], dh (T, 6), Ag (T, 6, nv)) along a trajectory sampled at ``fps``:
        q (T, nq), v (T, nv); the rates by differences of the samples
        (:meth:`imesh.robot.trajectory.TrajectoryData.centroidal`)."""
        return self._trajectory.centroidal(q, v, fps)

    def momentum_jacobians(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(T, 6, nv) derivative of the centroidal momentum with respect to each ``q_t``, its
        velocity held (:meth:`imesh.robot.trajectory.TrajectoryData.momentum_jacobians`)."""
        return self._trajectory.momentum_jacobians(q, v)

    def inverse_dynamics_trajectory(self, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                                    derivatives: np.ndarray | None = None
                                    ) -> tuple[np.ndarray, np.ndarray]:
        """(tau (T, nv), dtau (T, 3, nv, nv)) along a trajectory: q (T, nq), v and a (T, nv),
        derivatives at the (T,) bool frames asked for
        (:meth:`imesh.robot.trajectory.TrajectoryData.inverse_dynamics`)."""
        return self._trajectory.inverse_dynamics(q, v, a, derivatives)

    # --- poses ---------------------------------------------------------------------------------

    def neutral(self) -> np.ndarray:
        """(nq,) the nominal standing pose (a copy of ``q_nominal``)."""
        return self.q_nominal.copy()

    def clip(self, q) -> np.ndarray:
        """(nq,) ``q`` with the joints clipped to their position limits."""
        q = self._check_q(q).copy()
        q[7:] = np.clip(q[7:], self.q_lower, self.q_upper)
        return q

    def random_configuration(self, rng: np.random.Generator, scale: float = 1.0
                             ) -> np.ndarray:
        """(nq,) a random configuration: joints uniform inside ``scale`` x their range around the
        range centre, random base orientation, base position within 1 m of the origin."""
        q = np.zeros(self.nq)
        q[:3] = rng.uniform(-1, 1, 3)
        quat = rng.normal(size=4)
        q[3:7] = quat / np.linalg.norm(quat)
        mid, half = (self.q_lower + self.q_upper) / 2, (self.q_upper - self.q_lower) / 2
        q[7:] = mid + scale * half * rng.uniform(-1, 1, self.dof)
        return q

    def sole_corners(self, q, side: str) -> np.ndarray:
        """(4, 3) float [m] world positions of a sole's corners (q None: last configuration)."""
        sole = self.soles[side]
        return self.frame_positions(q, [sole.frame] * 4, sole.corners())

    def sole_center(self, q, side: str) -> np.ndarray:
        """(3,) float [m] world position of a sole's centre."""
        sole = self.soles[side]
        return self.frame_positions(q, [sole.frame], sole.center[None])[0]


    # --- collision -----------------------------------------------------------------------------

    def shape_poses(self, q) -> np.ndarray:
        """(S, 4, 4) float world poses of ``collision_shapes`` (q None: last configuration)."""
        self.configuration.placements_at(q)
        oMf = self.configuration.data.oMf
        return np.array([oMf[self.frame_id(s.frame)].homogeneous @ s.placement
                         for s in self.collision_shapes])

    def capsule_model(self) -> CapsuleModel:
        """The self-collision capsules and the pairs checked
        (:class:`imesh.robot.capsules.model.CapsuleModel`), built on first use and shared by the
        Robots of the same files."""
        if self._built.capsules is None:
            self._built.capsules = model_cache.capsule_model(self, self._built.cache_key)
        return self._built.capsules

    def link_geometry(self) -> dict:
        """link -> {"collision": [GeometryItem], "visual": [GeometryItem]} of the URDF (its
        meshes read on first use when the robot came from the robot cache)."""
        return self._built.link_geometry()

    def lowest_point(self, q) -> float:
        """[m] lowest z of any collision proxy (negative = below the ground z = 0)."""
        poses = self.shape_poses(q)
        low = np.inf
        for s, T in zip(self.collision_shapes, poses, strict=True):
            if s.kind == "sphere":
                low = min(low, T[2, 3] - s.dims[0])
                continue
            pts = s.support_points(n_circle=32)  # in frame; re-pose from shape to world
            local = (pts - s.placement[:3, 3]) @ s.placement[:3, :3]
            world = local @ T[:3, :3].T + T[:3, 3]
            low = min(low, float(world[:, 2].min()))
        return float(low)
