"""AMASS motions: SMPL-H and SMPL-X parameters in an ``.npz`` turned into joint positions with
the user's body-model files (``imesh retarget FILE.npz --body-model DIR``; docs/amass.md).

**The file.** An AMASS ``.npz`` holds ``poses`` (T, 156) for SMPL-H or (T, 165) for SMPL-X:
axis-angle rotations [rad] of every joint of the model's tree, parent-relative, root first
(SMPL-X: root, 21 body joints, jaw, left eye, right eye, 15 left-hand and 15 right-hand joints;
SMPL-H: root, 21 body joints, 15 + 15 hand joints); ``trans`` (T, 3) [m], the root translation;
``betas`` (B,) the body shape (16 in AMASS); ``gender`` (``neutral``, ``male``, ``female``); the
frame rate ``mocap_framerate`` (SMPL-H releases) or ``mocap_frame_rate`` (SMPL-X releases).
Other keys (``dmpls``, ``root_orient``, ``pose_body``, ``markers_latent`` ...) are not read.
AMASS bakes a rotation of the model's Y-up frame into ``poses[:, :3]``, so its joints are in
metres with **Z up**: the reader declares ``+Z`` (``--up-axis`` overrides it).

**The body model.** Joints depend on the shaped template only:
``J = J_regressor @ (v_template + shapedirs[..., :B] @ betas)`` (J, 3) [m], then forward
kinematics down ``kintree_table`` with the Rodrigues rotations of ``poses``, plus ``trans``.
Pose-dependent blend shapes (``posedirs``) and skinning move vertices, never the regressed
joints, so this numpy computation gives the joints the ``smplx`` package computes without
needing torch (about 700 MB). SMPL-X expression components (``shapedirs`` beyond the shape
ones) are taken as zero: AMASS stores no expression. Hand, jaw and eye rotations are applied
as stored (``flat_hand_mean``: a hand mean pose would move finger joints beyond the first
knuckle only, none of which imesh uses).

Files are found in the layout the ``smplx`` package and GMR use: ``DIR/smplx/SMPLX_NEUTRAL.npz``
(``MALE``, ``FEMALE``; ``.pkl`` too) and ``DIR/smplh/SMPLH_MALE.npz``, or AMASS's own SMPL+H
layout ``DIR/smplh/male/model.npz``; ``DIR`` may also be the ``smplx``/``smplh`` folder
itself. ``.npz`` is preferred; a ``.pkl`` is unpickled with an allow-list (numpy arrays, scipy
sparse matrices, Python containers), so a crafted file is refused rather than run.

The joints keep the names of the ``smplx`` package (``pelvis``, ``left_hip`` ...,
``left_index1`` ...) and the model's tree as bones; :func:`imesh.human.standard.to_standard`
recognizes the human body in that tree like any other skeleton.
"""

from __future__ import annotations

import io
import logging
import os
import pickle
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ImeshError, MotionFileError, _listing
from .npz import load_npz
from .raw import RawMotion

log = logging.getLogger(__name__)

__all__ = ["BodyModel", "BodyModelError", "MODELS", "GENDERS", "is_amass", "read_amass",
           "load_body_model", "find_body_model", "rest_joints_m", "joint_positions_m"]

#: The 22 body joints shared by SMPL, SMPL-H and SMPL-X (names of the smplx package).
BODY_JOINTS: tuple[str, ...] = (
    "pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2",
    "left_ankle", "right_ankle", "spine3", "left_foot", "right_foot", "neck", "left_collar",
    "right_collar", "head", "left_shoulder", "right_shoulder", "left_elbow", "right_elbow",
    "left_wrist", "right_wrist",
)
_BODY_PARENTS = (-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19)
_FINGERS = ("index", "middle", "pinky", "ring", "thumb")


def _hand(side: str) -> tuple[str, ...]:
    return tuple(f"{side}_{f}{k}" for f in _FINGERS for k in (1, 2, 3))


def _hand_parents(wrist: int, first: int) -> tuple[int, ...]:
    """Parents of the 15 joints of a hand starting at index ``first``: each finger a chain of
    3 from the wrist."""
    return tuple(wrist if k == 0 else first + 3 * f + k - 1 for f in range(5) for k in range(3))


@dataclass(frozen=True)
class ModelSpec:
    """One body-model family.

    Attributes:
        kind: "smplh" or "smplx" (the folder name of its files).
        joints: (J,) joint names, in the order of ``poses`` and of the model's tree.
        parents: (J,) parent index of each joint (-1 for the root).
        file_stem: stem of the model files (``SMPLX`` -> ``SMPLX_NEUTRAL.npz``).
    """

    kind: str
    joints: tuple[str, ...]
    parents: tuple[int, ...]
    file_stem: str

    @property
    def pose_width(self) -> int:
        """Columns of ``poses``: 3 per joint."""
        return 3 * len(self.joints)


_SMPLX_JOINTS = BODY_JOINTS + ("jaw", "left_eye_smplhf", "right_eye_smplhf") + _hand("left") \
    + _hand("right")
_SMPLX_PARENTS = _BODY_PARENTS + (15, 15, 15) + _hand_parents(20, 25) + _hand_parents(21, 40)
_SMPLH_JOINTS = BODY_JOINTS + _hand("left") + _hand("right")
_SMPLH_PARENTS = _BODY_PARENTS + _hand_parents(20, 22) + _hand_parents(21, 37)

#: Body-model families by kind: SMPL-X (55 joints, poses (T, 165)) and SMPL-H (52, (T, 156)).
MODELS: dict[str, ModelSpec] = {
    "smplx": ModelSpec("smplx", _SMPLX_JOINTS, _SMPLX_PARENTS, "SMPLX"),
    "smplh": ModelSpec("smplh", _SMPLH_JOINTS, _SMPLH_PARENTS, "SMPLH"),
}
#: Genders of the body models (AMASS ``gender``).
GENDERS = ("neutral", "male", "female")
#: SMPL-X shape components of the v1.1 models (``shapedirs`` of 400 = 300 shape + 100
#: expression); a model with fewer columns is v1.0: 10 shape + 10 expression (as in smplx).
SMPLX_SHAPE_DIM = 300
_SMPLX_V1_1_COLUMNS = 400
#: Keys of an AMASS file that are read (the rest is ignored).
AMASS_KEYS = ("poses", "trans", "betas", "gender", "mocap_framerate", "mocap_frame_rate",
              "surface_model_type")
_MODEL_KEYS = ("v_template", "shapedirs", "J_regressor", "kintree_table")
#: Frames whose forward kinematics run at once (bounds the (frames, joints, 3, 3) rotations).
_BLOCK_FRAMES = 8192


class BodyModelError(ImeshError):
    """The body model an AMASS file needs cannot be used: no ``--body-model`` folder, no file
    for the file's model and gender in it, or a file that is not that model.

    Attributes:
        path: the folder or file at fault ("" when none was given).
        reason: what is wrong.
        valid: what would be valid.
    """

    def __init__(self, path: str | os.PathLike, reason: str, valid: str):
        where = f"body model {str(path)!r}: " if str(path) else ""
        super().__init__(f"{where}{reason}; valid: {valid}")
        self.path = str(path)
        self.reason = reason
        self.valid = valid


@dataclass(frozen=True, eq=False)
class BodyModel:
    """What the joints of one body model need.

    Attributes:
        spec: the model family (joint names and tree).
        gender: "neutral", "male" or "female".
        path: the model file read.
        v_template_m: (V, 3) template vertices [m], the model's Y-up frame.
        shapedirs_m: (V, 3, S) shape blend shapes [m per unit beta] (shape components only).
        j_regressor: (J, V) joint regressor (rows sum to 1 in the official models).
    """

    spec: ModelSpec
    gender: str
    path: str
    v_template_m: np.ndarray = field(repr=False)
    shapedirs_m: np.ndarray = field(repr=False)
    j_regressor: np.ndarray = field(repr=False)

    @property
    def n_shape(self) -> int:
        """Shape components S."""
        return int(self.shapedirs_m.shape[2])


# ---------------------------------------------------------------------------- body models
def find_body_model(folder: str | os.PathLike, kind: str, gender: str) -> Path:
    """The model file of ``kind`` and ``gender`` in a body-model folder (module docstring).

    Args:
        folder (str | os.PathLike): ``DIR`` holding ``smplx/``/``smplh/``, or that folder.
        kind (str): "smplx" or "smplh".
        gender (str): "neutral", "male" or "female".

    Raises:
        BodyModelError: no such folder, or no file of the model and gender in it (lists the
            paths looked for and the model files found).
    """
    root = Path(folder)
    spec = MODELS[kind]
    if not root.is_dir():
        raise BodyModelError(root, "no such folder", f"the folder holding {kind}/"
                             f"{spec.file_stem}_{gender.upper()}.npz (--body-model DIR)")
    stem = f"{spec.file_stem}_{gender.upper()}"
    bases = [root / kind, root] if root.name.lower() != kind else [root]
    candidates = [b / f"{stem}{ext}" for b in bases for ext in (".npz", ".pkl")]
    if kind == "smplh":  # AMASS's "extended SMPL+H" layout
        candidates += [b / gender / "model.npz" for b in bases]
    for path in candidates:
        if path.is_file():
            return path
    found = sorted(str(p.relative_to(root)) for pattern in ("*.npz", "*.pkl", "*/*.npz",
                                                            "*/*.pkl", "*/*/model.npz")
                   for p in root.glob(pattern))
    raise BodyModelError(root, f"no {kind.upper()} model of gender {gender!r} (looked for "
                         f"{', '.join(str(p.relative_to(root)) for p in candidates)}; model "
                         f"files found: {_listing(found, 12) or 'none'})",
                         f"a folder with {kind}/{stem}.npz from the {kind.upper()} download "
                         "(docs/amass.md)")


_ALLOWED = {
    ("builtins", n) for n in ("dict", "list", "tuple", "set", "str", "bytes", "int", "float",
                              "bool", "complex", "object")
} | {("__builtin__", n) for n in ("object", "set", "frozenset")} | {
    (m, n) for m in ("numpy.core.multiarray", "numpy._core.multiarray")
    for n in ("_reconstruct", "scalar")
} | {("numpy", "ndarray"), ("numpy", "dtype"), ("copy_reg", "_reconstructor"),
     ("copyreg", "_reconstructor"), ("copyreg", "__newobj__"),
     ("_codecs", "encode")} | {
    (f"scipy.sparse.{p}{k}", f"{k}_matrix") for p in ("", "_") for k in ("csr", "csc", "coo")
}


class _ModelUnpickler(pickle.Unpickler):
    def find_class(self, module: str, name: str):
        if (module, name) in _ALLOWED or (module == "numpy" and name.endswith("DType")):
            return super().find_class(module, name)
        if module.startswith("chumpy"):
            raise pickle.UnpicklingError(
                "it holds chumpy objects: use the model's .npz file (in the same download), or "
                "remove chumpy with the smplx package's tools/clean_ch.py")
        raise pickle.UnpicklingError(f"{module}.{name} is not allowed in a body-model pickle "
                                     "(numpy arrays, scipy sparse matrices, Python containers)")


def _read_model_file(path: Path, what: str) -> dict[str, np.ndarray]:
    """The arrays of :data:`_MODEL_KEYS` in a model ``.npz`` or ``.pkl`` (dense float64)."""
    if path.suffix.lower() == ".npz":
        try:
            data: dict = load_npz(path, what, keys=_MODEL_KEYS)
        except MotionFileError as exc:
            raise BodyModelError(path, f"not readable ({exc})", f"the {what} file") from None
    else:
        try:
            data = _ModelUnpickler(io.BytesIO(path.read_bytes()), encoding="latin1").load()
        except (OSError, EOFError, pickle.UnpicklingError, AttributeError, ImportError,
                IndexError, TypeError, ValueError, MemoryError) as exc:
            raise BodyModelError(path, f"not a readable body-model pickle ({exc})",
                                 f"the {what} file") from None
        if not isinstance(data, dict):
            raise BodyModelError(path, f"holds a {type(data).__name__}, not a dict",
                                 f"the {what} file")
    missing = [k for k in _MODEL_KEYS if k not in data]
    if missing:
        raise BodyModelError(path, f"missing {', '.join(missing)}", f"a {what} file with "
                             f"{', '.join(_MODEL_KEYS)}")
    out = {}
    for key in _MODEL_KEYS:
        value = data[key]
        if hasattr(value, "toarray"):  # a scipy sparse J_regressor (.pkl files)
            value = value.toarray()
        try:
            out[key] = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise BodyModelError(path, f"{key} is not numeric ({exc})", f"the {what} file"
                                 ) from None
    return out


def load_body_model(path: str | os.PathLike, kind: str, gender: str) -> BodyModel:
    """Read and check a body-model file (``.npz`` or ``.pkl``).

    Args:
        path (str | os.PathLike): the file (:func:`find_body_model`).
        kind (str): "smplx" or "smplh": the tree the file must have.
        gender (str): recorded in the result.

    Raises:
        BodyModelError: unreadable, missing arrays, shapes that do not fit, another model's
            tree (an SMPL-H file given for SMPL-X poses), non-finite values.
    """
    path = Path(path)
    spec = MODELS[kind]
    what = f"{kind.upper()} body model"
    a = _read_model_file(path, what)
    v, sd, jr, tree = a["v_template"], a["shapedirs"], a["J_regressor"], a["kintree_table"]
    if sd.ndim == 2 and v.ndim == 2:  # one component stored flat
        sd = sd[:, :, None]
    n_joints = len(spec.joints)
    if v.ndim != 2 or v.shape[1] != 3 or sd.shape[:2] != v.shape or sd.ndim != 3 \
            or jr.shape != (n_joints, v.shape[0]) or tree.shape != (2, n_joints):
        raise BodyModelError(path, f"shapes v_template {v.shape}, shapedirs {sd.shape}, "
                             f"J_regressor {jr.shape}, kintree_table {tree.shape}",
                             f"a {what}: (V, 3), (V, 3, S), ({n_joints}, V), (2, {n_joints})")
    parents = tree[0].astype(np.int64)
    expected = np.array(spec.parents[1:])
    if not np.array_equal(parents[1:], expected):
        other = [k for k, s in MODELS.items() if len(s.joints) == n_joints and k != kind]
        raise BodyModelError(path, f"its kinematic tree is not the {kind.upper()} tree "
                             f"(joint {int(np.flatnonzero(parents[1:] != expected)[0]) + 1})"
                             + (f"; an {other[0].upper()} file?" if other else ""),
                             f"the {what} of the official download")
    for key, arr in (("v_template", v), ("shapedirs", sd), ("J_regressor", jr)):
        if not np.isfinite(arr).all():
            raise BodyModelError(path, f"{key} has non-finite values", f"a finite {what}")
    if kind == "smplx":  # shape components first, then expression (as the smplx package)
        n_shape = SMPLX_SHAPE_DIM if sd.shape[2] >= _SMPLX_V1_1_COLUMNS else min(10,
                                                                                 sd.shape[2])
        sd = sd[:, :, :n_shape]
    log.info("%s: %s %s body model, %d vertices, %d shape components", path, gender, kind,
             v.shape[0], sd.shape[2])
    return BodyModel(spec=spec, gender=gender, path=str(path), v_template_m=v,
                     shapedirs_m=np.ascontiguousarray(sd), j_regressor=jr)


def rest_joints_m(model: BodyModel, betas: np.ndarray) -> np.ndarray:
    """(J, 3) joints of the shaped template [m], model frame:
    ``J_regressor @ (v_template + shapedirs[..., :B] @ betas)``.

    Args:
        model (BodyModel): the body model.
        betas (np.ndarray): (B,) shape coefficients, B <= the model's shape components (more
            are allowed when the extra ones are zero).

    Raises:
        BodyModelError: non-zero betas beyond the model's shape components.
    """
    betas = np.asarray(betas, dtype=np.float64).reshape(-1)
    n = min(len(betas), model.n_shape)
    if np.any(betas[n:] != 0.0):
        raise BodyModelError(model.path, f"{model.n_shape} shape components, the motion has "
                             f"{len(betas)} non-zero betas", f"a model with at least "
                             f"{len(betas)} shape components (SMPL-X v1.1: 300; AMASS's SMPL+H: "
                             "16)")
    shaped = model.v_template_m + model.shapedirs_m[:, :, :n] @ betas[:n]
    return model.j_regressor @ shaped


def joint_positions_m(rest_m: np.ndarray, parents: np.ndarray | tuple[int, ...],
                      rotvec_rad: np.ndarray, trans_m: np.ndarray) -> np.ndarray:
    """(T, J, 3) posed joints [m]: forward kinematics of the rest joints with parent-relative
    axis-angle rotations, plus the root translation.

    Joint j's world rotation is ``G_j = G_parent @ R_j`` and its position
    ``p_j = p_parent + G_parent @ (rest_j - rest_parent)``; the root's is ``rest_0 + trans``.

    Args:
        rest_m (np.ndarray): (J, 3) rest joints [m].
        parents (np.ndarray | tuple[int, ...]): (J,) parent of each joint, -1 for the root,
            parents before children.
        rotvec_rad (np.ndarray): (T, J, 3) axis-angle rotations [rad].
        trans_m (np.ndarray): (T, 3) root translation [m].
    """
    from scipy.spatial.transform import Rotation  # not at import: imesh.io loads without scipy

    rest_m = np.asarray(rest_m, dtype=np.float64)
    n_frames, n_joints = rotvec_rad.shape[:2]
    parents = np.asarray(parents, dtype=np.int64)
    offsets = rest_m - rest_m[np.maximum(parents, 0)]
    out = np.empty((n_frames, n_joints, 3))
    for a in range(0, n_frames, _BLOCK_FRAMES):
        rv = np.array(rotvec_rad[a:a + _BLOCK_FRAMES], dtype=np.float64)  # scipy: writable
        local = Rotation.from_rotvec(rv.reshape(-1, 3)).as_matrix().reshape(*rv.shape[:2], 3, 3)
        world = np.empty_like(local)
        world[:, 0] = local[:, 0]
        out[a:a + len(rv), 0] = rest_m[0] + trans_m[a:a + len(rv)]
        for j in range(1, n_joints):
            p = parents[j]
            world[:, j] = world[:, p] @ local[:, j]
            out[a:a + len(rv), j] = out[a:a + len(rv), p] + world[:, p] @ offsets[j]
    return out


# ---------------------------------------------------------------------------- AMASS files
def _members(path: Path) -> list[str]:
    try:
        with zipfile.ZipFile(path) as zf:
            return [n[:-4] for n in zf.namelist() if n.endswith(".npy")]
    except (OSError, zipfile.BadZipFile, ValueError):
        return []


def is_amass(path: str | os.PathLike) -> bool:
    """True for an ``.npz`` holding ``poses`` and ``trans`` (the AMASS layout)."""
    path = Path(path)
    if path.suffix.lower() != ".npz" or not path.is_file():
        return False
    names = set(_members(path))
    return {"poses", "trans"} <= names


def _text(value: np.ndarray) -> str:
    item = np.asarray(value).reshape(-1)[0] if np.asarray(value).size else ""
    return item.decode("latin1") if isinstance(item, bytes) else str(item)


def _first_bad_frame(arr: np.ndarray) -> int:
    return int(np.flatnonzero(~np.isfinite(arr.reshape(len(arr), -1)).all(axis=1))[0])


@dataclass(frozen=True, eq=False)
class AmassParameters:
    """The parameters of an AMASS file, checked.

    Attributes:
        spec: the model family told by the pose width.
        poses_rad: (T, J, 3) axis-angle rotations [rad].
        trans_m: (T, 3) root translation [m].
        betas: (B,) shape coefficients.
        gender: "neutral", "male" or "female".
        fps: frame rate [1/s].
        fps_key: the key the frame rate came from (or "given").
    """

    spec: ModelSpec
    poses_rad: np.ndarray = field(repr=False)
    trans_m: np.ndarray = field(repr=False)
    betas: np.ndarray
    gender: str
    fps: float
    fps_key: str


def read_amass_parameters(path: str | os.PathLike, fps: float | None = None
                          ) -> AmassParameters:
    """The checked parameters of an AMASS ``.npz`` (module docstring).

    Args:
        path (str | os.PathLike): the file.
        fps (float | None): frame rate when the file stores none [1/s].

    Raises:
        MotionFileError: unreadable file, missing keys, a pose width of no known model,
            frames of ``poses`` and ``trans`` that differ, a non-finite frame (named), an
            unknown gender, no frame rate.
    """
    p = Path(path)
    a = load_npz(p, "AMASS motion", keys=AMASS_KEYS)
    missing = [k for k in ("poses", "trans", "betas", "gender") if k not in a]
    if missing:
        raise MotionFileError(str(p), f"missing keys {missing} of an AMASS motion (poses, "
                              f"trans, betas, gender, mocap_framerate); this file has "
                              f"{sorted(_members(p))}")
    try:
        poses = np.asarray(a["poses"], dtype=np.float64)
        trans = np.asarray(a["trans"], dtype=np.float64)
        betas = np.asarray(a["betas"], dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise MotionFileError(str(p), f"poses, trans and betas must be numbers ({exc})"
                              ) from None
    widths = {s.pose_width: s for s in MODELS.values()}
    if poses.ndim != 2 or poses.shape[1] not in widths:
        raise MotionFileError(str(p), f"poses has shape {poses.shape}; valid: " + " or ".join(
            f"(T, {w}) for {s.kind.upper()}" for w, s in widths.items()))
    spec = widths[poses.shape[1]]
    declared = _text(a["surface_model_type"]).lower() if "surface_model_type" in a else ""
    if declared and declared.replace("-", "").replace("+", "") != spec.kind:
        raise MotionFileError(str(p), f"surface_model_type {declared!r} but poses has "
                              f"{poses.shape[1]} columns ({spec.kind.upper()})")
    if poses.shape[0] == 0 or trans.shape != (poses.shape[0], 3):
        raise MotionFileError(str(p), f"trans has shape {trans.shape}, poses {poses.shape}; "
                              "valid: trans (T, 3) for poses (T, W), T >= 1")
    for key, arr in (("poses", poses), ("trans", trans)):
        if not np.isfinite(arr).all():
            t = _first_bad_frame(arr)
            raise MotionFileError(str(p), f"{key} has non-finite values ({arr[t].tolist()[:6]}"
                                  "...); valid: finite numbers", frame=t)
    if betas.ndim == 2 and betas.shape[0] == 1:
        betas = betas[0]
    if betas.ndim != 1 or not np.isfinite(betas).all():
        raise MotionFileError(str(p), f"betas has shape {betas.shape} or non-finite values; "
                              "valid: (B,) finite shape coefficients")
    gender = _text(a["gender"]).strip().lower()
    if gender not in GENDERS:
        raise MotionFileError(str(p), f"gender {gender!r}; valid: {', '.join(GENDERS)}")
    fps_key = next((k for k in ("mocap_framerate", "mocap_frame_rate") if k in a), "")
    if fps_key:
        try:
            file_fps = float(np.asarray(a[fps_key], dtype=np.float64).reshape(-1)[0])
        except (TypeError, ValueError, IndexError):
            file_fps = float("nan")
        if not (np.isfinite(file_fps) and file_fps > 0):
            raise MotionFileError(str(p), f"{fps_key} {file_fps!r}; valid: a frame rate > 0")
    elif fps is not None:
        file_fps, fps_key = float(fps), "given"
    else:
        raise MotionFileError(str(p), "no frame rate (mocap_framerate or mocap_frame_rate): "
                              "pass --source-fps")
    return AmassParameters(spec=spec, poses_rad=poses.reshape(len(poses), -1, 3),
                           trans_m=trans, betas=betas, gender=gender, fps=file_fps,
                           fps_key=fps_key)


def read_amass(path: str | os.PathLike, body_model: str | os.PathLike | None,
               fps: float | None = None) -> RawMotion:
    """The joints of an AMASS ``.npz`` computed with the user's body model (module docstring).

    The file is checked first, then the model is found and checked; only then are joints
    computed.

    Args:
        path (str | os.PathLike): the AMASS ``.npz``.
        body_model (str | os.PathLike | None): the body-model folder (``--body-model DIR``).
        fps (float | None): frame rate for a file that stores none [1/s].

    Returns:
        RawMotion of the model's joints (``format`` "amass", metres, +Z up, ``rig`` the model
        kind, ``bones`` the model's tree).

    Raises:
        MotionFileError: see :func:`read_amass_parameters`.
        BodyModelError: no ``body_model`` given, no model file of the kind and gender, an
            unusable file, more non-zero betas than the model's shape components.
    """
    p = Path(path)
    params = read_amass_parameters(p, fps)
    spec = params.spec
    if body_model is None:
        raise BodyModelError("", f"{p}: an AMASS {spec.kind.upper()} motion needs the "
                             f"{spec.kind.upper()} body model, which imesh cannot ship",
                             f"--body-model DIR (body_model= in load_motion), DIR holding "
                             f"{spec.kind}/{spec.file_stem}_{params.gender.upper()}.npz "
                             "(docs/amass.md)")
    model = load_body_model(find_body_model(body_model, spec.kind, params.gender), spec.kind,
                            params.gender)
    rest = rest_joints_m(model, params.betas)
    positions = joint_positions_m(rest, spec.parents, params.poses_rad, params.trans_m)
    bones = np.array([[spec.parents[j], j] for j in range(1, len(spec.joints))],
                     dtype=np.int64)
    log.info("%s: AMASS %s, %d frames at %g fps (%s), gender %s, %d betas, body model %s", p,
             spec.kind.upper(), len(positions), params.fps, params.fps_key, params.gender,
             len(params.betas), model.path)
    meta = {"amass_model": spec.kind, "gender": params.gender, "body_model": model.path,
            "betas": params.betas.tolist(), "fps_key": params.fps_key}
    return RawMotion(positions=positions, fps=params.fps, names=spec.joints,
                     valid=np.ones(positions.shape[:2], dtype=bool), path=str(p),
                     format="amass", bones=bones, declared_units="m", declared_up="+Z",
                     rig=spec.kind, meta=meta)
