"""Export formats of robot motions (``imesh export``, ``imesh retarget/batch --format``).

Formats (:data:`FORMATS`):

``npz``
    imesh's own file (:mod:`imesh.core.robot_motion`): keys ``fps``, ``robot``, ``joint_names``
    (n,), ``base_position`` (T, 3) [m], ``base_quat_xyzw`` (T, 4) (x, y, z, w), ``joint_positions``
    (T, n) [rad].
``csv``
    The layout of the widely used retargeted-LAFAN1 humanoid datasets that motion-tracking
    training code reads: no header, one row per frame, comma separated, ``%.17g`` numbers:
    base position x, y, z [m], base quaternion x, y, z, w, then one value per joint [rad] in the
    robot's joint order (``imesh.load_robot(name).joint_names``, the URDF's depth-first
    order; docs/exports.md lists the G1's). The file stores neither frame rate nor joint
    names: readers need the robot (and the frame rate, 30 fps in those datasets; ``--fps``).
``mujoco``
    MuJoCo ``qpos`` in an ``.npz``: ``qpos`` (T, nq) in the order of the robot's MJCF (free
    joint first: base position [m], base quaternion **w, x, y, z**; then each hinge/slide joint
    at its ``qposadr``), ``fps``, ``robot``, ``qpos_joint_names`` (joint of each column after
    the 7 base columns), ``filled_joints`` (MJCF joints the robot motion does not have, left at
    the model's ``qpos0``: e.g. hand joints), ``mjcf`` (where the model came from).
    ``data.qpos[:] = f["qpos"][t]`` then poses the MuJoCo model. By default the model is
    compiled by MuJoCo from the robot's own URDF (:func:`mujoco_from_urdf`: offline, any
    robot; its MJCF is stored in the file as ``mjcf_xml``, so
    ``mujoco.MjModel.from_xml_string(str(f["mjcf_xml"]))`` is the model the columns belong to);
    ``--mjcf menagerie`` takes the robot's model in the ``mujoco-menagerie`` package (G1:
    ``unitree_g1``, :data:`MENAGERIE`; the package downloads its assets on first use), and
    ``--mjcf FILE`` any MJCF whose joint names are the robot's.
``gmr``
    GMR's motion pickle (``.pkl``, :mod:`imesh.io.gmr`): ``fps``, ``root_pos`` (T, 3) [m],
    ``root_rot`` (T, 4) **x, y, z, w**, ``dof_pos`` (T, n) [rad] in the joint order of GMR's
    model of the robot (G1: GMR's ``unitree_g1``), ``local_body_pos``/``link_body_list`` None;
    also ``robot``, ``joint_names``, ``provenance``, which GMR's loaders ignore.

``--fps`` resamples first (:func:`resample_robot_motion`): linear in the base position and the
joints, spherical-linear (slerp) in the base quaternion.
"""

from __future__ import annotations

import logging
import os
import re
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from ..core.lazy import optional
from ..core.robot_motion import RobotMotion
from ..errors import ImeshError, MotionFileError, OptionError
from ..robot import load_robot
from .atomic import atomic_path
from .gmr import gmr_robot_name, is_gmr, read_gmr, write_gmr
from .npz import load_npz
from .robot_motion import load_robot_motion, read_provenance, save_robot_motion

log = logging.getLogger(__name__)

#: Export formats and the file suffix each writes.
FORMATS: dict[str, str] = {"npz": ".npz", "csv": ".csv", "mujoco": ".npz", "gmr": ".pkl"}
#: Frame rate assumed for a headerless CSV when none is given [1/s] (the LAFAN1 datasets').
CSV_DEFAULT_FPS = 30.0
#: Robots with a MuJoCo model in the ``mujoco-menagerie`` package (``--mjcf menagerie``): robot
#: -> (menagerie name, entry point).
MENAGERIE: dict[str, tuple[str, str]] = {"g1": ("unitree_g1", "g1")}
#: Marker of a MuJoCo export (.npz key ``format``).
MUJOCO_FORMAT = "imesh-mujoco-qpos-1"


class ExportError(ImeshError):
    """An export that cannot be written (no MuJoCo model, joints the model lacks...)."""


def format_for(path: str | os.PathLike, fmt: str | None) -> str:
    """The export format: ``fmt`` checked, or told by the suffix (.npz -> npz, .csv -> csv).

    Raises:
        OptionError: unknown format, or a suffix that does not fit it (lists the valid ones).
    """
    suffix = Path(path).suffix.lower()
    if fmt is None:
        by_suffix = {".npz": "npz", ".csv": "csv", ".pkl": "gmr"}
        if suffix not in by_suffix:
            raise OptionError(f"output extension of {path}", suffix or Path(path).name,
                              list(by_suffix))
        return by_suffix[suffix]
    if fmt not in FORMATS:
        raise OptionError("--format", fmt, list(FORMATS))
    if suffix != FORMATS[fmt]:
        raise OptionError(f"extension of {path} for --format {fmt}", suffix or Path(path).name,
                          [FORMATS[fmt]])
    return fmt


# ------------------------------------------------------------------------------- resampling
def resample_robot_motion(motion: RobotMotion, fps: float) -> RobotMotion:
    """The motion at another frame rate, over the same time span.

    Frame k is at time k / fps [s], k = 0 .. floor(duration * fps); base position and joints
    are interpolated linearly, the base quaternion by slerp (sign kept in the hemisphere of the
    preceding source frame). Frames at a source frame's time reproduce it exactly (to rounding).

    Args:
        motion: the source motion, T frames.
        fps: the new frame rate [1/s], > 0.

    Returns:
        A RobotMotion of ``floor((T - 1) * fps / motion.fps) + 1`` frames.
    """
    if not (np.isfinite(fps) and fps > 0):
        raise OptionError("--fps", fps, "a frame rate > 0")
    if abs(fps - motion.fps) <= 1e-12 * motion.fps:
        return motion

    t_old = np.arange(motion.n_frames) / motion.fps
    n_new = int(np.floor((motion.n_frames - 1) * fps / motion.fps + 1e-9)) + 1
    t_new = np.minimum(np.arange(n_new) / fps, t_old[-1])
    lin = np.column_stack([motion.base_position, motion.joint_positions])
    out = np.empty((n_new, lin.shape[1]))
    for c in range(lin.shape[1]):
        out[:, c] = np.interp(t_new, t_old, lin[:, c])
    if motion.n_frames == 1:
        quat = np.repeat(motion.base_quat_xyzw, n_new, axis=0)
    else:
        quat = Slerp(t_old, Rotation.from_quat(motion.base_quat_xyzw))(t_new).as_quat()
        left = np.clip(np.searchsorted(t_old, t_new, side="right") - 1, 0, motion.n_frames - 1)
        flip = np.einsum("ij,ij->i", quat, motion.base_quat_xyzw[left]) < 0
        quat[flip] *= -1.0
    return RobotMotion.from_parts(out[:, :3], quat, out[:, 3:], fps=fps, robot=motion.robot,
                                  joint_names=motion.joint_names)


# --------------------------------------------------------------------------------- MuJoCo
#: ``--mjcf`` value that asks for the robot's model in ``mujoco-menagerie``.
MENAGERIE_MJCF = "menagerie"


def mujoco_from_urdf(urdf: str | os.PathLike):
    """A MuJoCo model compiled by MuJoCo from a URDF, with a free joint on the root link.

    Visuals and mesh collision geometry are left out (their files may need the network or
    formats MuJoCo does not read); primitive collision shapes (box, cylinder, sphere) and every
    link's inertia are kept; inertia matrices that are not positive definite (rounded URDF
    values) are made so by clipping their eigenvalues at 1e-9 kg m^2.

    Returns:
        (``mujoco.MjModel``, its MJCF text).

    Raises:
        ExportError: mujoco not installed, or a URDF MuJoCo cannot compile (its message).
    """
    import tempfile
    import xml.etree.ElementTree as ET

    mujoco = optional("mujoco", "pip install imesh-retarget[mujoco]", "the MuJoCo export")
    try:
        root = ET.parse(urdf).getroot()
    except (OSError, ET.ParseError) as exc:
        raise ExportError(f"{urdf}: cannot read the URDF ({exc})") from None
    for link in root.iter("link"):
        for el in link.findall("visual"):
            link.remove(el)
        for el in link.findall("collision"):
            geometry = el.find("geometry")
            if geometry is None or geometry.find("mesh") is not None:
                link.remove(el)
    for el in root.findall("transmission") + root.findall("gazebo"):
        root.remove(el)
    keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    at = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
    for inertia in root.iter("inertia"):
        m = np.zeros((3, 3))
        for k, (a, b) in zip(keys, at, strict=True):
            m[a, b] = m[b, a] = float(inertia.get(k, 0.0))
        w, v = np.linalg.eigh(m)
        if w.min() <= 1e-12:
            m = (v * np.maximum(w, 1e-9)) @ v.T
            for k, (a, b) in zip(keys, at, strict=True):
                inertia.set(k, repr(float(m[a, b])))
    ET.SubElement(ET.SubElement(root, "mujoco"), "compiler", discardvisual="true",
                  fusestatic="false", balanceinertia="true", boundmass="1e-6",
                  boundinertia="1e-9")
    try:
        fixed = mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
        with tempfile.TemporaryDirectory() as folder:  # MuJoCo writes its MJCF to a file only
            mujoco.mj_saveLastXML(str(Path(folder) / "model.xml"), fixed)
            tree = ET.parse(Path(folder) / "model.xml")
        world = tree.getroot().find("worldbody")
        base = world.find("body") if world is not None else None
        if base is None:
            raise ValueError("the compiled model has no body")
        base.insert(0, ET.Element("freejoint", name="floating_base_joint"))
        xml = ET.tostring(tree.getroot(), encoding="unicode")
        return mujoco.MjModel.from_xml_string(xml), xml
    except (ValueError, AttributeError) as exc:
        raise ExportError(f"{urdf}: MuJoCo cannot compile this URDF ({exc}); pass --mjcf FILE"
                          ) from None


def mujoco_model(robot, mjcf: str | os.PathLike | None = None):
    """The MuJoCo model (``mujoco.MjModel``) of ``robot``, where it came from and its MJCF text.

    Args:
        robot (imesh.robot.Robot | str): the robot (or a robot name, loaded with
            ``load_robot``).
        mjcf: None (default): compiled from the robot's URDF (:func:`mujoco_from_urdf`);
            ``"menagerie"``: the robot's model in ``mujoco-menagerie`` (:data:`MENAGERIE`);
            else an MJCF file.

    Raises:
        ExportError: no ``mujoco`` (or ``mujoco-menagerie`` when asked) installed, a robot
            without a menagerie model (names the robots that have one), a model that cannot be
            loaded.
    """
    mujoco = optional("mujoco", "pip install imesh-retarget[mujoco]", "the MuJoCo export")
    name = robot if isinstance(robot, str) else robot.name
    if mjcf is None:
        robot = load_robot(robot) if isinstance(robot, str) else robot
        model, xml = mujoco_from_urdf(robot.urdf)
        return model, f"compiled by MuJoCo from {robot.urdf}", xml
    if str(mjcf) != MENAGERIE_MJCF:
        try:
            return (mujoco.MjModel.from_xml_path(str(mjcf)), str(mjcf),
                    Path(mjcf).read_text(encoding="utf-8", errors="replace"))
        except (ValueError, OSError) as exc:
            raise ExportError(f"--mjcf {mjcf}: cannot load ({exc})") from None
    if name not in MENAGERIE:
        raise ExportError(f"robot {name!r} has no MuJoCo model in mujoco-menagerie (robots "
                          f"with one: {', '.join(sorted(MENAGERIE))}); leave out --mjcf (the "
                          "model compiled from the robot's URDF) or pass --mjcf FILE")
    menagerie_name, entry = MENAGERIE[name]
    mujoco_menagerie = optional("mujoco_menagerie", "pip install imesh-retarget[mujoco] (or "
                                "leave out --mjcf)", f"the menagerie model of {name}")
    try:
        model = mujoco_menagerie.load(menagerie_name, entry)
    except Exception as exc:  # noqa: BLE001 - download/cache errors of the package
        raise ExportError(f"cannot load the MuJoCo model {menagerie_name}/{entry} of {name} "
                          f"from mujoco-menagerie ({type(exc).__name__}: {exc}); leave out "
                          "--mjcf (the model compiled from the robot's URDF, offline)") from None
    return model, f"mujoco-menagerie {menagerie_name}/{entry}", ""


def mujoco_qpos(motion: RobotMotion, model) -> tuple[np.ndarray, list[str], list[str]]:
    """``(qpos (T, model.nq), qpos_joint_names, filled_joints)`` of ``motion`` for ``model``.

    The model's first joint must be a free joint at qpos address 0 (the base); every other
    joint a hinge or slide joint. Joints of the motion missing from the model raise
    ExportError; model joints the motion lacks keep ``model.qpos0``.
    """
    mujoco = optional("mujoco", "pip install imesh-retarget[mujoco]", "the MuJoCo export")
    free, hinge, slide = (int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_HINGE),
                          int(mujoco.mjtJoint.mjJNT_SLIDE))
    if model.njnt == 0 or int(model.jnt_type[0]) != free or model.jnt_qposadr[0] != 0:
        raise ExportError("the MuJoCo model's first joint must be the free joint of the base")
    qpos = np.tile(np.asarray(model.qpos0, dtype=np.float64), (motion.n_frames, 1))
    qpos[:, 0:3] = motion.base_position
    qpos[:, 3] = motion.base_quat_xyzw[:, 3]  # w, x, y, z
    qpos[:, 4:7] = motion.base_quat_xyzw[:, :3]
    index = {n: i for i, n in enumerate(motion.joint_names)}
    names, filled = [], []
    for j in range(1, model.njnt):
        name = model.joint(j).name
        if int(model.jnt_type[j]) not in (hinge, slide):
            raise ExportError(f"MuJoCo joint {name!r} is neither hinge nor slide")
        names.append(name)
        if name in index:
            qpos[:, model.jnt_qposadr[j]] = motion.joint_positions[:, index.pop(name)]
        else:
            filled.append(name)
    if index:
        raise ExportError(f"joints of {motion.robot} missing from the MuJoCo model: "
                          f"{sorted(index)}; its joints: {names}")
    if filled:
        log.info("MuJoCo export: %d model joints not in the motion keep qpos0: %s",
                 len(filled), filled)
    return qpos, names, filled


# ------------------------------------------------------------------------------- writing
def write_export(motion: RobotMotion, path: str | os.PathLike, fmt: str | None = None, *,
                 fps: float | None = None, mjcf: str | os.PathLike | None = None,
                 robot=None) -> Path:
    """Write ``motion`` to ``path`` in format ``fmt`` (module docstring), atomically.

    Args:
        motion: the robot motion.
        path: output file (.npz for npz and mujoco, .csv for csv).
        fmt: a key of :data:`FORMATS`; None: from the suffix.
        fps: resample to this frame rate first [1/s].
        mjcf: MuJoCo model for ``mujoco`` (:func:`mujoco_model`: None compiles the robot's
            URDF, ``"menagerie"``, or an MJCF file).
        robot (imesh.robot.Robot | None): the robot of the motion, for its URDF (default
            ``load_robot(motion.robot)``; a robot whose model the user provides must be given).

    Returns:
        The path written.
    """
    path = Path(path)
    fmt = format_for(path, fmt)
    if fps is not None:
        motion = resample_robot_motion(motion, fps)
    if fmt == "npz":
        save_robot_motion(path, motion)
    elif fmt == "csv":
        with atomic_path(path) as tmp:
            np.savetxt(tmp, motion.q, delimiter=",", fmt="%.17g")
    elif fmt == "gmr":
        write_gmr(motion, path)
    else:
        model, source, xml = mujoco_model(motion.robot if robot is None else robot, mjcf)
        qpos, names, filled = mujoco_qpos(motion, model)
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(fh, format=np.str_(MUJOCO_FORMAT), qpos=qpos,
                                fps=np.float64(motion.fps), robot=np.str_(motion.robot),
                                qpos_joint_names=np.array(names, dtype=np.str_).reshape(-1),
                                filled_joints=np.array(filled, dtype=np.str_).reshape(-1),
                                mjcf=np.str_(source), mjcf_xml=np.str_(xml))
    log.info("exported %s (%s): %d frames of %s at %g fps", path, fmt, motion.n_frames,
             motion.robot, motion.fps)
    return path


# ------------------------------------------------------------------------------- reading
def _first_data_line(path: Path) -> str:
    try:
        with open(path, encoding="utf-8") as fh:
            for line in fh:
                if line.strip():
                    return line.strip()
    except (OSError, UnicodeDecodeError) as exc:
        raise MotionFileError(str(path), f"cannot read ({exc})") from None
    return ""


def _is_headerless_csv(path: Path) -> bool:
    first = _first_data_line(path).split(",")[0]
    try:
        float(first)
    except ValueError:
        return False
    return True


def _is_mujoco(path: Path) -> bool:
    return "qpos" in load_npz(path, "robot motion")


def is_export(path: str | os.PathLike) -> bool:
    """True for a headerless (LAFAN1-layout) CSV or a MuJoCo qpos .npz."""
    path = Path(path)
    if not path.is_file():
        return False
    suffix = path.suffix.lower()
    return (suffix == ".csv" and _is_headerless_csv(path)) or (suffix == ".npz"
                                                                 and _is_mujoco(path))


def robot_named_in(path: str | os.PathLike) -> str | None:
    """The robot a motion file names (None for a headerless CSV, a GMR pickle GMR wrote or a
    file that names none)."""
    path = Path(path)
    if is_gmr(path):
        return gmr_robot_name(path)
    if path.suffix.lower() == ".npz":
        arrays = load_npz(path, "robot motion")
        return str(arrays["robot"]) if "robot" in arrays else None
    if _is_headerless_csv(path):
        return None

    match = re.search(r"robot=(\S+)", _first_data_line(path))
    return match[1] if match else None


def robot_for_motion_file(path: str | os.PathLike, robot: str | os.PathLike | None = None,
                          urdf: str | os.PathLike | None = None):
    """The robot of a motion file: ``robot`` when given (``load_robot(robot, urdf)``), else the
    robot the file names (``imesh view|evaluate|export`` without ``--robot``); ``urdf`` alone
    is that robot's model file when the file names a shipped robot (``hrp4c``), else the URDF a
    configuration is generated from.

    A robot whose model the user provides (HRP-4C, a URDF alone) is found by the robot.toml
    and URDF paths its provenance records, when they still exist. A robot configuration that
    changed since the motion was made (another SHA-256 than its provenance's) is logged as a
    warning.

    Raises:
        MotionFileError: the file names no robot (a headerless CSV, plain arrays without
            ``robot``): pass ``--robot``.
        RobotConfigError: the named robot cannot be loaded (unknown name, model missing).
    """
    from ..core.provenance import robot_sha256
    from ..robot.errors import RobotConfigError

    if robot is not None:
        return load_robot(str(robot), urdf=None if urdf is None else str(urdf))
    path = Path(path)
    if not path.is_file():
        raise MotionFileError(str(path), "no such file")
    name = robot_named_in(path) if path.suffix.lower() in (".npz", ".csv") or is_gmr(path) \
        else None
    if urdf is not None:
        # ``--urdf`` alone on a motion of a shipped robot whose model the user provides
        # (hrp4c): that robot with this model, as ``imesh retarget --robot hrp4c --urdf``
        # made it; a robot of no shipped configuration: generated from the URDF alone
        from ..robot.registry import robot_names

        return load_robot(name if name in robot_names() else None, urdf=str(urdf))
    if not name:
        raise MotionFileError(str(path), "the file does not name its robot: pass --robot "
                              "(robot=)" + ("; GMR's pickles do not (GMR's unitree_g1 is "
                                            "--robot g1)" if is_gmr(path) else ""))
    provenance = read_provenance(path)
    try:
        loaded = load_robot(name)
    except RobotConfigError:
        if provenance is None or not Path(provenance.robot_toml).is_file():
            raise
        log.info("%s: robot %s from the files its provenance names (%s, %s)", path, name,
                 provenance.robot_toml, provenance.urdf)
        loaded = load_robot(provenance.robot_toml, urdf=provenance.urdf
                            if Path(provenance.urdf).is_file() else None)
    if provenance is not None and robot_sha256(loaded) != provenance.robot_sha256:
        log.warning("%s: the configuration of robot %s (robot.toml, markers.toml, URDF) "
                    "changed since the motion was made (imesh %s)", path, name,
                    provenance.imesh_version)
    return loaded


def read_export(path: str | os.PathLike, robot=None, fps: float | None = None) -> RobotMotion:
    """Read any robot-motion file imesh writes: the imesh .npz/.csv, a headerless CSV
    (``robot`` required: name or Robot for its joint names; ``fps`` default
    :data:`CSV_DEFAULT_FPS`), a MuJoCo qpos .npz (joints the motion did not have dropped) or a
    GMR pickle (``.pkl``, :func:`imesh.io.gmr.read_gmr`; ``robot`` required unless the file
    names it; ``fps`` overrides the file's).

    Raises:
        MotionFileError: unreadable or malformed file (names the file and the problem).
    """
    path = Path(path)
    if not path.is_file():
        raise MotionFileError(str(path), "no such file")
    suffix = path.suffix.lower()
    if is_gmr(path):
        if robot is None or isinstance(robot, str | os.PathLike):
            robot = robot_for_motion_file(path, robot)
        return read_gmr(path, robot, fps)
    if suffix == ".csv" and _is_headerless_csv(path):
        return _read_headerless_csv(path, robot, fps)
    if suffix == ".npz" and _is_mujoco(path):
        return _read_mujoco(path)
    return load_robot_motion(path, robot)


def _read_headerless_csv(path: Path, robot, fps: float | None) -> RobotMotion:
    if robot is None or isinstance(robot, str | os.PathLike):
        if robot is None:
            raise MotionFileError(str(path), "a headerless CSV does not name its robot or "
                                  "joints: pass the robot (--robot)")

        robot = load_robot(robot)
    names = tuple(robot.joint_names)
    try:
        table = np.loadtxt(path, delimiter=",", ndmin=2, dtype=np.float64)
    except ValueError as exc:
        raise MotionFileError(str(path), f"not a table of numbers ({exc})") from None
    if table.shape[1] != 7 + len(names):
        raise MotionFileError(str(path), f"{table.shape[1]} columns; {robot.name} needs 7 base "
                              f"columns + {len(names)} joints = {7 + len(names)}")
    try:
        return RobotMotion(q=table, fps=fps or CSV_DEFAULT_FPS, robot=robot.name,
                           joint_names=names)
    except ImeshError as exc:
        raise MotionFileError(str(path), str(exc)) from None


def _read_mujoco(path: Path) -> RobotMotion:
    a = load_npz(path, "MuJoCo qpos export")
    missing = [k for k in ("qpos", "fps", "robot", "qpos_joint_names", "filled_joints")
               if k not in a]
    if missing:
        raise MotionFileError(str(path), f"missing keys {missing} of a MuJoCo qpos export")
    qpos = np.asarray(a["qpos"], dtype=np.float64)
    names = [str(n) for n in np.asarray(a["qpos_joint_names"]).reshape(-1)]
    filled = {str(n) for n in np.asarray(a["filled_joints"]).reshape(-1)}
    if qpos.ndim != 2 or qpos.shape[1] != 7 + len(names):
        raise MotionFileError(str(path), f"qpos has shape {qpos.shape}; 7 + {len(names)} joint "
                              "columns expected (hinge/slide joints only)")
    keep = [i for i, n in enumerate(names) if n not in filled]
    quat = np.column_stack([qpos[:, 4:7], qpos[:, 3]])
    try:
        return RobotMotion.from_parts(qpos[:, :3], quat, qpos[:, 7:][:, keep],
                                      fps=float(a["fps"]), robot=str(a["robot"]),
                                      joint_names=[names[i] for i in keep])
    except ImeshError as exc:
        raise MotionFileError(str(path), str(exc)) from None
