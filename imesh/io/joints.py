"""Joint-position motions: ``(T, J, 3)`` arrays in ``.npy`` or ``.npz`` files, with joint names.

Many datasets ship world positions of named joints per frame and nothing else (no rotations, no
skeleton file): holosoma's climbing demo (``(T, 53, 3)`` float32, metres, Z up), the output of
pose estimators, exported FK. This reader turns them into a :class:`~imesh.io.raw.RawMotion`;
units, up axis and floor are then detected like for any marker set (:func:`imesh.io.finalize`).

**Files.**

- ``.npy``: a plain ``(T, J, 3)`` array. The joint names come from ``joints=`` (``--joints
  FILE``: a text file, one name per line; blank lines and ``#`` comments skipped), else from a
  file found beside the array (logged): ``<stem>.joints.txt``, then ``joint_names.txt`` in the
  array's folder, then in its parent folder (the layout of the holosoma demo data).
- ``.npz``: ``positions`` (T, J, 3), ``names`` (or ``joint_names``; else ``joints=`` / a file
  beside it as for ``.npy``), optionally
  ``fps``, ``units`` ("m", "cm", "mm", "in") and ``parents`` ((J,) int, -1 at the root: the
  joints' tree, so that a naming no rig table knows is recognized by its structure,
  :mod:`imesh.human.rig`).

**Frame rate.** An ``.npy`` stores none, and there is no convention for joint arrays (the
120 fps of ``.amc`` files is the CMU listing's, documented for that database only). So the rate
is ``fps=`` (``--source-fps``; :func:`imesh.io.read_raw` puts it in place of a stored one),
else the ``fps`` member of an ``.npz``, else :class:`FrameRateMissingError` lists those
options; it is never guessed. (The holosoma climbing
set is best read at 120 fps: its MANIFEST.)

**Names.** A naming of a built-in rig table (:func:`imesh.human.rig_tables.rig_of`; e.g.
``holosoma_mocap``, the 53-joint naming of holosoma's ``mocap`` format) maps the joints to the
standard markers by name. Without a table and without ``parents`` the clip cannot be mapped;
:func:`imesh.human.standard.to_standard` then says so and lists the built-in rigs (pass
``--rig TABLE.toml``).
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np

from ..errors import MotionFileError, _listing
from ..human.rig_tables import rig_of
from .npz import load_npz
from .raw import RawMotion

log = logging.getLogger(__name__)

__all__ = ["JointNamesError", "FrameRateMissingError", "read_joint_positions",
           "read_joint_names", "find_joint_names", "JOINTS_EXTENSIONS", "NAMES_FILES"]

#: Extensions of joint-position files (``.npz`` also holds AMASS motions: told by their keys).
JOINTS_EXTENSIONS = (".npy", ".npz")
#: Members of an ``.npz`` holding the positions, the names, the frame rate (first found wins).
#: Not ``joint_positions`` (a plain robot motion's joint angles, imesh.evaluate.motion_files)
#: nor ``positions_m`` (imesh's marker files).
POSITION_KEYS = ("positions",)
NAME_KEYS = ("names", "joint_names")
FPS_KEYS = ("fps", "frame_rate", "mocap_framerate")
#: Names files looked for beside an array without names (``{stem}`` is the array's stem).
NAMES_FILES = ("{stem}.joints.txt", "joint_names.txt", "../joint_names.txt")
#: Most joints a file may name (a pose estimator's whole-body set has ~130).
MAX_JOINTS = 1000


class JointNamesError(MotionFileError):
    """The joint names of a joint-position file are missing or do not fit its array.

    Attributes:
        path: the array file.
        names_path: the names file, or "" (names stored in the ``.npz``, or none found).
        n_names: names given (0 when none were found).
        n_joints: joints in the array.
    """

    def __init__(self, path: str, message: str, *, names_path: str = "", n_names: int = 0,
                 n_joints: int = 0):
        super().__init__(path, message)
        self.names_path = names_path
        self.n_names = n_names
        self.n_joints = n_joints


class FrameRateMissingError(MotionFileError):
    """A joint-position file stores no frame rate and none was given.

    Attributes:
        path: the file.
        options: the ways to give one.
    """

    def __init__(self, path: str):
        self.options = ("--source-fps RATE on the command line",
                        "fps=RATE of imesh.io.load_motion / read_clip's source_fps",
                        "an 'fps' member in the .npz")
        super().__init__(path, "the file stores no frame rate and none was given (imesh does "
                         "not guess one); valid: " + "; ".join(self.options))


def read_joint_names(path: str | os.PathLike, array_path: str = "") -> tuple[str, ...]:
    """Joint names from a text file: one per line, blank lines and ``#`` comments skipped.

    Raises:
        JointNamesError: no such file, unreadable, no names, or a name given twice.
    """
    p = Path(path)
    where = array_path or str(p)
    try:
        text = p.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise JointNamesError(where, f"cannot read the joint-names file {p} ({exc}); valid: a "
                              "text file with one joint name per line", names_path=str(p)
                              ) from None
    names = tuple(s for s in (line.split("#", 1)[0].strip() for line in text.splitlines()) if s)
    if not names:
        raise JointNamesError(where, f"joint-names file {p} holds no names; valid: one joint "
                              "name per line", names_path=str(p))
    seen: set[str] = set()
    twice = [n for n in names if n in seen or seen.add(n)]  # type: ignore[func-returns-value]
    if twice:
        raise JointNamesError(where, f"joint-names file {p} names {twice[0]!r} twice; valid: "
                              "distinct names", names_path=str(p), n_names=len(names))
    return names


def find_joint_names(path: str | os.PathLike) -> Path | None:
    """The names file found beside an array (:data:`NAMES_FILES`, first that exists), or None."""
    p = Path(path)
    for pattern in NAMES_FILES:
        candidate = (p.parent / pattern.format(stem=p.stem)).resolve()
        if candidate.is_file():
            return candidate
    return None


def _names_for(p: Path, joints: str | os.PathLike | None, stored: np.ndarray | None,
               n_joints: int) -> tuple[tuple[str, ...], str]:
    """(names, where they came from) for an array of ``n_joints`` joints."""
    if joints is not None:
        names, origin = read_joint_names(joints, str(p)), str(joints)
    elif stored is not None:
        names, origin = tuple(str(n) for n in np.asarray(stored).ravel()), "the .npz"
    else:
        found = find_joint_names(p)
        if found is None:
            tried = ", ".join(str((p.parent / f.format(stem=p.stem)).resolve())
                              for f in NAMES_FILES)
            raise JointNamesError(str(p), f"no joint names: the file stores none and none was "
                                  f"given; valid: --joints FILE (one name per line), a 'names' "
                                  f"member in an .npz, or a names file beside it ({tried})",
                                  n_joints=n_joints)
        names, origin = read_joint_names(found, str(p)), str(found)
        log.info("%s: joint names from %s (found beside the file; --joints overrides)", p, found)
    if len(names) != n_joints:
        raise JointNamesError(str(p), f"{len(names)} joint names (from {origin}) for an array of "
                              f"{n_joints} joints; valid: exactly one name per joint",
                              names_path="" if origin == "the .npz" else origin,
                              n_names=len(names), n_joints=n_joints)
    if len(set(names)) != len(names):
        twice = sorted({n for n in names if names.count(n) > 1})
        raise JointNamesError(str(p), f"joint names {twice} given twice (from {origin}); valid: "
                              "distinct names", n_names=len(names), n_joints=n_joints)
    return names, origin


def _bones_from_parents(p: Path, parents: np.ndarray, n_joints: int) -> np.ndarray:
    """(B, 2) (parent, child) pairs of a ``parents`` array (-1 at roots)."""
    par = np.asarray(parents).ravel()
    if par.shape != (n_joints,) or not np.issubdtype(par.dtype, np.integer):
        raise MotionFileError(str(p), f"'parents' has shape {par.shape} and dtype {par.dtype}; "
                              f"valid: ({n_joints},) integers, -1 at the root")
    par = par.astype(np.int64)
    bad = np.flatnonzero((par < -1) | (par >= n_joints) | (par == np.arange(n_joints)))
    if bad.size:
        raise MotionFileError(str(p), f"'parents'[{int(bad[0])}] = {int(par[bad[0]])}; valid: "
                              f"-1 or another joint's index 0..{n_joints - 1}")
    child = np.flatnonzero(par >= 0)
    return np.column_stack([par[child], child]).astype(np.int64)


def read_joint_positions(path: str | os.PathLike, *, joints: str | os.PathLike | None = None,
                         fps: float | None = None) -> RawMotion:
    """Read a joint-position motion (``.npy`` array or ``.npz`` archive).

    Args:
        path: the file.
        joints: joint-names file (one per line); overrides names stored in an ``.npz`` and the
            names file found beside the array.
        fps: the frame rate [1/s] when the file stores none (an ``fps`` member of an ``.npz``
            is read as stored here; :func:`imesh.io.read_raw` replaces it with a rate given).

    Returns:
        RawMotion (format "joints") with positions (T, J, 3) float64 in the file's units (NaN
        samples invalid), the names, bones from ``parents`` (none otherwise),
        ``declared_up`` None (detected) and ``rig`` the built-in table the names match.
        ``declared_units`` comes from an ``.npz``'s ``units`` member (None otherwise).

    Raises:
        MotionFileError: unreadable file, wrong shape or dtype, more than :data:`MAX_JOINTS`
            joints, a bad ``parents``.
        JointNamesError: no names, or not one per joint.
        FrameRateMissingError: no frame rate stored or given.
    """
    p = Path(path)
    if not p.is_file():
        raise MotionFileError(str(p), "no such file")
    ext = p.suffix.lower()
    stored_names = parents = None
    units = None
    file_fps = None
    if ext == ".npy":
        try:
            data = np.load(p, allow_pickle=False, mmap_mode="r")
        except (OSError, ValueError, EOFError) as exc:
            raise MotionFileError(str(p), f"not a readable .npy array ({exc}); valid: a (T, J, 3) "
                                  "float array saved by numpy.save") from None
        key = "the array"
    elif ext == ".npz":
        members = load_npz(p, "joint-position .npz",
                           keys=POSITION_KEYS + NAME_KEYS + FPS_KEYS + ("units", "parents"))
        found = next((k for k in POSITION_KEYS if k in members), None)
        if found is None:
            raise MotionFileError(str(p), f"no joint positions: the archive has none of "
                                  f"{', '.join(POSITION_KEYS)}; valid: a (T, J, 3) array under "
                                  "one of these names (AMASS files are told by poses, trans, "
                                  "betas, gender)")
        key = found
        data = members[key]
        stored_names = next((members[k] for k in NAME_KEYS if k in members), None)
        if "units" in members:
            units = str(np.asarray(members["units"]).ravel()[0])
        fps_key = next((k for k in FPS_KEYS if k in members), None)
        if fps_key is not None:
            file_fps = float(np.asarray(members[fps_key]).ravel()[0])
        parents = members.get("parents")
    else:
        raise MotionFileError(str(p), f"extension {ext!r} is not a joint-position file; valid: "
                              f"{', '.join(JOINTS_EXTENSIONS)}")
    if data.ndim != 3 or data.shape[2] != 3 or data.shape[0] < 1 or data.shape[1] < 1:
        raise MotionFileError(str(p), f"{key} has shape {tuple(data.shape)}; valid: (T, J, 3) "
                              "positions, T frames of J joints")
    if not (np.issubdtype(data.dtype, np.floating) or np.issubdtype(data.dtype, np.integer)):
        raise MotionFileError(str(p), f"{key} has dtype {data.dtype}; valid: float or integer "
                              "numbers")
    n_frames, n_joints = int(data.shape[0]), int(data.shape[1])
    if n_joints > MAX_JOINTS:
        raise MotionFileError(str(p), f"{key} has {n_joints} joints; valid: at most {MAX_JOINTS} "
                              "(is the array (T, J, 3)?)")
    names, origin = _names_for(p, joints, stored_names, n_joints)
    if file_fps is not None:  # a rate given replaces it in imesh.io.read_raw
        fps = file_fps
    if fps is None:
        raise FrameRateMissingError(str(p))
    if not (np.isfinite(fps) and fps > 0):
        raise MotionFileError(str(p), f"frame rate {fps!r}; valid: a finite number > 0")
    positions = np.array(data, dtype=np.float64)  # a copy: the mmap is read-only
    valid = np.asarray(np.isfinite(positions).all(axis=2))
    positions[~valid] = np.nan
    bones = (np.zeros((0, 2), dtype=np.int64) if parents is None
             else _bones_from_parents(p, parents, n_joints))
    rig = rig_of(names)
    if not rig and not len(bones):
        log.warning("%s: no built-in rig table knows these joint names (%s) and the file has no "
                    "'parents': pass --rig TABLE.toml to map them", p, _listing(names, 8))
    meta = {"joint_names_from": origin, "joints_key": key}
    log.info("%s: joint positions %d frames x %d joints at %g fps, rig %r, %.1f %% samples "
             "missing", p, n_frames, n_joints, fps, rig or "unknown",
             100.0 * (1.0 - valid.mean()))
    return RawMotion(positions=positions, fps=float(fps), names=names, valid=valid,
                     path=str(p), format="joints", bones=bones, declared_units=units,
                     declared_up=None, rig=rig, meta=meta)
