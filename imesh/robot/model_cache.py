"""The robot cache: what loading a robot derives from its URDF's meshes, kept on disk.

Reading the G1's 71 meshes (pinocchio's ``buildGeomFromUrdf``, coal's BVH building) is 95 % of
loading it (about 3-4.5 s); parsing the URDF and reducing the model take 10 ms. So the pinocchio
model is always built from the URDF (no pinocchio object is stored), and what is derived from
the meshes is stored in imesh's cache folder (``models/``, :func:`imesh.core.cache.cache_root`):
the soles, the primitive collision proxies, the nominal standing pose, the adjacent and the
ignored proxy pairs (:class:`CachedRobot`); and, once the whole-body solve or the evaluator has
asked for them, the self-collision capsules with their ignore list (:class:`CachedCapsules`).
A robot read from the cache reads its meshes only when something needs them
(:meth:`imesh.robot.build.BuiltModel.link_geometry`: the capsule fit on a cache miss, the
mesh collision check, ``imesh robots --collisions``).

Keys (:func:`robot_key`) hash the bytes of the URDF, robot.toml and markers.toml, their paths
and the mesh search folders, the imesh, pinocchio and coal versions, :data:`ROBOT_CACHE_VERSION`
and the source of the modules that compute the entries; the capsule key adds the bytes of
``collision_pairs.toml``. An entry also lists the mesh files it was derived from with their
sizes and modification times: a changed mesh is a miss. A file that does not read, lists other
joints or other sizes is computed again, never trusted. ``IMESH_CACHE_DIR=""`` turns it off.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..core.cache import READ_ERRORS, cache_enabled, cache_file, read_cached, write_cached
from .collision import CollisionShape
from .config import RobotConfig, SoleRectangle
from .pin import _pinocchio

if TYPE_CHECKING:  # pragma: no cover - typing only
    from .build import BuiltModel
    from .capsules.model import Capsule
    from .model import Robot

log = logging.getLogger(__name__)

#: Bump when what the robot cache stores, or how it is computed, changes.
ROBOT_CACHE_VERSION = 3

#: Cache folder kinds (``<cache>/<kind>/<key>.npz``).
MODELS_KIND = "models"
CAPSULES_KIND = "capsule-models"

_HERE = Path(__file__).resolve().parent

#: The modules whose code computes the robot entry (their source is part of the key).
ROBOT_SOURCES = ("build.py", "collision.py", "config.py", "geometry.py", "markers_config.py",
                 "model.py", "model_cache.py", "standing.py")
#: The same for the capsule entry (added to the robot's key).
CAPSULE_SOURCES = ("capsules/bodies.py", "capsules/fit.py", "capsules/hulls.py",
                   "capsules/mesh_check.py",
                   "capsules/model.py", "capsules/pairs.py", "capsules/robot.py")


@functools.cache
def _source_digest(files: tuple[str, ...]) -> bytes:
    """A hash of the source of imesh.robot modules (an installation without its .py files
    hashes their names only: the imesh version and ROBOT_CACHE_VERSION then stand for it)."""
    h = hashlib.sha256()
    for name in files:
        try:
            source = (_HERE / name).read_bytes()
        except OSError:
            source = b"(no source)"
        h.update(name.encode() + b"\0" + source)
    return h.digest()


def _file_bytes(path: Path | None) -> bytes:
    return b"-" if path is None or not Path(path).is_file() else Path(path).read_bytes()


def robot_key(config: RobotConfig, urdf: Path, package_dirs: Iterable[str]) -> str:
    """The robot cache key of a robot's files (see the module docstring): a 32-hex-digit hash.

    Args:
        config: its robot.toml content (``config.path``, ``config.markers_path``).
        urdf: the URDF file loaded.
        package_dirs: the folders its ``package://`` mesh URIs are looked up in.
    """
    from .. import __version__

    pin = _pinocchio()
    coal = getattr(pin, "coal", None) or getattr(pin, "hppfcl", None)
    h = hashlib.sha256(repr((
        "imesh robot cache", ROBOT_CACHE_VERSION, __version__, pin.__version__,
        getattr(coal, "__version__", ""), str(Path(urdf).resolve()), list(package_dirs),
        str(Path(config.path).resolve()),
        str(Path(config.markers_path).resolve()) if config.markers_path else "",
    )).encode())
    for path in (urdf, config.path, config.markers_path):
        data = _file_bytes(path)
        h.update(len(data).to_bytes(8, "little") + data)
    h.update(_source_digest(ROBOT_SOURCES))
    return h.hexdigest()[:32]


def _capsule_key(robot_key_: str, pairs_toml: Path) -> str:
    from .capsules.fit import FIT_VERSION, MAX_CAPSULES, SPLIT_GAIN, SPLIT_MAX_EDGE_M, SPLIT_RADIUS

    h = hashlib.sha256(repr(("imesh capsule cache", robot_key_, FIT_VERSION, MAX_CAPSULES,
                             SPLIT_GAIN, SPLIT_RADIUS, SPLIT_MAX_EDGE_M)).encode())
    h.update(_file_bytes(pairs_toml))
    h.update(_source_digest(CAPSULE_SOURCES))
    return h.hexdigest()[:32]


def _file_stats(paths: Iterable[str]) -> tuple[np.ndarray, np.ndarray]:
    """(sizes, modification times [ns]) of files, int64; -1 for a file that is missing."""
    sizes, mtimes = [], []
    for p in paths:
        try:
            st = os.stat(p)
            sizes.append(st.st_size)
            mtimes.append(st.st_mtime_ns)
        except OSError:
            sizes.append(-1)
            mtimes.append(-1)
    return np.array(sizes, dtype=np.int64), np.array(mtimes, dtype=np.int64)


def _pairs(pairs: Iterable[tuple[str, str]]) -> np.ndarray:
    return np.array(sorted(pairs), dtype=str).reshape(-1, 2)


def _pair_set(arr: np.ndarray) -> set[tuple[str, str]]:
    return {(str(a), str(b)) for a, b in arr}


@dataclass(frozen=True)
class CachedRobot:
    """What the robot cache holds for a robot (everything :func:`imesh.robot.model.load_robot`
    derives from the meshes and the nominal pose).

    Attributes:
        q_nominal: (nq,) float nominal standing pose.
        soles: ``"left"``/``"right"`` -> SoleRectangle.
        shapes: the primitive collision proxies.
    """

    q_nominal: np.ndarray
    soles: dict[str, SoleRectangle]
    shapes: list[CollisionShape]


def write_robot(key: str, built: BuiltModel) -> None:
    """Store a built model's mesh-derived parts under ``key`` (atomically; a read-only cache
    folder is no error)."""
    from .build import mesh_files

    meshes = mesh_files(built.link_geometry())
    sizes, mtimes = _file_stats(meshes)
    sides = sorted(built.soles)
    shapes = built.shapes
    dims = np.zeros((len(shapes), 3))
    for i, s in enumerate(shapes):
        dims[i, :len(s.dims)] = s.dims
    write_cached(
        MODELS_KIND, key, version=np.array(ROBOT_CACHE_VERSION),
        joint_names=np.array(list(built.model.names)[2:], dtype=str),
        q_nominal=np.asarray(built.q_nominal, dtype=float),
        sole_sides=np.array(sides, dtype=str),
        sole_frames=np.array([built.soles[s].frame for s in sides], dtype=str),
        sole_centers=np.array([built.soles[s].center for s in sides], dtype=float).reshape(-1, 3),
        sole_half=np.array([built.soles[s].half_extents for s in sides],
                           dtype=float).reshape(-1, 2),
        sole_normals=np.array([built.soles[s].normal for s in sides], dtype=float).reshape(-1, 3),
        shape_frames=np.array([s.frame for s in shapes], dtype=str),
        shape_kinds=np.array([s.kind for s in shapes], dtype=str),
        shape_dims=dims, shape_ndims=np.array([len(s.dims) for s in shapes], dtype=np.int64),
        shape_poses=np.array([s.placement for s in shapes], dtype=float).reshape(-1, 4, 4),
        mesh_paths=np.array(meshes, dtype=str), mesh_sizes=sizes, mesh_mtimes=mtimes)


def read_robot(key: str, built: BuiltModel) -> CachedRobot | None:
    """The entry stored under ``key`` for the (geometry-less) built model, or None when there
    is none, it does not read, it was made for other joints, or a mesh file it was derived
    from changed."""
    data = read_cached(MODELS_KIND, key)
    if data is None:
        return None
    path = cache_file(MODELS_KIND, key)
    try:
        if int(data["version"]) != ROBOT_CACHE_VERSION:
            return None
        model = built.model
        if [str(n) for n in data["joint_names"]] != list(model.names)[2:] \
                or data["q_nominal"].shape != (model.nq,):
            log.warning("robot cache %s: made for another model: building again", path)
            return None
        sizes, mtimes = _file_stats(str(p) for p in data["mesh_paths"])
        if not (np.array_equal(sizes, data["mesh_sizes"])
                and np.array_equal(mtimes, data["mesh_mtimes"])):
            log.info("robot cache %s: a mesh file changed: building again", path)
            return None
        soles = {str(side): SoleRectangle(frame=str(f), center=c.copy(), half_extents=h.copy(),
                                          normal=n.copy())
                 for side, f, c, h, n in zip(data["sole_sides"], data["sole_frames"],
                                             data["sole_centers"], data["sole_half"],
                                             data["sole_normals"], strict=True)}
        shapes = [CollisionShape(str(f), str(k), tuple(float(x) for x in d[:int(n)]), p.copy())
                  for f, k, d, n, p in zip(data["shape_frames"], data["shape_kinds"],
                                           data["shape_dims"], data["shape_ndims"],
                                           data["shape_poses"], strict=True)]
        return CachedRobot(q_nominal=data["q_nominal"].astype(float), soles=soles,
                           shapes=shapes)
    except READ_ERRORS as exc:
        log.warning("robot cache %s unreadable (%s): building again", path, exc)
        return None


@dataclass(frozen=True)
class CachedCapsules:
    """The capsule model's inputs as the robot cache holds them.

    Attributes:
        capsules: the fitted capsules.
        ignored: body pairs never checked.
    """

    capsules: list[Capsule]
    ignored: set[tuple[str, str]]


def capsule_model(robot: Robot, key: str):
    """The robot's :class:`imesh.robot.capsules.model.CapsuleModel`: read from the robot cache
    under the capsule key derived from the robot's ``key``, else built
    (:func:`imesh.robot.capsules.robot.build_capsule_model`, which reads the meshes) and stored.

    Args:
        robot: an :class:`imesh.robot.Robot`.
        key: its robot cache key ("" when the robot cache is off: built, not stored).
    """
    from .capsules.model import Capsule, CapsuleModel
    from .capsules.pairs import pairs_file
    from .capsules.robot import build_capsule_model

    if not key or not cache_enabled():
        return build_capsule_model(robot)
    ckey = _capsule_key(key, pairs_file(robot))
    data = read_cached(CAPSULES_KIND, ckey)
    if data is not None:
        try:
            if int(data["version"]) == ROBOT_CACHE_VERSION:
                capsules = [Capsule(name=str(n), body=str(b), frame=str(f), a=a.copy(),
                                    b=e.copy(), radius=float(r))
                            for n, b, f, a, e, r in zip(data["name"], data["body"], data["frame"],
                                                        data["a"], data["b"], data["radius"],
                                                        strict=True)]
                ends = np.cumsum(data["hull_count"])
                parts = np.split(data["hull_points"], ends[:-1]) if len(ends) else []
                hulls = {str(b): p.copy() for b, p in zip(data["hull_body"], parts, strict=True)}
                log.debug("robot %s: capsule model read from the robot cache", robot.name)
                return CapsuleModel(capsules, _pair_set(data["ignored"]), hulls)
        except READ_ERRORS as exc:
            log.warning("capsule cache %s unreadable (%s): building again",
                        cache_file(CAPSULES_KIND, ckey), exc)
    model = build_capsule_model(robot)
    caps = model.capsules
    hulls = model.hulls or {}
    write_cached(CAPSULES_KIND, ckey, version=np.array(ROBOT_CACHE_VERSION),
                 name=np.array([c.name for c in caps], dtype=str),
                 body=np.array([c.body for c in caps], dtype=str),
                 frame=np.array([c.frame for c in caps], dtype=str),
                 a=np.array([c.a for c in caps], dtype=float).reshape(-1, 3),
                 b=np.array([c.b for c in caps], dtype=float).reshape(-1, 3),
                 radius=np.array([c.radius for c in caps], dtype=float),
                 ignored=_pairs(model.ignored),
                 hull_body=np.array(list(hulls), dtype=str),
                 hull_count=np.array([len(v) for v in hulls.values()], dtype=np.int64),
                 hull_points=np.concatenate([np.zeros((0, 3)), *hulls.values()]))
    return model
