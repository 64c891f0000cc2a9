"""The human-to-robot map of the retarget, ``p -> c + s (p - c)``, for the props.

:func:`imesh.human.arrange.arrange_for_robot` scales the prepared human markers by ``s`` about
``c``, the floor point under their centroid at the first frame. It returns ``s`` (the
arrangement's ``scale``) but not ``c``; :func:`morph_transform` recovers ``c`` from the markers
before and after the scaling (every kept marker but the pelvis, which is turned afterwards, gives
``c = (scaled - s * human) / (1 - s)``; they must agree), so the props follow exactly the map the
human went through, and a change to the arrangement shows up here as an error instead of boxes
in the wrong place.
"""

from __future__ import annotations

import logging

import numpy as np

from ..errors import ImeshError
from ..human.arrange import Arrangement, arrange_for_robot
from ..human.filtering import lowpass
from ..morph.adapt import prepare_markers

log = logging.getLogger(__name__)

__all__ = ["morph_transform", "arrangement_centre"]

#: Largest disagreement [m] between the centres the markers give.
CENTRE_TOLERANCE_M = 1e-6


def arrangement_centre(human, arrangement: Arrangement) -> np.ndarray:
    """(3,) the fixed point ``c`` of the arrangement's scaling (z = 0) [m].

    Args:
        human: the prepared (standard, resampled, low-passed) markers that were arranged.
        arrangement: their arrangement.

    Raises:
        ImeshError: the markers do not follow one map ``c + s (p - c)``.
    """
    s = float(arrangement.scale)
    arranged = arrangement.motion
    names = [n for n in arranged.names if n in human.names and n != "pelvis"]
    if not names:
        raise ImeshError("scene scaling: no arranged marker to recover the scaling's centre")
    u = human.positions_m[0, human.indices(names)]
    a = arranged.positions_m[0, arranged.indices(names)]
    if abs(1.0 - s) < 1e-9:
        return np.r_[u[:, :2].mean(axis=0), 0.0]
    c = (a - s * u) / (1.0 - s)
    spread = float(np.abs(c[:, :2] - c[:, :2].mean(axis=0)).max())
    if spread > CENTRE_TOLERANCE_M or np.abs(c[:, 2]).max() > CENTRE_TOLERANCE_M:
        raise ImeshError(f"scene scaling: the arranged markers do not follow one scaling about a "
                         f"floor point (centres differ by {spread:.3g} m): the arrangement "
                         "changed; imesh.scene.morph_frame must follow it")
    return np.r_[c[:, :2].mean(axis=0), 0.0]


def morph_transform(motion, robot, *, fps: float | None = 30.0,
                    lowpass_hz: float | None = 8.0) -> tuple[float, np.ndarray]:
    """``(s, c)`` of the human-to-robot map the retarget applies to ``motion``: the markers
    prepared as :func:`imesh.pipeline.retarget.retarget` prepares them (standard markers,
    resampled to ``fps``, low-passed at ``lowpass_hz``; its RetargetConfig's defaults), then
    arranged for ``robot``.

    Returns:
        (scale, (3,) centre [m]).
    """
    human = prepare_markers(motion)
    if fps is not None and abs(human.fps - fps) > 1e-9:
        human = human.resample(fps)
    if lowpass_hz is not None:
        human = lowpass(human, lowpass_hz)
    arrangement = arrange_for_robot(human, robot)
    centre = arrangement_centre(human, arrangement)
    log.info("scene: human-to-robot scale %.4f about (%.3f, %.3f) m", arrangement.scale,
             centre[0], centre[1])
    return float(arrangement.scale), centre


def scene_for_clip(paths, motion, robot, *, scale: float | None = None,
                   fps: float | None = 30.0, lowpass_hz: float | None = 8.0):
    """The robot-world scene of scene files given with a loaded clip: read
    (:func:`imesh.scene.load_scene`), converted as the clip was (:func:`imesh.scene.human_scene`)
    and mapped like the human (:func:`imesh.scene.robot_scene`) with the retarget's scale, or
    ``scale`` about the same fixed point.

    Args:
        paths: the scene files (mesh, URDF).
        motion: the clip as loaded (its ``meta`` holds the unit, up axis and floor shift).
        robot: the robot.
        scale: an explicit scale (``--scene-scale``), or None for the human-to-robot one.
        fps, lowpass_hz: the retarget's working rate and low-pass (RetargetConfig).
    """
    from .scene import human_scene, load_scene, robot_scene

    human = human_scene(load_scene(paths), motion.meta)
    s, centre = morph_transform(motion, robot, fps=fps, lowpass_hz=lowpass_hz)
    if scale is not None:
        log.info("scene: scale %.4f given (--scene-scale) instead of the human's %.4f", scale, s)
        s = float(scale)
    return robot_scene(human, s, centre)
