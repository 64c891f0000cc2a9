"""From a robot.toml and a URDF to the reduced pinocchio model and what is derived from it once:
limits, soles, geometry per link and primitive collision proxies.

:func:`build_model` is the expensive step of loading a robot (parsing the URDF and its meshes);
:func:`imesh.robot.model.load_robot` keeps its result per (robot.toml, URDF) and completes it
with the nominal pose and the ignored collision pairs, which need a Robot.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from importlib import import_module, metadata
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .capsules.model import CapsuleModel
from .collision import CollisionShape, GeometryItem, build_proxies, derive_sole
from .config import SIDES, RobotConfig, SoleRectangle
from .errors import RobotConfigError, closest_first
from .geometry import geometry_items
from .inertia import regularize_inertias
from .markers_config import MarkerConfig
from .pin import _pinocchio, find_frame, frame_names

if TYPE_CHECKING:  # pragma: no cover - typing only
    import pinocchio  # no type information: its classes are Any to mypy

log = logging.getLogger(__name__)

#: link name, prefer the visual geometry -> the link's geometry items.
LinkItems = Callable[[str, bool], list[GeometryItem]]

# ----------------------------------------------------------------------------------------------
# locating the URDF


def _package_dirs(urdf: Path, extra: Sequence[Path] = ()) -> list[str]:
    """Folders where ``package://NAME/...`` mesh URIs are looked up (pinocchio searches
    ``DIR/NAME/...``): the URDF's ancestors and the package's parent folder."""
    dirs = [*extra, *list(urdf.resolve().parents)[:6]]
    return list(dict.fromkeys(str(d) for d in dirs))


def _distribution_file(dist: metadata.Distribution, suffix: str) -> Path | None:
    """The installed file of a distribution whose path ends with ``suffix`` (``/``-separated),
    or None. Its RECORD is searched as text first (G1's example-robot-data lists 1,029 files:
    ``dist.files`` makes a path object of each, 45-90 ms of every robot load), then
    ``dist.files`` (distributions without a RECORD, quoted names)."""
    for line in (dist.read_text("RECORD") or "").splitlines():
        name = line.rsplit(",", 2)[0]  # path,hash,size
        if name.replace("\\", "/").endswith(suffix):
            path = Path(str(dist.locate_file(name)))
            if path.is_file():
                return path
    for f in dist.files or ():
        if str(f).replace("\\", "/").endswith(suffix):
            # typed as a SimplePath: a pathlib.Path for an installed distribution
            path = Path(str(dist.locate_file(f)))
            if path.is_file():
                return path
    return None


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
            found = _distribution_file(dist, suffix)
            if found is not None:
                return found, _package_dirs(found)
            tried.append(f"{m.distribution} files ending with {suffix}")
    raise RobotConfigError(
        f"the model of robot {config.name!r} is not installed ({'; '.join(tried)} not found): "
        f"{install}", path=config.path, key="model")



# ----------------------------------------------------------------------------------------------
# building


@dataclass
class BuiltModel:
    """Everything loading a robot computes once per (robot.toml, URDF) and shares between the
    Robots of the same files (:func:`imesh.robot.model.load_robot`).

    :func:`build_model` fills all but ``q_nominal``, which needs a
    Robot (``load_robot`` completes it, or reads it with the soles and proxies from the
    robot cache, :mod:`imesh.robot.model_cache`); ``capsules`` is built on first use, and so is
    ``geometry`` when the soles and proxies came from the cache (:meth:`link_geometry`).

    Attributes:
        q_nominal: (nq,) float nominal standing pose.
        q_lower, q_upper: (nq-7,) float [rad] position limits.
        v_max: (nv-6,) float [rad/s]; a_max: (nv-6,) float [rad/s^2]; effort_max: (nv-6,)
            float [Nm].
        geometry: link -> {"collision": [GeometryItem], "visual": [GeometryItem]}, or None
            until :meth:`link_geometry` loads it.
        full: the pinocchio model before the reduction (the geometry's frames refer to it).
        package_dirs: folders for the URDF's ``package://`` mesh URIs.
        cache_key: the robot cache key of these files (:func:`imesh.robot.model_cache.robot_key`),
            or "" when the robot cache is off.
    """

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
    geometry: dict | None = None
    capsules: CapsuleModel | None = None
    full: pinocchio.Model | None = None
    package_dirs: list[str] = field(default_factory=list)
    cache_key: str = ""

    def link_geometry(self) -> dict:
        """link -> {"collision": [GeometryItem], "visual": [GeometryItem]}: the URDF's
        geometry, its meshes read on first use (:func:`load_geometry`)."""
        if self.geometry is None:
            self.geometry = load_geometry(self.full, self.urdf, self.package_dirs)
        return self.geometry


def _set_joint(model, q: np.ndarray, jid: int, value: float) -> None:
    """Set joint ``jid`` of configuration ``q`` (nq,) to the angle ``value`` [rad] in place."""
    j = model.joints[jid]
    if j.nq == 1:
        q[j.idx_q] = value
    elif j.nq == 2:  # continuous joint stored as (cos, sin)
        q[j.idx_q:j.idx_q + 2] = [np.cos(value), np.sin(value)]
    else:
        raise RobotConfigError(f"joint {model.names[jid]!r} is not a 1-DOF joint")


def _foot_items(model, foot: str, link_items: LinkItems) -> list[GeometryItem]:
    """Geometry of the links on the foot frame's joint, expressed in the foot frame (which may
    be a frame on the foot link rather than the link, e.g. iCub's ``l_sole``)."""
    pin = _pinocchio()
    fid = find_frame(model, foot)
    joint = model.frames[fid].parentJoint
    to_foot = model.frames[fid].placement.inverse()
    items = []
    for f in model.frames:
        if f.parentJoint != joint or f.type != pin.FrameType.BODY:
            continue
        T = (to_foot * f.placement).homogeneous
        items += [it if f.name == foot else dataclasses.replace(it, frame=foot,
                                                                placement=T @ it.placement)
                  for it in link_items(f.name, False)]
    return items


def load_geometry(full, urdf: Path, package_dirs: list[str]) -> dict:
    """The URDF's collision and visual geometry per link, meshes read (pinocchio and coal:
    about 4.5 s for the G1's 71 meshes, so a robot read from the robot cache does this only
    when something asks for the meshes: the capsule fit, the mesh collision check).

    Args:
        full: the pinocchio model of the URDF (before the reduction).
        urdf: the URDF file.
        package_dirs: folders for its ``package://`` mesh URIs (:func:`resolve_urdf`).

    Returns:
        link -> {"collision": [GeometryItem], "visual": [GeometryItem]}, items in link frames
        (valid for the reduced model: links keep their names).

    Raises:
        RobotConfigError: a mesh does not load.
    """
    pin = _pinocchio()
    geoms = {}
    for kind, gtype in (("collision", pin.GeometryType.COLLISION),
                        ("visual", pin.GeometryType.VISUAL)):
        try:
            geoms[kind] = pin.buildGeomFromUrdf(full, str(urdf), gtype, None, package_dirs)
        except Exception as exc:
            raise RobotConfigError(f"cannot load the {kind} geometry (mesh files are looked up "
                                   f"relative to {', '.join(package_dirs[:3])}): {exc}",
                                   path=urdf) from None
    coll = geometry_items(full, geoms["collision"], "collision")
    vis = geometry_items(full, geoms["visual"], "visual")
    by_link: dict[str, dict[str, list[GeometryItem]]] = {}
    for it in coll + vis:
        by_link.setdefault(it.frame, {"collision": [], "visual": []})[it.source].append(it)
    return by_link


def mesh_files(geometry: dict) -> list[str]:
    """The mesh files the geometry was read from (absolute paths, each once, sorted)."""
    return sorted({str(Path(p).resolve()) for d in geometry.values()
                   for items in d.values() for it in items
                   if (p := it.mesh_path)})


def build_model(config: RobotConfig, markers: MarkerConfig | None, urdf: Path,
                package_dirs: list[str], geometry: bool = True) -> BuiltModel:
    """Parse the URDF, reduce it by ``joints.fixed``, check the configuration against it and
    derive limits, soles, geometry and collision proxies.

    Args:
        config: the robot.toml content.
        markers: the markers.toml content (its frames are checked), or None.
        urdf: the URDF file.
        package_dirs: folders for its ``package://`` mesh URIs (:func:`resolve_urdf`).
        geometry: read the meshes and derive the soles and proxies from them. False: the model,
            the checks and the limits only (soles and shapes empty, ``geometry`` None), for a
            robot whose soles and proxies come from the robot cache.

    Returns:
        The built model without the nominal pose and the ignored pairs (see
        :class:`BuiltModel`).

    Raises:
        RobotConfigError: the URDF or its meshes do not load, or the configuration names
            joints or frames the model lacks, or limits are missing or invalid.
    """
    pin = _pinocchio()
    try:
        tree = ET.parse(urdf)
    except ET.ParseError as exc:
        raise RobotConfigError(f"URDF does not parse: {exc}", path=urdf) from None
    try:
        if regularize_inertias(tree.getroot()):  # as DART gets them (imesh.robot.inertia)
            full = pin.buildModelFromXML(ET.tostring(tree.getroot(), encoding="unicode"),
                                         pin.JointModelFreeFlyer())
        else:
            full = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
    except Exception as exc:  # pinocchio raises ValueError/RuntimeError with the parser message
        raise RobotConfigError(f"URDF does not parse: {exc}", path=urdf) from None
    by_link = load_geometry(full, urdf, package_dirs) if geometry else None

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
    frames = frame_names(model)
    refs = [(config.path, k, f) for k, f in config.frame_references()]
    if markers is not None:
        refs += [(markers.path, k, f) for k, f in markers.frame_references()]
    refs += [(config.path, "collision.use_visual", f) for f in config.collision.use_visual]
    refs += [(config.path, "collision.skip", f) for f in config.collision.skip]
    for path, key, name in refs:
        if find_frame(model, name) < 0:
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

    built = BuiltModel(config=config, markers=markers, urdf=urdf, model=model,
                       q_nominal=np.zeros(model.nq), q_lower=q_lower, q_upper=q_upper,
                       v_max=v_max, a_max=a_max, effort_max=effort, soles={}, shapes=[],
                       geometry=by_link, full=full,
                       package_dirs=list(package_dirs))
    if by_link is None:
        return built
    built.soles, built.shapes = derive_soles_and_proxies(config, full, by_link)
    return built


def derive_soles_and_proxies(config: RobotConfig, full, by_link: dict
                             ) -> tuple[dict[str, SoleRectangle], list[CollisionShape]]:
    """The soles (robot.toml's, else derived from the foot geometry) and the primitive
    collision proxies of a robot, from its URDF geometry per link (:func:`load_geometry`).

    Raises:
        RobotConfigError: a sole cannot be derived (naming ``soles.<side>``).
    """

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
        items = _foot_items(full, foot, link_items)
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
    return soles, build_proxies(chosen)
