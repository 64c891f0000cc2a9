"""The robot model: a reduced pinocchio model with a free-flyer root, limits, soles, nominal pose
and primitive collision proxies, behind a small numpy API.

Every pinocchio call of imesh lives in ``imesh.robot``; pinocchio is imported lazily by
:func:`load_robot`, so importing imesh works without it.

Configuration vector ``q``: ``[x, y, z, qx, qy, qz, qw, joints...]`` (pinocchio free-flyer order,
base position in the world, base orientation as a unit quaternion), then one angle [rad] per
actuated joint in ``Robot.joint_names`` order. Velocity ``v`` (nv = nq - 1): base linear and
angular velocity expressed in the *base* frame (pinocchio's convention), then joint rates.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from importlib import import_module, metadata
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ImeshError
from .collision import (
    CollisionShape,
    CollisionWorld,
    GeometryItem,
    adjacent_frame_pairs,
    build_proxies,
    derive_sole,
    pair_key,
)
from .config import (
    SIDES,
    MarkerConfig,
    RobotConfig,
    RobotConfigError,
    SoleRectangle,
    closest_first,
    load_markers_config,
    load_robot_config,
)
from .registry import resolve_robot_toml

if TYPE_CHECKING:  # pragma: no cover - typing only
    import pinocchio  # no type information: its classes are Any to mypy

    from .capsules import CapsuleModel

log = logging.getLogger(__name__)

GRAVITY = 9.81

#: Frames as names or indices: a sequence, or an int array of indices.
FrameRefs = Sequence[int | str] | np.ndarray


def _pinocchio() -> ModuleType:
    try:
        import pinocchio
    except ImportError as exc:
        raise ImeshError("robot models need pinocchio: pip install pin") from exc
    return pinocchio


# ----------------------------------------------------------------------------------------------
# locating the URDF


def _package_dirs(urdf: Path, extra: Sequence[Path] = ()) -> list[str]:
    """Folders where ``package://NAME/...`` mesh URIs are looked up (pinocchio searches
    ``DIR/NAME/...``): the URDF's ancestors and the package's parent folder."""
    dirs = [*extra, *list(urdf.resolve().parents)[:6]]
    return list(dict.fromkeys(str(d) for d in dirs))


def resolve_urdf(config: RobotConfig, urdf: str | os.PathLike | None) -> tuple[Path, list[str]]:
    """The URDF file of a robot and the folders for its ``package://`` URIs.

    Args:
        config: the robot configuration.
        urdf: a URDF path given by the user (required for ``source = "user"``; overrides the
            package file otherwise).

    Raises:
        RobotConfigError: missing argument, missing file, or package not installed (with the
            command that installs it).
    """
    m = config.model
    if urdf is not None:
        path = Path(urdf).expanduser()
        if not path.is_file():
            raise RobotConfigError("URDF file not found", path=path, key="urdf")
        if m.source == "user" and m.urdf and path.name != Path(m.urdf).name:
            log.warning("robot %s expects %s, loading %s", config.name, m.urdf, path)
        elif m.source == "package":
            log.info("robot %s: loading the user URDF %s instead of the package's", config.name,
                     path)
        return path, _package_dirs(path)
    if m.source == "user":
        raise RobotConfigError(
            f"robot {config.name!r} uses a model file you provide: pass urdf=PATH "
            f"(command line: --urdf PATH) pointing to {m.urdf}"
            + (f" ({m.url})" if m.url else ""), path=config.path, key="urdf")
    install = m.install or f"pip install {m.distribution or m.package}"
    tried = []
    if m.package:
        try:
            mod = import_module(m.package)
        except ImportError:
            mod = None
            tried.append(f"import {m.package}")
        if mod is not None:
            mod_file = getattr(mod, "__file__", None)
            pkg_dir = Path(mod_file).parent if mod_file else None
            attr = getattr(mod, m.urdf, None) if m.urdf.isidentifier() else None
            candidates = [Path(attr)] if isinstance(attr, str | os.PathLike) else []
            if pkg_dir is not None:
                candidates.append(pkg_dir / m.urdf)
            for c in candidates:
                if c.is_file():
                    extra = [pkg_dir.parent] if pkg_dir is not None else []
                    return c, _package_dirs(c, extra)
            tried.append(f"{m.package}: {m.urdf}")
    if m.distribution:
        try:
            dist = metadata.distribution(m.distribution)
        except metadata.PackageNotFoundError:
            dist = None
            tried.append(f"distribution {m.distribution}")
        if dist is not None:
            suffix = m.urdf.replace("\\", "/").lstrip("/")
            for f in dist.files or ():
                if str(f).replace("\\", "/").endswith(suffix):
                    # typed as a SimplePath: a pathlib.Path for an installed distribution
                    path = Path(str(dist.locate_file(f)))
                    if path.is_file():
                        return path, _package_dirs(path)
            tried.append(f"{m.distribution} files ending with {suffix}")
    raise RobotConfigError(
        f"the model of robot {config.name!r} is not installed ({'; '.join(tried)} not found): "
        f"{install}", path=config.path, key="model")


# ----------------------------------------------------------------------------------------------
# building (cached)


@dataclass
class _Built:
    """Everything load_robot computes once per (robot.toml, URDF) and shares between Robots."""

    config: RobotConfig
    markers: MarkerConfig | None
    urdf: Path
    model: pinocchio.Model
    q_nominal: np.ndarray
    q_lower: np.ndarray
    q_upper: np.ndarray
    v_max: np.ndarray
    a_max: np.ndarray
    effort_max: np.ndarray
    soles: dict[str, SoleRectangle]
    shapes: list[CollisionShape]
    ignored: set[tuple[str, str]]
    adjacent: set[tuple[str, str]] = field(default_factory=set)
    geometry: dict = field(default_factory=dict)  # link -> {"collision": [...], "visual": [...]}
    capsules: CapsuleModel | None = None  # built on first use


_CACHE: dict[tuple, _Built] = {}


def _mtime(path: Path | None) -> int:
    return path.stat().st_mtime_ns if path is not None and path.exists() else 0


#: Collada ``<up_axis>Y_UP``: file coordinates -> z-up coordinates (x, y, z) -> (x, -z, y).
_Y_UP = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])
_UP_AXIS: dict[str, str] = {}


def _collada_up_axis(path: str) -> str:
    """The ``<up_axis>`` a Collada file declares ("" when none or not Collada; cached)."""
    if not path.lower().endswith(".dae"):
        return ""
    if path not in _UP_AXIS:
        try:
            with open(path, "rb") as f:
                head = f.read(65536).decode("utf-8", "replace")
        except OSError:
            head = ""
        i = head.find("<up_axis>")
        _UP_AXIS[path] = head[i + 9:head.find("</up_axis>", i)].strip() if i >= 0 else ""
    return _UP_AXIS[path]


def _geometry_items(pin, model, geom_model, source: str) -> list[GeometryItem]:
    items = []
    for g in geom_model.geometryObjects:
        frame = model.frames[g.parentFrame]
        T = (frame.placement.inverse() * g.placement).homogeneous
        # A Collada mesh declaring Y_UP is meant to be turned z-up (as ROS viewers and the
        # model's authors show it, e.g. iCub's feet); coal reads the raw coordinates, so the
        # turn goes into the placement (vertices and coal's own geometry stay as loaded).
        up = _collada_up_axis(getattr(g, "meshPath", "") or "")
        if up == "Y_UP":
            T = T @ _Y_UP
        elif up == "X_UP":
            log.warning("%s: Collada X_UP mesh %s used as z-up", source, g.meshPath)
        geo = g.geometry
        cls = type(geo).__name__
        verts = None
        dims: tuple[float, ...]
        if cls.startswith("BVHModel") or cls.startswith("Convex"):
            kind, dims = "mesh", ()
            pts = geo.vertices() if hasattr(geo, "vertices") else geo.points()
            verts = np.array(pts, dtype=float).reshape(-1, 3)
        elif cls == "Box":
            kind, dims = "box", tuple(float(2 * h) for h in geo.halfSide)
        elif cls == "Sphere":
            kind, dims = "sphere", (float(geo.radius),)
        elif cls == "Cylinder":
            kind, dims = "cylinder", (float(geo.radius), float(2 * geo.halfLength))
        elif cls == "Capsule":
            kind, dims = "capsule", (float(geo.radius), float(2 * geo.halfLength))
        else:
            log.warning("%s geometry %s of %s has unsupported type %s: ignored", source, g.name,
                        frame.name, cls)
            continue
        items.append(GeometryItem(frame=frame.name, kind=kind, dims=dims, placement=T,
                                  vertices=verts, source=source, name=g.name, native=geo))
    return items


def _frame_names(model) -> list[str]:
    return list(dict.fromkeys(f.name for f in model.frames))


def _find_frame(pin, model, name: str) -> int:
    """Frame index by name, preferring link (BODY) frames; -1 when absent."""
    for ftype in (pin.FrameType.BODY, None):
        if ftype is None:
            idx = [i for i, f in enumerate(model.frames) if f.name == name]
            return idx[0] if idx else -1
        if model.existFrame(name, ftype):
            return int(model.getFrameId(name, ftype))
    return -1


def _set_joint(model, q: np.ndarray, jid: int, value: float) -> None:
    j = model.joints[jid]
    if j.nq == 1:
        q[j.idx_q] = value
    elif j.nq == 2:  # continuous joint stored as (cos, sin)
        q[j.idx_q:j.idx_q + 2] = [np.cos(value), np.sin(value)]
    else:
        raise RobotConfigError(f"joint {model.names[jid]!r} is not a 1-DOF joint")


def _foot_items(pin, model, foot: str, link_items) -> list[GeometryItem]:
    """Geometry of the links on the foot frame's joint, expressed in the foot frame (which may
    be a frame on the foot link rather than the link, e.g. iCub's ``l_sole``)."""
    fid = _find_frame(pin, model, foot)
    joint = model.frames[fid].parentJoint
    to_foot = model.frames[fid].placement.inverse()
    items = []
    for f in model.frames:
        if f.parentJoint != joint or f.type != pin.FrameType.BODY:
            continue
        T = (to_foot * f.placement).homogeneous
        items += [it if f.name == foot else dataclasses.replace(it, frame=foot,
                                                                placement=T @ it.placement)
                  for it in link_items(f.name, prefer_visual=False)]
    return items


def _build(config: RobotConfig, markers: MarkerConfig | None, urdf: Path,
           package_dirs: list[str]) -> _Built:
    pin = _pinocchio()
    try:
        ET.parse(urdf)
    except ET.ParseError as exc:
        raise RobotConfigError(f"URDF does not parse: {exc}", path=urdf) from None
    try:
        full = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
    except Exception as exc:  # pinocchio raises ValueError/RuntimeError with the parser message
        raise RobotConfigError(f"URDF does not parse: {exc}", path=urdf) from None
    geoms = {}
    for kind, gtype in (("collision", pin.GeometryType.COLLISION),
                        ("visual", pin.GeometryType.VISUAL)):
        try:
            geoms[kind] = pin.buildGeomFromUrdf(full, str(urdf), gtype, None, package_dirs)
        except Exception as exc:
            raise RobotConfigError(f"cannot load the {kind} geometry (mesh files are looked up "
                                   f"relative to {', '.join(package_dirs[:3])}): {exc}",
                                   path=urdf) from None

    # --- joints: validate names, fix the listed ones at their nominal values
    joint_names = list(full.names)[2:]  # universe, root_joint
    for key, names in (("joints.fixed", config.fixed_joints), ("nominal", config.nominal),
                       ("limits.velocity", config.limits.velocity),
                       ("limits.effort", config.limits.effort),
                       ("limits.acceleration", config.limits.acceleration),
                       ("limits.position", config.limits.position)):
        for n in names:
            if n not in joint_names:
                raise RobotConfigError(f"unknown joint {n!r} in {urdf.name}", path=config.path,
                                       key=f"{key}.{n}" if key != "joints.fixed" else key,
                                       valid=closest_first(n, joint_names))
    q_ref = pin.neutral(full)
    for n in joint_names:
        jid = full.getJointId(n)
        j = full.joints[jid]
        value = config.nominal.get(n, 0.0)
        if j.nq == 1 and n not in config.nominal:
            lo, hi = full.lowerPositionLimit[j.idx_q], full.upperPositionLimit[j.idx_q]
            value = float(np.clip(0.0, lo, hi))
        _set_joint(full, q_ref, jid, value)
    locked = [full.getJointId(n) for n in config.fixed_joints]
    model = pin.buildReducedModel(full, locked, q_ref) if locked else full.copy()
    dof = model.nv - 6
    actuated = list(model.names)[2:]
    if config.dof is not None and dof != config.dof:
        raise RobotConfigError(
            f"robot.toml declares dof = {config.dof} but {urdf.name} reduced by joints.fixed has "
            f"{dof} actuated joints: {', '.join(actuated)}", path=config.path, key="dof")
    for n in actuated:
        if model.joints[model.getJointId(n)].nq != 1:
            raise RobotConfigError(f"joint {n!r} is not a 1-DOF revolute/prismatic joint; fix it "
                                   "or use a URDF without it", path=config.path,
                                   key="joints.fixed")

    # --- frames named by the configuration must exist in the reduced model
    frames = _frame_names(model)
    refs = [(config.path, k, f) for k, f in config.frame_references()]
    if markers is not None:
        refs += [(markers.path, k, f) for k, f in markers.frame_references()]
    refs += [(config.path, "collision.use_visual", f) for f in config.collision.use_visual]
    refs += [(config.path, "collision.skip", f) for f in config.collision.skip]
    refs += [(config.path, "collision.ignore", f) for p in config.collision.ignore for f in p]
    for path, key, name in refs:
        if _find_frame(pin, model, name) < 0:
            raise RobotConfigError(f"unknown frame {name!r} (not a link or frame of "
                                   f"{urdf.name})", path=path, key=key,
                                   valid=closest_first(name, frames))

    # --- limits (actuated joints, q[7:] / v[6:] order)
    q_lower = np.array(model.lowerPositionLimit[7:], dtype=float)
    q_upper = np.array(model.upperPositionLimit[7:], dtype=float)
    v_max = np.array(model.velocityLimit[6:], dtype=float)
    effort = np.array(model.effortLimit[6:], dtype=float)
    a_max = np.full(dof, config.limits.acceleration_default)
    lim = config.limits
    for i, n in enumerate(actuated):
        if n in lim.position:
            q_lower[i], q_upper[i] = lim.position[n]
        if n in lim.velocity:
            v_max[i] = lim.velocity[n]
        if n in lim.effort:
            effort[i] = lim.effort[n]
        if n in lim.acceleration:
            a_max[i] = lim.acceleration[n]
    for arr, what in ((q_lower, "lower"), (q_upper, "upper"), (v_max, "velocity"),
                      (effort, "effort")):
        bad = [actuated[i] for i in np.flatnonzero(~np.isfinite(arr) | (np.abs(arr) > 1e6))]
        if bad or (what in ("velocity", "effort") and np.any(arr <= 0)):
            bad = bad or [actuated[i] for i in np.flatnonzero(arr <= 0)]
            raise RobotConfigError(f"{what} limit missing or invalid in {urdf.name} for "
                                   f"{', '.join(bad)}: give it in [limits]", path=config.path,
                                   key="limits")
    bad = [actuated[i] for i in np.flatnonzero(q_lower >= q_upper)]
    if bad:
        raise RobotConfigError(f"lower position limit not below upper for {', '.join(bad)}",
                               path=config.path, key="limits.position")
    model.lowerPositionLimit[7:] = q_lower
    model.upperPositionLimit[7:] = q_upper
    model.velocityLimit[6:] = v_max
    model.effortLimit[6:] = effort

    # --- geometry items per link (in link frames; valid for the reduced model: links keep names)
    coll = _geometry_items(pin, full, geoms["collision"], "collision")
    vis = _geometry_items(pin, full, geoms["visual"], "visual")
    by_link: dict[str, dict[str, list[GeometryItem]]] = {}
    for it in coll + vis:
        by_link.setdefault(it.frame, {"collision": [], "visual": []})[it.source].append(it)

    def link_items(link: str, prefer_visual: bool) -> list[GeometryItem]:
        d = by_link.get(link, {"collision": [], "visual": []})
        if prefer_visual and d["visual"]:
            return d["visual"]
        return d["collision"] or d["visual"]

    # --- soles
    soles: dict[str, SoleRectangle] = {}
    for side in SIDES:
        if side in config.soles:
            soles[side] = config.soles[side]
            continue
        foot = config.foot_frames[side]
        items = _foot_items(pin, full, foot, link_items)
        try:
            soles[side] = derive_sole(items, foot)
        except RobotConfigError as exc:
            raise RobotConfigError(str(exc), path=config.path, key=f"soles.{side}") from None
        log.debug("robot %s: %s sole derived from %s geometry: centre %s, half extents %s",
                  config.name, side, items[0].source if items else "-",
                  np.round(soles[side].center, 4), np.round(soles[side].half_extents, 4))

    # --- collision proxies
    chosen: list[GeometryItem] = []
    for link in by_link:
        if link in config.collision.skip:
            continue
        chosen += link_items(link, prefer_visual=link in config.collision.use_visual)
    shapes = build_proxies(chosen)

    built = _Built(config=config, markers=markers, urdf=urdf, model=model,
                   q_nominal=np.zeros(model.nq), q_lower=q_lower, q_upper=q_upper, v_max=v_max,
                   a_max=a_max, effort_max=effort, soles=soles, shapes=shapes, ignored=set(),
                   geometry=by_link)
    robot = Robot(built)  # a provisional Robot to compute the nominal pose and ignored pairs
    built.q_nominal = robot._standing_pose()
    frame_joint = {s.frame: int(model.frames[robot.frame_id(s.frame)].parentJoint)
                   for s in shapes}
    built.adjacent = adjacent_frame_pairs(frame_joint, list(model.parents))
    ignored = set(built.adjacent)
    ignored |= {pair_key(a, b) for a, b in config.collision.ignore}
    margin = config.collision.touch_margin
    for (a, b), d in robot.shape_pair_distances(built.q_nominal, exclude=ignored).items():
        if d < margin:
            ignored.add((a, b))
            log.debug("robot %s: ignoring %s-%s (distance %.4f m in the nominal pose)",
                      config.name, a, b, d)
    built.ignored = ignored
    return built


#: The robot of ``load_robot(None)`` and of the command line without --robot.
DEFAULT_ROBOT = "jvrc1"


def load_robot(name_or_toml: str | os.PathLike | None = None,
               urdf: str | os.PathLike | None = None) -> Robot:
    """Load a robot: its configuration, its reduced pinocchio model, soles, proxies, nominal pose.

    Args:
        name_or_toml: a robot name (a folder of ``robots/``: see :func:`list_robots`), a robot
            folder, or a path to a robot.toml. None: with ``urdf``, a configuration generated
            from the URDF alone (:func:`imesh.robot.generate.generate_for_urdf`, cached);
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
            from .generate_files import generate_for_urdf

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


# ----------------------------------------------------------------------------------------------
# the Robot


@dataclass(frozen=True, eq=False)
class TrajectoryKinematics:
    """Kinematics of a configuration trajectory (:meth:`Robot.trajectory_kinematics`).

    Attributes:
        placements: (T, F, 4, 4) float world poses of the frames.
        jacobians: (T, F, 6, nv) float world-aligned frame Jacobians (rows 0-2 the origin's
            linear velocity, 3-5 the angular velocity).
        com: (T, 3) float [m] centre of mass.
        com_jacobians: (T, 3, nv) float Jacobians of the centre of mass.
    """

    placements: np.ndarray
    jacobians: np.ndarray
    com: np.ndarray
    com_jacobians: np.ndarray


def _skew(r: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


class Robot:
    """A humanoid robot model (see the module docstring for q and v).

    Attributes:
        name: robot name.
        config: the robot.toml content.
        markers: the markers.toml content (keypoints, directions, arrangement), or None.
        urdf: the URDF file loaded.
        model: pinocchio.Model with a free-flyer root, reduced (fixed joints removed).
        data: pinocchio.Data of this Robot.
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
        collision_shapes: primitive proxies (frame, kind, dims, placement in frame).
        ignored_pairs: sorted frame-name pairs never checked for self-collision (adjacent in
            the tree, rigidly attached, listed in robot.toml, or touching in the nominal pose).
    """

    def __init__(self, built: _Built):
        self._pin = _pinocchio()
        self._built = built
        self.config: RobotConfig = built.config
        self.name: str = built.config.name
        self.markers: MarkerConfig | None = built.markers
        self.urdf: Path = built.urdf
        self.model = built.model
        self.data = self.model.createData()
        self.nq: int = int(self.model.nq)
        self.nv: int = int(self.model.nv)
        self.joint_names: tuple[str, ...] = tuple(self.model.names)[2:]
        self.q_lower = built.q_lower.copy()
        self.q_upper = built.q_upper.copy()
        self.v_max = built.v_max.copy()
        self.a_max = built.a_max.copy()
        self.effort_max = built.effort_max.copy()
        self.q_nominal = built.q_nominal.copy()
        self.mass: float = float(self._pin.computeTotalMass(self.model))
        self.soles: dict[str, SoleRectangle] = dict(built.soles)
        self.waist_frame: str = built.config.waist_frame
        self.foot_frames: dict[str, str] = dict(built.config.foot_frames)
        self.collision_shapes: list[CollisionShape] = list(built.shapes)
        self.ignored_pairs: set[tuple[str, str]] = set(built.ignored)
        self._frame_cache: dict[str, int] = {}
        self._q: np.ndarray | None = None
        self._jac_valid = False
        self._world: CollisionWorld | None = None
        self._world_pairs: tuple | None = None

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
        return _frame_names(self.model)

    def frame_id(self, name: str) -> int:
        """The pinocchio frame index of a frame (link frames preferred over joint frames).

        Raises:
            RobotConfigError: unknown frame, listing the valid names (closest first).
        """
        idx = self._frame_cache.get(name)
        if idx is None:
            idx = _find_frame(self._pin, self.model, name)
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

    # --- kinematics --------------------------------------------------------------------------

    def _check_q(self, q) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        if q.shape != (self.nq,):
            raise ImeshError(f"robot {self.name!r}: q must have shape ({self.nq},), got "
                             f"{q.shape}")
        return q

    def forward(self, q) -> None:
        """Forward kinematics and joint Jacobians at ``q`` (the getters then accept q=None, and
        getters called with this same ``q`` reuse the result instead of recomputing).

        Args:
            q: (nq,) float configuration.
        """
        q = self._check_q(q)
        self._pin.computeJointJacobians(self.model, self.data, q)
        self._pin.updateFramePlacements(self.model, self.data)
        self._q = q.copy()
        self._jac_valid = True

    def _same_q(self, q) -> bool:
        return self._q is not None and np.array_equal(q, self._q)

    def _fk(self, q) -> None:
        if q is not None:
            q = self._check_q(q)
            if self._same_q(q):  # already computed (e.g. by forward(q)): reuse
                return
            self._pin.framesForwardKinematics(self.model, self.data, q)
            self._q = q.copy()
            self._jac_valid = False
        elif self._q is None:
            raise ImeshError("no configuration yet: pass q or call forward(q) first")

    def _jac(self, q) -> None:
        if q is not None:
            q = self._check_q(q)
            if not (self._jac_valid and self._same_q(q)):
                self.forward(q)
        elif self._q is None:
            raise ImeshError("no configuration yet: pass q or call forward(q) first")
        elif not self._jac_valid:
            self.forward(self._q)

    def frame_placements(self, q, frames: FrameRefs) -> np.ndarray:
        """(F, 4, 4) float world poses of frames.

        Args:
            q: (nq,) configuration, or None to reuse the last one.
            frames: frame indices (or names).
        """
        self._fk(q)
        return np.array([self.data.oMf[i].homogeneous for i in self._ids(frames)])

    def frame_positions(self, q, frames: FrameRefs,
                        offsets: np.ndarray | None = None) -> np.ndarray:
        """(F, 3) float [m] world positions of points fixed in frames.

        Args:
            q: (nq,) configuration, or None to reuse the last forward().
            frames: F frame indices (or names).
            offsets: (F, 3) float [m] point positions in their frames; None = frame origins.
        """
        self._fk(q)
        ids = self._ids(frames)
        out = np.empty((len(ids), 3))
        for k, i in enumerate(ids):
            M = self.data.oMf[i]
            out[k] = M.translation if offsets is None else M.rotation @ offsets[k] + M.translation
        return out

    def frame_rotations(self, q, frames: FrameRefs) -> np.ndarray:
        """(F, 3, 3) float world rotations of frames (columns = frame axes in the world)."""
        self._fk(q)
        return np.array([self.data.oMf[i].rotation for i in self._ids(frames)])

    def point_jacobians(self, q, frames: FrameRefs,
                        offsets: np.ndarray | None = None) -> np.ndarray:
        """(F, 3, nv) float world-aligned linear Jacobians of points fixed in frames.

        ``d p_world = J @ v`` for a velocity ``v`` in pinocchio's convention, so a finite step
        ``integrate(q, eps * dv)`` moves the point by ``eps * J @ dv`` to first order.

        Args:
            q: (nq,) configuration, or None to reuse the last forward().
            frames: F frame indices (or names).
            offsets: (F, 3) float [m] point positions in their frames; None = frame origins.
        """
        self._jac(q)
        pin = self._pin
        ids = self._ids(frames)
        out = np.empty((len(ids), 3, self.nv))
        for k, i in enumerate(ids):
            J = pin.getFrameJacobian(self.model, self.data, i, pin.LOCAL_WORLD_ALIGNED)
            if offsets is None:
                out[k] = J[:3]
            else:
                r = self.data.oMf[i].rotation @ offsets[k]
                out[k] = J[:3] - _skew(r) @ J[3:]
        return out

    def frame_jacobians(self, q, frames: FrameRefs) -> np.ndarray:
        """(F, 6, nv) float world-aligned Jacobians of frames: rows 0-2 the frame origin's
        linear velocity, rows 3-5 the angular velocity (one pinocchio call per frame, where
        :meth:`point_jacobians` and :meth:`frame_angular_jacobians` make one each)."""
        self._jac(q)
        pin = self._pin
        out = np.empty((len(frames), 6, self.nv))
        for k, i in enumerate(self._ids(frames)):
            out[k] = pin.getFrameJacobian(self.model, self.data, i, pin.LOCAL_WORLD_ALIGNED)
        return out

    def trajectory_kinematics(self, q: np.ndarray, frames: FrameRefs
                              ) -> TrajectoryKinematics:
        """Placements and world-aligned Jacobians of frames, CoM and its Jacobian, at every
        configuration of a trajectory (one pass of pinocchio calls per configuration: joint
        Jacobians once, then the frames and the CoM from them).

        Args:
            q: (T, nq) float configurations.
            frames: F frame indices (or names).
        """
        pin, model, data = self._pin, self.model, self.data
        q = np.asarray(q, dtype=float)
        ids = self._ids(frames)
        T = len(q)
        place = np.empty((T, len(ids), 4, 4))
        jac = np.empty((T, len(ids), 6, self.nv))
        com = np.empty((T, 3))
        jcom = np.empty((T, 3, self.nv))
        world = pin.LOCAL_WORLD_ALIGNED
        for t in range(T):  # pinocchio is per configuration; ~30 us per frame
            pin.computeJointJacobians(model, data, q[t])
            pin.updateFramePlacements(model, data)
            jcom[t] = pin.jacobianCenterOfMass(model, data, True)
            com[t] = data.com[0]
            for k, i in enumerate(ids):
                place[t, k] = data.oMf[i].homogeneous
                jac[t, k] = pin.getFrameJacobian(model, data, i, world)
        self._q = None  # the data no longer matches a single cached configuration
        self._jac_valid = False
        return TrajectoryKinematics(placements=place, jacobians=jac, com=com,
                                    com_jacobians=jcom)

    def centroidal_trajectory(self, q: np.ndarray, v: np.ndarray, a: np.ndarray
                              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Centroidal quantities along a trajectory (pinocchio ``ccrba`` and
        ``computeCentroidalMomentumTimeVariation``).

        Args:
            q: (T, nq) configurations; v, a: (T, nv) velocities and accelerations.

        Returns:
            (com (T, 3) [m], dh (T, 6) rate of the centroidal momentum [linear N, angular Nm]
            about the CoM, Ag (T, 6, nv) centroidal momentum matrix: ``h = Ag v``).
        """
        pin, model, data = self._pin, self.model, self.data
        T = len(q)
        com, dh, ag = np.empty((T, 3)), np.empty((T, 6)), np.empty((T, 6, self.nv))
        for t in range(T):  # pinocchio is per configuration
            ag[t] = pin.ccrba(model, data, q[t], v[t])
            dh[t] = pin.computeCentroidalMomentumTimeVariation(model, data, q[t], v[t],
                                                               a[t]).np
            com[t] = data.com[0]
        self._q = None
        self._jac_valid = False
        return com, dh, ag

    def inverse_dynamics_trajectory(self, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                                    derivatives: np.ndarray | None = None):
        """Inverse dynamics along a trajectory (pinocchio ``rnea``; where asked, also
        ``computeRNEADerivatives``).

        Args:
            q: (T, nq) configurations; v, a: (T, nv) velocities and accelerations.
            derivatives: (T,) bool frames whose partial derivatives are wanted (None: none).

        Returns:
            (tau (T, nv), dtau (T, 3, nv, nv)): generalized forces (the base's wrench in the base
            frame, then joint torques [Nm]) and, at the frames asked for, ``[dtau/dq, dtau/dv,
            dtau/da]`` (with respect to a tangent perturbation of q); zeros elsewhere.
        """
        pin, model, data = self._pin, self.model, self.data
        T = len(q)
        tau = np.empty((T, self.nv))
        dtau = np.zeros((T, 3, self.nv, self.nv))
        want = np.zeros(T, bool) if derivatives is None else np.asarray(derivatives, bool)
        upper = np.triu(np.ones((self.nv, self.nv), bool), 1)
        for t in range(T):  # pinocchio is per configuration
            tau[t] = pin.rnea(model, data, q[t], v[t], a[t])
            if want[t]:
                dq, dv, da = pin.computeRNEADerivatives(model, data, q[t], v[t], a[t])
                dtau[t, 0], dtau[t, 1], dtau[t, 2] = dq, dv, da
                # pinocchio fills only the upper triangle of dtau/da (the mass matrix)
                dtau[t, 2][upper.T] = dtau[t, 2].T[upper.T]
        self._q = None
        self._jac_valid = False
        return tau, dtau

    def frame_angular_jacobians(self, q, frames: FrameRefs) -> np.ndarray:
        """(F, 3, nv) float world angular-velocity Jacobians of frames (``omega = J @ v``)."""
        self._jac(q)
        pin = self._pin
        return np.array([pin.getFrameJacobian(self.model, self.data, i,
                                              pin.LOCAL_WORLD_ALIGNED)[3:]
                         for i in self._ids(frames)])

    def integrate(self, q, dv) -> np.ndarray:
        """(nq,) ``q (+) dv``: move the configuration by the tangent vector ``dv`` (nv,)."""
        return np.asarray(self._pin.integrate(self.model, self._check_q(q),
                                              np.asarray(dv, dtype=float)))

    def difference(self, q0, q1) -> np.ndarray:
        """(nv,) tangent vector ``dv`` with ``integrate(q0, dv) == q1``."""
        return np.asarray(self._pin.difference(self.model, self._check_q(q0),
                                               self._check_q(q1)))

    def _resync(self, q: np.ndarray) -> None:
        """After a pinocchio call that overwrote the joint placements for ``q``: make the frame
        placements match ``q`` again (so q=None getters mean the last configuration used)."""
        self._pin.framesForwardKinematics(self.model, self.data, q)
        self._q = q.copy()
        self._jac_valid = False

    def _q_or_last(self, q) -> np.ndarray:
        if q is None:
            if self._q is None:
                raise ImeshError("no configuration yet: pass q or call forward(q) first")
            return self._q
        return self._check_q(q)

    def com(self, q=None) -> np.ndarray:
        """(3,) float [m] world centre of mass (q None: the last configuration)."""
        q = self._q_or_last(q)
        c = np.array(self._pin.centerOfMass(self.model, self.data, q))
        self._resync(q)
        return c

    def com_jacobian(self, q=None) -> np.ndarray:
        """(3, nv) float Jacobian of the centre of mass (q None: the last configuration)."""
        q = self._q_or_last(q)
        J = np.array(self._pin.jacobianCenterOfMass(self.model, self.data, q))
        self._resync(q)
        return J

    def zmp(self, q, v, a, ground_z: float = 0.0) -> np.ndarray:
        """(2,) float [m] multibody ZMP (x, y) on the plane z = ``ground_z``.

        From the CoM ``c`` and the rate of the centroidal momentum (linear ``m cddot`` and
        angular ``Ldot`` about the CoM):
        ``p_x = c_x - ((c_z - z0) cddot_x + Ldot_y / m) / (cddot_z + g)``,
        ``p_y = c_y - ((c_z - z0) cddot_y - Ldot_x / m) / (cddot_z + g)``.

        Args:
            q: (nq,) configuration; v: (nv,) velocity; a: (nv,) acceleration (pinocchio
            convention, base twist in the base frame).
        """
        pin = self._pin
        q = self._check_q(q)
        dh = np.array(pin.computeCentroidalMomentumTimeVariation(
            self.model, self.data, q, np.asarray(v, float), np.asarray(a, float)))
        c = np.array(self.data.com[0])
        m = self.mass
        cdd = dh[:3] / m
        ldot = dh[3:]
        denom = cdd[2] + GRAVITY
        h = c[2] - ground_z
        self._resync(q)
        return np.array([c[0] - (h * cdd[0] + ldot[1] / m) / denom,
                         c[1] - (h * cdd[1] - ldot[0] / m) / denom])

    def inverse_dynamics(self, q, v, a) -> np.ndarray:
        """(nv,) float generalized forces ``M(q) a + C(q, v) v + g(q)`` (recursive Newton-Euler;
        pinocchio convention: the first 6 rows are the wrench the free-flyer needs, in the base
        frame, the rest joint torques [Nm])."""
        q = self._check_q(q)
        tau = np.array(self._pin.rnea(self.model, self.data, q, np.asarray(v, float),
                                      np.asarray(a, float)))
        self._resync(q)
        return tau

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

    def _standing_pose(self) -> np.ndarray:
        """Nominal joints from robot.toml, ankles adjusted so both soles are level, base level
        above the origin at the height that puts the soles on z = 0."""
        pin = self._pin
        cfg = self.config
        q = np.zeros(self.nq)
        q[6] = 1.0
        for n in self.joint_names:
            q[7 + self.joint_index(n)] = cfg.nominal.get(n, 0.0)
        z = np.array([0.0, 0.0, 1.0])
        for side in SIDES:
            sole = self.soles[side]
            fid = self.frame_id(sole.frame)
            # the two joints closest to the foot level the sole (ankle pitch and roll)
            j = self.model.frames[fid].parentJoint
            chain = [j, self.model.parents[j]]
            cols = [self.model.joints[k].idx_v for k in chain if k > 1]
            qcols = [self.model.joints[k].idx_q for k in chain if k > 1]
            for _ in range(50):
                self.forward(q)
                n = self.data.oMf[fid].rotation @ sole.normal
                err = n - z
                if np.linalg.norm(err) < 1e-13:
                    break
                Jw = pin.getFrameJacobian(self.model, self.data, fid,
                                          pin.LOCAL_WORLD_ALIGNED)[3:, cols]
                dn = -_skew(n) @ Jw  # d n / d theta
                step = np.linalg.lstsq(dn, -err, rcond=None)[0]
                q[qcols] += step
            else:
                raise RobotConfigError(f"cannot level the {side} sole with the ankle joints",
                                       path=cfg.path, key="nominal")
            moved = {self.model.names[k]: q[self.model.joints[k].idx_q]
                     - cfg.nominal.get(self.model.names[k], 0.0) for k in chain if k > 1}
            if any(abs(d) > 1e-3 for d in moved.values()):
                log.info("robot %s: nominal %s adjusted by %s rad to level the %s sole",
                         self.name, ", ".join(moved),
                         ", ".join(f"{d:+.4f}" for d in moved.values()), side)
        self.forward(q)
        heights = {s: self.sole_center(None, s)[2] for s in SIDES}
        if abs(heights["left"] - heights["right"]) > 1e-6:
            raise RobotConfigError(
                f"the nominal pose puts the soles at different heights (left {heights['left']:.4f}"
                f" m, right {heights['right']:.4f} m relative to the base): use a symmetric "
                "[nominal] leg pose", path=cfg.path, key="nominal")
        q[2] = -(heights["left"] + heights["right"]) / 2
        bad = [n for i, n in enumerate(self.joint_names)
               if not self.q_lower[i] - 1e-9 <= q[7 + i] <= self.q_upper[i] + 1e-9]
        if bad:
            raise RobotConfigError(f"nominal pose outside the position limits for "
                                   f"{', '.join(bad)}", path=cfg.path, key="nominal")
        self._q = None
        return q

    # --- collision -----------------------------------------------------------------------------

    def shape_poses(self, q) -> np.ndarray:
        """(S, 4, 4) float world poses of ``collision_shapes`` (q None: last configuration)."""
        self._fk(q)
        return np.array([self.data.oMf[self.frame_id(s.frame)].homogeneous @ s.placement
                         for s in self.collision_shapes])

    def _collision_world(self, pairs: tuple) -> CollisionWorld:
        if self._world is None or self._world_pairs != pairs:
            self._world = CollisionWorld(self.collision_shapes, list(pairs))
            self._world_pairs = pairs
        return self._world

    def _checked_pairs(self, exclude: set[tuple[str, str]]) -> tuple:
        shapes = self.collision_shapes
        return tuple((i, j) for i in range(len(shapes)) for j in range(i + 1, len(shapes))
                     if shapes[i].frame != shapes[j].frame
                     and pair_key(shapes[i].frame, shapes[j].frame) not in exclude)

    def shape_pair_distances(self, q, exclude: set[tuple[str, str]] | None = None
                             ) -> dict[tuple[str, str], float]:
        """Signed distances [m] between the proxies of every frame pair not in ``exclude``
        (default: ``ignored_pairs``); negative = penetration depth; minimum over the frames'
        shapes; keys are sorted frame-name pairs."""
        exclude = self.ignored_pairs if exclude is None else exclude
        world = self._collision_world(self._checked_pairs(exclude))
        world.set_poses(self.shape_poses(q))
        out: dict[tuple[str, str], float] = {}
        for (i, j), d in zip(world.pairs, world.distances(), strict=True):
            key = pair_key(self.collision_shapes[i].frame, self.collision_shapes[j].frame)
            out[key] = min(out.get(key, np.inf), float(d))
        return out

    def self_collisions(self, q, depth: float = 0.005) -> list[tuple[str, str, float]]:
        """Non-ignored frame pairs penetrating deeper than ``depth`` [m] at ``q``.

        Returns:
            (frame_a, frame_b, penetration [m] > 0), deepest first.
        """
        hits = [(a, b, -d) for (a, b), d in self.shape_pair_distances(q).items() if -d > depth]
        return sorted(hits, key=lambda h: -h[2])

    def capsule_model(self) -> CapsuleModel:
        """The self-collision capsules and the pairs checked
        (:class:`imesh.robot.capsules.CapsuleModel`), built on first use and shared by the
        Robots of the same files."""
        if self._built.capsules is None:
            from .capsules import build_capsule_model

            self._built.capsules = build_capsule_model(self)
        return self._built.capsules

    def link_geometry(self) -> dict:
        """link -> {"collision": [GeometryItem], "visual": [GeometryItem]} of the URDF."""
        return self._built.geometry

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
