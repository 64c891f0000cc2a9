"""The top-level Python API: ``imesh.retarget``, ``imesh.evaluate``, ``imesh.load_robot``,
``imesh.load_robot_motion`` and ``imesh.export_motion`` (``imesh.load_motion`` reads human clips,
:func:`imesh.io.load_motion`).

Each function takes paths or objects and robot names or :class:`imesh.robot.Robot` objects, so a
script needs no other import::

    import imesh

    result = imesh.retarget("walk.bvh", "g1", output="walk_g1.npz")
    report = imesh.evaluate("walk_g1.npz")

``import imesh`` loads this module (and with it scipy, pinocchio and the solvers) when one of
these names is first used (:mod:`imesh`'s lazy exports).
"""

from __future__ import annotations

import dataclasses
import logging
import os
from importlib import resources
from pathlib import Path
from typing import Any

from .core.motion import MarkerMotion
from .core.robot_motion import RobotMotion
from .errors import MotionFileError
from .evaluate.motion_files import load_motion_file
from .evaluate.scoreboard import evaluate_motion
from .evaluate.verify import verify_motion
from .io import load_motion
from .io.formats import is_export, read_export, robot_named_in, write_export
from .io.gmr import is_gmr
from .io.robot_motion import _match_joints, save_robot_motion
from .pipeline.retarget import RetargetConfig, RetargetResult
from .pipeline.retarget import retarget as _retarget
from .robot import Robot
from .robot import load_robot as _load_robot

log = logging.getLogger(__name__)

PathLike = str | os.PathLike


def demo_clip() -> Path:
    """The shipped demo clip: a 2.9 s CMU walk (BVH, 120 fps; imesh/data/demo).

    Examples:
        >>> import imesh
        >>> imesh.demo_clip().name
        'cmu_02_01_walk.bvh'
    """
    return Path(str(resources.files("imesh").joinpath("data", "demo", "cmu_02_01_walk.bvh")))


def load_robot(name: str | PathLike | None = None, urdf: PathLike | None = None) -> Robot:
    """Load a robot: a name of ``imesh robots`` (``"jvrc1"``, ``"g1"``, ``"hrp4c"``), the path
    of a ``robot.toml``, or any humanoid URDF alone (its configuration generated:
    docs/byo-robot.md).

    Args:
        name: robot name or ``robot.toml`` path; None: generated from ``urdf`` when given, else
            ``"jvrc1"``.
        urdf: the model file of robots whose model the user provides (HRP-4C), or of a robot
            without a configuration.

    Returns:
        An :class:`imesh.robot.Robot` (reduced pinocchio model, joint names and limits).

    Raises:
        OptionError: unknown robot name (the message lists the known robots).

    Examples:
        >>> import imesh
        >>> robot = imesh.load_robot("jvrc1")
        >>> robot.name, len(robot.joint_names)
        ('jvrc1', 32)
    """
    return _load_robot(None if name is None else str(name),
                       urdf=None if urdf is None else str(urdf))


def _robot(robot: Robot | str | PathLike, urdf: PathLike | None = None) -> Robot:
    if isinstance(robot, str | os.PathLike):
        return load_robot(robot, urdf=urdf)
    return robot


def _human(clip: MarkerMotion | PathLike) -> MarkerMotion:
    if isinstance(clip, str | os.PathLike):
        return load_motion(clip)
    return clip


def retarget(clip: MarkerMotion | PathLike, robot: Robot | str = "jvrc1", *,
             output: PathLike | None = None, fps: float | None = None,
             balance: str = "wholebody", config: RetargetConfig | None = None,
             verify: bool = True, urdf: PathLike | None = None) -> RetargetResult:
    """Retarget a human clip to a robot (the pipeline of ``imesh retarget``).

    Args:
        clip: a motion file (BVH, ASF/AMC, C3D, TRC) or a loaded :class:`imesh.MarkerMotion`.
        robot: robot name (``"jvrc1"``, ``"g1"``, ``"hrp4c"``) or a loaded Robot.
        output: when given, write the robot motion here: ``.npz``/``.csv`` in imesh's own
            layout (with the adapted markers in the .npz), atomically. Use
            :func:`export_motion` for the CSV (LAFAN1 layout) and MuJoCo exports.
        fps: working and output frame rate [1/s] (default :class:`RetargetConfig`'s 30).
        balance: ``"wholebody"`` (default), ``"nishiwaki"`` or ``"none"``.
        config: a full :class:`imesh.pipeline.retarget.RetargetConfig` (``fps`` and ``balance`` then
            replace its fields when given explicitly).
        verify: before writing ``output``, compute the metrics and raise
            :class:`~imesh.errors.VerificationError` when a gate fails (nothing is written),
            as the command line does.
        urdf: model file of robots whose model the user provides (HRP-4C).

    Returns:
        :class:`imesh.pipeline.retarget.RetargetResult`; ``result.motion`` is the
        :class:`~imesh.core.robot_motion.RobotMotion` (T frames, ``q`` of shape (T, 7 + n)) and
        ``result.meta``-free ``result.report()`` a JSON-able summary. When ``verify`` and
        ``output`` are given, ``result.report()`` is complemented by ``result.metrics``.

    Raises:
        ImeshError: unreadable clip, unknown robot, flight phases, solver failure,
            verification failure.

    Examples:
        >>> import imesh
        >>> result = imesh.retarget(imesh.demo_clip(), "jvrc1")  # about a minute
        >>> motion = result.motion
        >>> motion.robot, motion.fps, motion.q.shape[1] == 7 + len(motion.joint_names)
        ('jvrc1', 30.0, True)
    """
    robot = _robot(robot, urdf)
    human = _human(clip)
    config = config or RetargetConfig()
    changes: dict[str, Any] = ({"balance": balance} if balance != "wholebody"
                               or config.balance == "wholebody" else {})
    if fps is not None:
        changes["fps"] = float(fps)
    config = dataclasses.replace(config, **changes)
    result = _retarget(human, robot, config=config)
    if output is not None:
        if verify:
            verify_motion(robot, result.motion, adapted=result.adapted, seconds=result.seconds,
                          name=str(clip) if isinstance(clip, str | os.PathLike) else "clip",
                          balanced=config.balance != "none", source=human)
        save_robot_motion(output, result.motion, markers=result.adapted)
    return result


def load_robot_motion(path: PathLike, robot: Robot | str | None = None) -> RobotMotion:
    """Read a robot motion: an imesh ``.npz``/``.csv`` or a file of :func:`export_motion`
    (format told by the content; the headerless LAFAN1-layout CSV needs ``robot``).

    Args:
        path: the file.
        robot: the robot the motion is for (name or Robot); checks the file and, for the
            headerless CSV, supplies the joint names.

    Returns:
        The :class:`~imesh.core.robot_motion.RobotMotion`.

    Raises:
        MotionFileError: unreadable or malformed file (names the file and what is wrong).

    Examples:
        >>> import imesh, tempfile, os
        >>> motion = imesh.RobotMotion.from_parts(
        ...     [[0.0, 0.0, 0.8]] * 2, [[0.0, 0.0, 0.0, 1.0]] * 2, [[0.1], [0.2]], fps=30.0,
        ...     robot="demo", joint_names=["knee"])
        >>> path = os.path.join(tempfile.mkdtemp(), "m.npz")
        >>> imesh.export_motion(motion, path)
        >>> imesh.load_robot_motion(path).joint_positions[:, 0].tolist()
        [0.1, 0.2]
    """
    return read_export(path, robot)


def export_motion(motion: RobotMotion | PathLike, output: PathLike, fmt: str | None = None, *,
                  fps: float | None = None, robot: Robot | str | None = None,
                  mjcf: PathLike | None = None) -> None:
    """Write a robot motion in one of the export formats (:mod:`imesh.io.formats`), atomically.

    Args:
        motion: a RobotMotion or the path of a robot-motion file.
        output: the file to write.
        fmt: ``"npz"`` (imesh's own layout), ``"csv"`` (one headerless row per frame: base
            position [m], base quaternion x, y, z, w, joints [rad] in the robot's order, the
            retargeted-LAFAN1 layout), ``"mujoco"`` (``.npz`` with ``qpos`` (T, nq) in the
            MJCF's order, base quaternion w, x, y, z) or ``"gmr"`` (GMR's ``.pkl``: ``fps``,
            ``root_pos``, ``root_rot`` x, y, z, w, ``dof_pos`` in GMR's joint order; G1);
            default from the suffix (.npz, .csv, .pkl).
        fps: resample to this frame rate first [1/s] (linear, slerp for the base).
        robot: the robot, to read a headerless CSV given as ``motion``.
        mjcf: the MuJoCo model for ``"mujoco"``: None (default) compiles the robot's URDF
            offline, ``"menagerie"`` its mujoco-menagerie model, or an MJCF file.

    Raises:
        OptionError: unknown format (lists the valid ones), a robot without an MJCF.
    """
    if isinstance(motion, str | os.PathLike):
        motion = load_robot_motion(motion, robot)
    write_export(motion, Path(output), fmt, fps=fps, mjcf=mjcf,
                 robot=robot if isinstance(robot, Robot) else None)


def evaluate(motion: RobotMotion | PathLike, robot: Robot | str | None = None, *,
             source: MarkerMotion | PathLike | None = None,
             adapted: MarkerMotion | PathLike | None = None, physics: bool = False,
             fps: float | None = None, resample: bool = False,
             urdf: PathLike | None = None) -> dict:
    """Every quality metric of a robot motion (the numbers of ``imesh evaluate``), also for
    the output of another retargeting tool (docs/checking.md).

    Args:
        motion: a RobotMotion, or a motion file (imesh .npz/.csv, plain arrays .npz, GMR's
            .pkl, or a file of :func:`export_motion`).
        robot: the robot (name or Robot); default the robot the file names.
        source: the human clip, for ``close_pair_error`` and ``marker_rms_mm``.
        adapted: the adapted markers the robot fitted (an imesh .npz stores them itself).
        physics: run the DART dynamics check (slower); a motion file's props (the
            ``.scene.npz`` beside it) stand in its world.
        fps: frame rate of files that store none [1/s].
        resample: compare ``source``/``adapted`` markers of another frame rate or frame count
            (resampled to the motion's fps, first common frames; e.g. a 120 fps clip against a
            30 fps motion); by default such a mismatch raises SourceMismatchError.
        urdf: model file of robots whose model the user provides (HRP-4C).

    Returns:
        dict: metric name -> ``{"value", "unit", ...}`` (``imesh.evaluate.METRIC_NAMES``).

    Examples:
        >>> import imesh
        >>> robot = imesh.load_robot("jvrc1")
        >>> q = robot.q_nominal
        >>> motion = imesh.RobotMotion(q=[q] * 40, fps=30.0, robot="jvrc1",
        ...                            joint_names=robot.joint_names)
        >>> report = imesh.evaluate(motion, robot)
        >>> report["limit_violation_frames"]["value"]
        0
    """
    scene = None
    if isinstance(motion, str | os.PathLike):
        path = Path(motion)
        if robot is None:
            robot = _robot_named_in(path)
        robot = _robot(robot, urdf)
        motion = _load_for_evaluate(path, robot, fps)
        if physics:  # the props written beside the motion stand in the DART world too
            from .scene import find_scene  # noqa: PLC0415

            scene = find_scene(path)
    else:
        robot = _robot(robot if robot is not None else motion.robot, urdf)
    return evaluate_motion(robot, motion, source=source, adapted=adapted, physics=physics,
                           resample=resample, scene=scene)


def _robot_named_in(path: Path) -> str:
    """The robot a motion file names (``robot=`` of :func:`evaluate` left out)."""
    if (path.suffix.lower() in (".npz", ".csv") or is_gmr(path)) and path.is_file():
        name = robot_named_in(path)
        if name:
            return name
    raise MotionFileError(str(path), "the file does not name its robot: pass robot=")


def _load_for_evaluate(path: Path, robot: Robot, fps: float | None) -> RobotMotion:
    """A motion file to evaluate: an export (:mod:`imesh.io.formats`) or what
    :func:`imesh.evaluate.motion_files.load_motion_file` reads."""
    if is_export(path):
        motion = read_export(path, robot)
        q, names = _match_joints(path, motion.joint_positions, motion.joint_names,
                                 tuple(robot.joint_names))
        return type(motion).from_parts(motion.base_position, motion.base_quat_xyzw, q,
                                       fps=fps or motion.fps, robot=robot.name,
                                       joint_names=names)
    return load_motion_file(path, robot, fps=fps)
