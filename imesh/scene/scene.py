"""A scene: the static props of a clip, in the human's world and in the robot's.

**Frames.** Scene files are given in the frame and units of the clip file they go with (the
shared climbing boxes: the joints' frame, metres, Z up). The reader's conversion of the clip to
metres, Z up, floor at z = 0 (:func:`imesh.io.finalize`: unit, up-axis rotation, floor shift,
recorded in ``motion.meta``) is applied to the props too: :func:`human_scene`.

**Scale.** The retarget scales the human before the morph
(:func:`imesh.human.arrange.arrange_for_robot`): by ``s`` = the robot's leg length (thigh +
shank key-point distances in its nominal pose) over the human's (median over frames), about the
floor point ``c`` under the centroid of the arranged markers at the first frame. The props get
the same map, ``p -> c + s (p - c)`` (:func:`robot_scene`), so a box top under a planted foot stays
under it; ``--scene-scale`` replaces ``s`` (about the same ``c``). :func:`morph_transform`
recovers ``(s, c)`` from the pipeline's stages.

**Files.** The scaled scene is written beside the robot motion, ``OUT.scene.npz`` for
``OUT.npz`` (:func:`scene_path_for`, :func:`save_scene`, atomically), holding both the robot-world
and the human-world vertices, the scale and the centre, so ``imesh evaluate OUT.npz`` finds it.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..io.units import rotation_to_z_up
from .props import Prop, SceneFileError, load_props

log = logging.getLogger(__name__)

__all__ = ["Scene", "load_scene", "human_scene", "robot_scene", "scene_path_for",
           "save_scene", "load_saved_scene", "SCENE_FORMAT", "SCENE_SUFFIX"]

SCENE_FORMAT = "imesh-scene-1"
#: Suffix of the scene file beside a robot motion (``walk.npz`` -> ``walk.scene.npz``).
SCENE_SUFFIX = ".scene.npz"


@dataclass(frozen=True, eq=False)
class Scene:
    """Static props in one world frame.

    Attributes:
        props: the props (vertices in this scene's frame, metres).
        frame: "file" (as read), "human" (the clip's metres, Z up, floor z = 0) or "robot"
            (scaled by the human-to-robot map).
        scale: the human-to-robot scale applied (1 unless ``frame == "robot"``).
        centre_m: (3,) the fixed point of that scale [m].
        human_props: for a robot scene, the same props in the human world (else empty).
        sources: the scene files.
    """

    props: tuple[Prop, ...]
    frame: str = "file"
    scale: float = 1.0
    centre_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    human_props: tuple[Prop, ...] = ()
    sources: tuple[str, ...] = ()

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.props)

    def tops_m(self) -> np.ndarray:
        """(P,) highest z of each prop [m]."""
        return np.array([p.top_m for p in self.props])


def load_scene(paths: Sequence[str | os.PathLike]) -> Scene:
    """Props of every scene file (``--scene``, repeatable), in the files' frame.

    Raises:
        SceneFileError: a file cannot be read; two props of the same name.
    """
    props: list[Prop] = []
    for path in paths:
        props += load_props(path)
    names = [p.name for p in props]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:  # the same box given twice would count its contacts twice
        raise SceneFileError(", ".join(map(str, paths)), f"props named {twice} given twice",
                             "each prop once")
    return Scene(tuple(props), "file", sources=tuple(str(p) for p in paths))


def human_scene(scene: Scene, motion_meta: dict) -> Scene:
    """The scene in the human world of a loaded clip: the clip's unit, up-axis rotation and
    floor levelling and shift (``motion.meta``: ``unit_scale_m``, ``up_axis``,
    ``floor_level_rotation`` and ``floor_level_pivot_m`` when levelled, ``floor_offset_m``)
    applied to the props as :func:`imesh.io.finalize` applied them to the clip:
    ``p -> L (R u p - c) + c - floor e_z``."""
    if scene.frame != "file":
        return scene
    unit = float(motion_meta.get("unit_scale_m", 1.0))
    rot = rotation_to_z_up(str(motion_meta.get("up_axis", "+Z")))
    floor = float(motion_meta.get("floor_offset_m", 0.0))
    level = np.asarray(motion_meta.get("floor_level_rotation", np.eye(3)), dtype=float)
    pivot = np.asarray(motion_meta.get("floor_level_pivot_m", np.zeros(3)), dtype=float)
    offset = pivot - level @ pivot - np.array([0.0, 0.0, floor])
    props = tuple(p.transformed(level @ rot, unit, offset) for p in scene.props)
    if unit != 1.0 or floor != 0.0 or not np.allclose(level @ rot, np.eye(3)):
        log.info("scene: props converted as the clip was (x %g, up %s, floor %+.3f m)", unit,
                 motion_meta.get("up_axis"), -floor)
    return Scene(props, "human", sources=scene.sources)


def robot_scene(scene: Scene, scale: float, centre_m: np.ndarray) -> Scene:
    """The human-world scene mapped like the human: ``p -> c + scale (p - c)``."""
    if scene.frame != "human":
        raise SceneFileError(", ".join(scene.sources), f"a scene in the {scene.frame!r} frame "
                             "cannot be scaled to the robot", "a scene in the human world")
    if not (np.isfinite(scale) and scale > 0):
        raise SceneFileError(", ".join(scene.sources), f"scale {scale!r}", "a number > 0")
    c = np.asarray(centre_m, dtype=float).reshape(3)
    props = tuple(p.transformed(np.eye(3), scale, c * (1.0 - scale)) for p in scene.props)
    log.info("scene: %d props scaled by %.4f about (%.3f, %.3f, %.3f) m: tops %s m", len(props),
             scale, *c, ", ".join(f"{p.top_m:.3f}" for p in props))
    return Scene(props, "robot", float(scale), c, scene.props, scene.sources)


def scene_path_for(motion_path: str | os.PathLike) -> Path:
    """The scene file beside a robot motion: ``OUT.scene.npz`` for ``OUT.npz`` / ``OUT.csv``."""
    p = Path(motion_path)
    return p.with_name(p.stem + SCENE_SUFFIX)


def _pack(props: Sequence[Prop]) -> dict[str, np.ndarray]:
    nv = np.cumsum([0] + [len(p.vertices_m) for p in props])
    nf = np.cumsum([0] + [len(p.faces) for p in props])
    return {"vertex_offsets": nv.astype(np.int64), "face_offsets": nf.astype(np.int64),
            "vertices_m": np.concatenate([p.vertices_m for p in props]).astype(np.float64),
            "faces": np.concatenate([p.faces for p in props]).astype(np.int64)}


def _unpack(names: Sequence[str], vertices: np.ndarray, faces: np.ndarray, nv: np.ndarray,
            nf: np.ndarray, source: str) -> tuple[Prop, ...]:
    return tuple(Prop(str(n), vertices[nv[k]:nv[k + 1]].copy(), faces[nf[k]:nf[k + 1]].copy(),
                      source) for k, n in enumerate(names))


def save_scene(path: str | os.PathLike, scene: Scene, atomic=None) -> None:
    """Write a robot-world scene (``.scene.npz``): props' names, robot-world and human-world
    vertices, faces, scale, centre, source files.

    Args:
        path: the file.
        scene: a scene from :func:`robot_scene`.
        atomic: a context manager factory yielding a temporary path renamed onto ``path`` on
            success (:func:`imesh.io.atomic.atomic_path`); None writes directly.
    """
    if scene.frame != "robot":
        raise SceneFileError(str(path), f"only a robot-world scene is written, not {scene.frame!r}")
    robot = _pack(scene.props)
    human = _pack(scene.human_props)
    arrays: dict[str, Any] = {"format": np.str_(SCENE_FORMAT), "names": np.array(scene.names),
              "scale": np.float64(scene.scale), "centre_m": scene.centre_m.astype(np.float64),
              "sources": np.array(scene.sources or ("",)),
              **robot, "human_vertices_m": human["vertices_m"]}
    if atomic is None:
        np.savez_compressed(path, **arrays)
        return
    with atomic(path) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, **arrays)
    log.info("wrote %s: %d props at scale %.4f", path, len(scene.props), scene.scale)


def load_saved_scene(path: str | os.PathLike) -> Scene:
    """A scene written by :func:`save_scene`.

    Raises:
        SceneFileError: not such a file.
    """
    p = Path(path)
    if not p.is_file():
        raise SceneFileError(p, "no such file", f"a {SCENE_SUFFIX} file written by imesh "
                             "retarget --scene")
    try:
        with np.load(p, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError) as exc:
        raise SceneFileError(p, f"not a readable .npz ({exc})", "a scene file") from None
    if str(data.get("format", "")) != SCENE_FORMAT:
        raise SceneFileError(p, f"format {str(data.get('format', 'none'))!r}",
                             f"{SCENE_FORMAT} (written by imesh retarget --scene)")
    try:
        names = [str(n) for n in data["names"]]
        nv, nf = data["vertex_offsets"], data["face_offsets"]
        props = _unpack(names, data["vertices_m"], data["faces"], nv, nf, str(p))
        human = _unpack(names, data["human_vertices_m"], data["faces"], nv, nf, str(p))
        return Scene(props, "robot", float(data["scale"]), np.asarray(data["centre_m"], float),
                     human, tuple(str(s) for s in data["sources"]))
    except (KeyError, IndexError, ValueError) as exc:
        raise SceneFileError(p, f"missing or mistyped member ({exc!r})", "a scene file"
                             ) from None


def find_scene(motion_path: str | os.PathLike) -> Scene | None:
    """The scene written beside a robot motion, or None (logged when found)."""
    path = scene_path_for(motion_path)
    if not path.is_file():
        return None
    log.info("%s: scene from %s", motion_path, path)
    return load_saved_scene(path)


def scene_from_files(paths: Sequence[str | os.PathLike]) -> Scene:
    """Scene files named on the command line: a written ``.scene.npz`` is read as it is
    (robot world), mesh/URDF files are read in the file frame."""
    if len(paths) == 1 and str(paths[0]).endswith(SCENE_SUFFIX):
        return load_saved_scene(paths[0])
    return load_scene(paths)
