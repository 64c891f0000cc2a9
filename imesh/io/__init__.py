"""Motion import: BVH, CMU ASF/AMC, C3D, TRC, AMASS (SMPL-H/SMPL-X .npz, with the user's body
model) and joint-position arrays (.npy/.npz with joint names, :mod:`imesh.io.joints`) to
:class:`~imesh.core.motion.MarkerMotion`.

``load_motion(path)`` picks the reader by extension, converts to metres, Z up, floor at z = 0 and
logs each decision (units, up axis, floor) so it can be checked and overridden.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np

from ..core.motion import MarkerMotion
from ..errors import MotionFileError, UnsupportedFormatError
from .amass import _members as npz_members
from .amass import is_amass, read_amass
from .asf_amc import read_asf_amc
from .bvh import read_bvh
from .c3d import read_c3d
from .joints import POSITION_KEYS, read_joint_positions
from .raw import RawMotion
from .trc import read_trc
from .units import UNIT_SCALES_M, UP_AXES, finalize

__all__ = ["load_motion", "read_raw", "finalize", "RawMotion", "UNIT_SCALES_M", "UP_AXES",
           "SUPPORTED_EXTENSIONS"]

SUPPORTED_EXTENSIONS = (".bvh", ".amc", ".c3d", ".trc", ".npz", ".npy")


def _is_joint_positions(path: Path) -> bool:
    """Whether an .npz holds joint positions (a member of :data:`imesh.io.joints.POSITION_KEYS`)."""
    return bool(set(npz_members(path)) & set(POSITION_KEYS))


def read_raw(path: str | os.PathLike, *, asf: str | os.PathLike | None = None,
             fps: float | None = None,
             body_model: str | os.PathLike | None = None,
             joints: str | os.PathLike | None = None) -> RawMotion:
    """Parse a motion file without unit/axis conversion.

    Args:
        path: .bvh, .amc (with its .asf), .c3d, .trc, AMASS .npz or joint-position .npy/.npz
            file.
        asf: skeleton file for .amc input; by default the single .asf in the same folder whose
            name is a prefix of the .amc name (``cmu_07.asf`` for ``cmu_07_05.amc``).
        fps: frame rate for formats that do not store one (AMC; default 120 as in the CMU
            listing; an AMASS file without ``mocap_framerate``; a joint-position file without
            ``fps``, which then needs it); for the others it replaces the file's rate (a wrong
            header), which ``meta["header_fps"]`` keeps.
        body_model: the body-model folder an AMASS file needs (:mod:`imesh.io.amass`).
        joints: the joint-names file of a joint-position array (:mod:`imesh.io.joints`).
    """
    if fps is not None and not (np.isfinite(fps) and fps > 0):
        raise MotionFileError(str(path), f"frame rate {fps!r}; valid: a finite number > 0")
    raw = _read_raw(Path(path), asf=asf, fps=fps, body_model=body_model, joints=joints)
    if fps is not None and raw.fps != fps:
        raw = dataclasses.replace(raw, fps=float(fps), meta={**raw.meta, "header_fps": raw.fps})
    return raw


def _read_raw(p: Path, *, asf, fps, body_model, joints) -> RawMotion:
    if not p.is_file():
        raise MotionFileError(str(p), "no such file")
    ext = p.suffix.lower()
    if ext == ".bvh":
        return read_bvh(p)
    if ext == ".amc":
        return read_asf_amc(p, asf_path=asf, fps=fps)
    if ext == ".c3d":
        return read_c3d(p)
    if ext == ".trc":
        return read_trc(p)
    if ext == ".npy":
        return read_joint_positions(p, joints=joints, fps=fps)
    if ext == ".npz":
        if is_amass(p):
            return read_amass(p, body_model, fps=fps)
        if _is_joint_positions(p):
            return read_joint_positions(p, joints=joints, fps=fps)
        raise UnsupportedFormatError(
            str(p), "an .npz clip must be an AMASS motion (keys poses, trans, betas, gender, "
            "mocap_framerate) or joint positions (keys positions, names, fps: "
            "docs/terrain.md); robot motions are read by imesh evaluate/view/export")
    raise UnsupportedFormatError(
        str(p), f"unsupported extension {ext!r}; valid: {', '.join(SUPPORTED_EXTENSIONS)}"
    )


def load_motion(path: str | os.PathLike, *, units: str | float | None = None,
                up_axis: str | None = None, ground: str | float = "auto",
                fps: float | None = None, asf: str | os.PathLike | None = None,
                check: bool = True,
                body_model: str | os.PathLike | None = None,
                joints: str | os.PathLike | None = None) -> MarkerMotion:
    """Read a motion file into a MarkerMotion (metres, Z up, floor at z = 0).

    Args:
        path: .bvh, .amc, .c3d, .trc, AMASS .npz or joint-position .npy/.npz file.
        units: override the detected unit ("m", "cm", "mm", "in", "cmu") or metres per unit.
        up_axis: override the detected up axis ("+Y", "+Z", ...).
        ground: "auto" (level a floor tilted 0.25-2 degrees under the planted feet, then shift
            to the floor when off by > 3 cm), "none", or a shift in metres.
        fps: frame rate for AMC files, which store none (default 120), for AMASS files
            without one, and for joint-position files without one (required: never guessed);
            for the other formats it replaces the file's rate. When None, a clip whose
            performer cannot keep their balance at the file's rate but can at half of it is
            read at half (:mod:`imesh.human.timing`; ``meta["fps_reason"]`` says why).
        asf: the skeleton for an .amc file (default: found beside it).
        body_model: the folder of SMPL-X/SMPL-H body-model files an AMASS .npz needs
            (docs/amass.md).
        joints: the joint-names file of a joint-position array (default: a names file beside
            it, :mod:`imesh.io.joints`).
        check: run the plausibility checks of :func:`imesh.core.motion.check_plausible` (frame
            rate, body height 0.3-3 m, positions within 1 km, no marker faster than 100 m/s).

    Returns:
        The motion; ``motion.meta`` records every decision taken.

    Raises:
        MotionFileError: the file cannot be read (message names file, line, frame).
        imesh.io.amass.BodyModelError: an AMASS file without a usable body model.
        ImplausibleMotionError: the content cannot be a recording of a person (names the check,
            frame and marker, and the valid range).
    """
    raw = read_raw(path, asf=asf, fps=fps, body_model=body_model, joints=joints)
    return finalize(raw, units=units, up_axis=up_axis, ground=ground, check=check,
                    consume=True, timing=fps is None)
