"""GMR's robot-motion pickle (github ``YanjieZe/GMR``, "General Motion Retargeting"), read and
written (``imesh evaluate MOTION.pkl``, ``imesh export --format gmr``; docs/exports.md).

The layout GMR's scripts (``bvh_to_robot.py``, ``smplx_to_robot.py``) write with ``pickle``: a
dict of ``fps`` (number), ``root_pos`` (T, 3) [m] (the root body's position in the world,
Z up), ``root_rot`` (T, 4) the root body's orientation as a quaternion **x, y, z, w**,
``dof_pos`` (T, n) [rad] in the joint order of GMR's robot model (MJCF), and
``local_body_pos`` / ``link_body_list`` (None in those scripts; body positions in the root
frame and their names in ``bvh_to_robot_dataset.py``; imesh neither needs nor writes them).

The pickle names neither the robot nor its joints: the columns of ``dof_pos`` are those of
GMR's model, :data:`GMR_JOINTS` (GMR's ``unitree_g1``: 29, ``unitree_g1_with_hands``: 43, told
apart by the column count), mapped by name to the robot's joints. imesh's G1 (example-robot-
data's ``g1_29dof_rev_1_0.urdf``) has the same 29 joint names, the same kinematics and the same
root body (``pelvis``) as GMR's ``g1_mocap_29dof.xml``; hand joints of ``unitree_g1_with_hands``
are dropped. A file imesh writes adds ``robot``, ``joint_names`` and ``provenance`` (JSON)
keys, which GMR's loaders ignore.

Pickles run code when loaded by ``pickle.load``: :func:`read_gmr` unpickles with an allow-list
(numpy arrays and scalars, Python containers and numbers), so a crafted file is refused rather
than run.
"""

from __future__ import annotations

import io
import logging
import os
import pickle
from pathlib import Path

import numpy as np

from ..core.provenance import Provenance
from ..core.robot_motion import RobotMotion
from ..errors import ImeshError, MotionFileError, _listing
from .atomic import atomic_path

log = logging.getLogger(__name__)

_G1_29 = (
    "left_hip_pitch_joint", "left_hip_roll_joint", "left_hip_yaw_joint", "left_knee_joint",
    "left_ankle_pitch_joint", "left_ankle_roll_joint",
    "right_hip_pitch_joint", "right_hip_roll_joint", "right_hip_yaw_joint", "right_knee_joint",
    "right_ankle_pitch_joint", "right_ankle_roll_joint",
    "waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint",
    "left_shoulder_pitch_joint", "left_shoulder_roll_joint", "left_shoulder_yaw_joint",
    "left_elbow_joint", "left_wrist_roll_joint", "left_wrist_pitch_joint",
    "left_wrist_yaw_joint",
    "right_shoulder_pitch_joint", "right_shoulder_roll_joint", "right_shoulder_yaw_joint",
    "right_elbow_joint", "right_wrist_roll_joint", "right_wrist_pitch_joint",
    "right_wrist_yaw_joint",
)
_HAND = ("thumb_0", "thumb_1", "thumb_2", "middle_0", "middle_1", "index_0", "index_1")

#: GMR robot model -> the joint order of its ``dof_pos`` columns (GMR commit 4f9e8b7,
#: ``assets/unitree_g1/g1_mocap_29dof.xml`` and ``g1_mocap_29dof_with_hands.xml``).
GMR_JOINTS: dict[str, tuple[str, ...]] = {
    "unitree_g1": _G1_29,
    "unitree_g1_with_hands": (_G1_29[:22] + tuple(f"left_hand_{h}_joint" for h in _HAND)
                              + _G1_29[22:] + tuple(f"right_hand_{h}_joint" for h in _HAND)),
}
#: imesh robot -> the GMR model :func:`write_gmr` writes for it.
GMR_ROBOTS: dict[str, str] = {"g1": "unitree_g1"}
#: File suffixes read as GMR pickles.
GMR_SUFFIXES = (".pkl", ".pickle")


class GMRJointError(MotionFileError):
    """A GMR pickle whose joints do not map onto the robot (or a motion that GMR's model of the
    robot cannot hold). ``missing``: the robot's joints the file lacks (or the reverse)."""

    def __init__(self, path: str, message: str, missing: tuple[str, ...] = ()):
        super().__init__(path, message)
        self.missing = missing


def is_gmr(path: str | os.PathLike) -> bool:
    """True for a path with a pickle suffix (:data:`GMR_SUFFIXES`)."""
    return Path(path).suffix.lower() in GMR_SUFFIXES


_ALLOWED = {
    ("builtins", n) for n in ("dict", "list", "tuple", "set", "frozenset", "str", "bytes",
                              "int", "float", "bool", "complex", "NoneType", "slice")
} | {
    (m, n) for m in ("numpy.core.multiarray", "numpy._core.multiarray")
    for n in ("_reconstruct", "scalar")
} | {("numpy", "ndarray"), ("numpy", "dtype"), ("numpy.core.numeric", "_frombuffer"),
     ("numpy._core.numeric", "_frombuffer")}


class _Unpickler(pickle.Unpickler):
    def find_class(self, module: str, name: str):
        if (module, name) in _ALLOWED or (module == "numpy" and name.endswith("DType")):
            return super().find_class(module, name)
        raise pickle.UnpicklingError(f"{module}.{name} is not allowed in a GMR motion pickle "
                                     "(numpy arrays and Python numbers, strings, containers)")


def _unpickle(path: Path) -> dict:
    try:
        data = _Unpickler(io.BytesIO(path.read_bytes())).load()
    except (OSError, EOFError, pickle.UnpicklingError, AttributeError, ImportError,
            IndexError, TypeError, ValueError) as exc:
        raise MotionFileError(str(path), f"not a readable GMR pickle ({exc})") from None
    if not isinstance(data, dict):
        raise MotionFileError(str(path), f"a GMR pickle holds a dict; this one a "
                              f"{type(data).__name__}")
    return data


def gmr_robot_name(path: str | os.PathLike) -> str | None:
    """The robot a GMR pickle names (only files imesh wrote name one; GMR's do not)."""
    name = _unpickle(Path(path)).get("robot")
    return str(name) if name else None


def read_gmr(path: str | os.PathLike, robot, fps: float | None = None) -> RobotMotion:
    """A GMR motion pickle (module docstring) as a motion of ``robot``.

    Args:
        path: the ``.pkl`` file.
        robot: the :class:`imesh.robot.Robot` (its joint names; columns are put in its order).
        fps: overrides the file's frame rate [1/s].

    Raises:
        MotionFileError: unreadable pickle, missing keys, wrong shapes, non-finite values, a
            motion of another robot.
        GMRJointError: a ``dof_pos`` column count of no known GMR model, or joints of the
            robot that the file's GMR model lacks (named).
    """
    path = Path(path)
    data = _unpickle(path)
    need = ("fps", "root_pos", "root_rot", "dof_pos")
    missing = [k for k in need if k not in data]
    if missing:
        raise MotionFileError(str(path), f"missing keys {missing}; a GMR motion pickle has "
                              f"fps, root_pos (T, 3), root_rot (T, 4) xyzw, dof_pos (T, n); "
                              f"this one has {sorted(map(str, data))}")
    try:
        dof = np.asarray(data["dof_pos"], dtype=np.float64)
        root = np.asarray(data["root_pos"], dtype=np.float64)
        quat = np.asarray(data["root_rot"], dtype=np.float64)
        file_fps = float(data["fps"])
    except (TypeError, ValueError) as exc:
        raise MotionFileError(str(path), f"wrong array types ({exc})") from None
    name = data.get("robot")
    if name is not None and str(name) != robot.name:
        raise MotionFileError(str(path), f"this is a motion of robot {name!r}, not of "
                              f"{robot.name!r}")
    if dof.ndim != 2 or root.shape != (dof.shape[0], 3) or quat.shape != (dof.shape[0], 4):
        raise MotionFileError(str(path), f"shapes dof_pos {dof.shape}, root_pos {root.shape}, "
                              f"root_rot {quat.shape}; expected (T, n), (T, 3), (T, 4)")
    if data.get("joint_names") is not None:
        names = tuple(str(n) for n in np.asarray(data["joint_names"]).reshape(-1))
        model = "the file's joint_names"
    else:
        models = [m for m, joints in GMR_JOINTS.items() if len(joints) == dof.shape[1]]
        if not models:
            raise GMRJointError(str(path), f"dof_pos has {dof.shape[1]} columns; GMR models "
                                "imesh knows: " + ", ".join(
                                    f"{m} ({len(j)})" for m, j in GMR_JOINTS.items()))
        model = f"GMR's {models[0]}"
        names = GMR_JOINTS[models[0]]
    if len(names) != dof.shape[1]:
        raise MotionFileError(str(path), f"{len(names)} joint_names for {dof.shape[1]} "
                              "dof_pos columns")
    absent = tuple(n for n in robot.joint_names if n not in names)
    if absent:
        raise GMRJointError(str(path), f"joints of {robot.name} missing from {model}: "
                            f"{_listing(absent)}; a GMR pickle of this robot needs all "
                            f"{robot.dof}", missing=absent)
    dropped = [n for n in names if n not in robot.joint_names]
    if dropped:
        log.info("%s: %d joints of %s not in %s dropped: %s", path, len(dropped), model,
                 robot.name, dropped)
    order = [names.index(n) for n in robot.joint_names]
    provenance = None
    if data.get("provenance") is not None:
        try:
            provenance = Provenance.from_json(str(data["provenance"]))
            provenance.clip_frames(dof.shape[0])
        except (ImeshError, ValueError, TypeError, KeyError) as exc:
            raise MotionFileError(str(path), f"malformed provenance ({exc})") from None
    try:
        motion = RobotMotion.from_parts(root, quat, dof[:, order],
                                        fps=fps if fps is not None else file_fps,
                                        robot=robot.name, joint_names=robot.joint_names)
    except ImeshError as exc:
        raise MotionFileError(str(path), str(exc)) from None
    if provenance is not None:
        import dataclasses

        motion = dataclasses.replace(motion, provenance=provenance)
    return motion


def write_gmr(motion: RobotMotion, path: str | os.PathLike) -> Path:
    """Write ``motion`` as a GMR motion pickle (module docstring), atomically.

    ``dof_pos`` is in the joint order of the GMR model of the robot (:data:`GMR_ROBOTS`),
    ``root_rot`` x, y, z, w, ``fps`` an int when it is a whole number (as GMR writes it), float64
    arrays; ``local_body_pos`` and ``link_body_list`` None (as GMR's ``bvh_to_robot.py``).

    Raises:
        GMRJointError: a robot GMR has no model of, or joints of that model the motion lacks.
    """
    path = Path(path)
    model = GMR_ROBOTS.get(motion.robot)
    if model is None:
        raise GMRJointError(str(path), f"GMR has no model of robot {motion.robot!r}; robots "
                            f"with one: {', '.join(f'{r} ({m})' for r, m in GMR_ROBOTS.items())}")
    joints = GMR_JOINTS[model]
    absent = tuple(n for n in joints if n not in motion.joint_names)
    if absent:
        raise GMRJointError(str(path), f"joints of GMR's {model} missing from the motion: "
                            f"{_listing(absent)}", missing=absent)
    order = [motion.joint_names.index(n) for n in joints]
    fps: float | int = int(motion.fps) if float(motion.fps).is_integer() else float(motion.fps)
    data = {
        "fps": fps,
        "root_pos": np.array(motion.base_position, dtype=np.float64),
        "root_rot": np.array(motion.base_quat_xyzw, dtype=np.float64),
        "dof_pos": np.array(motion.joint_positions[:, order], dtype=np.float64),
        "local_body_pos": None,
        "link_body_list": None,
        "robot": motion.robot,
        "joint_names": list(joints),
        "provenance": None if motion.provenance is None else motion.provenance.to_json(),
    }
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        pickle.dump(data, fh, protocol=4)
    return path
