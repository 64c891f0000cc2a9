"""imesh's .npz files: safe reading of any archive, and the marker files imesh writes.

:func:`load_npz` reads every array of an .npz file after checking the archive's declared sizes,
so a corrupt or hostile file raises :class:`~imesh.errors.MotionFileError` instead of a
traceback or a huge allocation. :func:`save_marker_motion` / :func:`load_marker_motion` write
and read adapted markers (.npz or .csv).
"""

from __future__ import annotations

import logging
import math
import os
import struct
import tokenize
import zipfile
import zlib
from collections.abc import Collection
from pathlib import Path

import numpy as np

from ..core.motion import MarkerMotion
from ..errors import InvalidMotionError, MotionFileError, OptionError
from .atomic import atomic_path

log = logging.getLogger(__name__)

#: Largest uncompressed size of an .npz archive :func:`load_npz` accepts [bytes].
MAX_NPZ_BYTES = 1 << 30

def save_marker_motion(path: str | os.PathLike, motion: MarkerMotion) -> None:
    """Save markers as .npz (keys: positions_m (T, M, 3), valid (T, M), names (M,), bones (B, 2),
    fps) or .csv (header: frame, time_s, then ``name.x name.y name.z`` per marker), atomically."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(fh, positions_m=motion.positions_m, valid=motion.valid,
                                names=np.array(motion.names), bones=motion.bones,
                                fps=np.float64(motion.fps), source=np.str_(motion.source))
    elif suffix == ".csv":
        header = ["frame", "time_s"] + [f"{n}.{c}" for n in motion.names for c in "xyz"]
        t = np.arange(motion.n_frames)
        table = np.column_stack([t, t / motion.fps,
                                 motion.positions_m.reshape(motion.n_frames, -1)])
        with atomic_path(path) as tmp:
            np.savetxt(tmp, table, delimiter=",", header=",".join(header), comments="",
                       fmt="%.9g")
    else:
        raise OptionError("output file extension", suffix or path.name, [".npz", ".csv"])


# ----------------------------------------------------------------------------------------------
# reading .npz files safely

#: What reading a corrupt archive can raise (zipfile, zlib, numpy's .npy header parser).
_NPZ_ERRORS = (OSError, EOFError, ValueError, zipfile.BadZipFile, zlib.error,
               NotImplementedError, RuntimeError, struct.error, OverflowError, SyntaxError,
               KeyError, tokenize.TokenError)


def load_npz(path: str | os.PathLike, what: str = ".npz file", *,
             keys: Collection[str] | None = None) -> dict[str, np.ndarray]:
    """Every array of an .npz archive, read after checking what the archive declares.

    Each member must be an ``.npy`` array of a plain (non-object) dtype whose header's shape
    times item size equals the member's size; the archive may hold at most
    :data:`MAX_NPZ_BYTES` uncompressed. Nothing larger than the archive declares is allocated.

    Args:
        path: the file.
        what: what the file should be, for messages ("robot motion .npz").
        keys: read only the members of these names (absent ones are left out of the result);
            the others are neither read nor checked, so an archive may hold arrays of Python
            objects imesh does not need (an AMASS file's ``markers_latent_vids``, a body
            model's ``joint2num``). None: every member.

    Raises:
        MotionFileError: no such file, empty, not a zip archive, corrupt member, object arrays,
            a header that does not match the data.
    """
    p = Path(path)
    if not p.is_file():
        raise MotionFileError(str(p), "no such file")
    if p.stat().st_size == 0:
        raise MotionFileError(str(p), f"empty file (0 bytes): not a readable .npz file "
                              f"({what})")
    try:
        return _read_npz_members(p, what, None if keys is None else set(keys))
    except MotionFileError:
        raise
    except MemoryError:
        raise MotionFileError(str(p), f"not a readable .npz file ({what}): too large to load"
                              ) from None
    except _NPZ_ERRORS as exc:
        raise MotionFileError(str(p), f"not a readable .npz file ({what}; "
                              f"{type(exc).__name__}: {str(exc)[:200]})") from None


def _read_npz_members(p: Path, what: str, keys: set[str] | None) -> dict[str, np.ndarray]:
    fmt = np.lib.format
    out: dict[str, np.ndarray] = {}
    with zipfile.ZipFile(p) as zf:
        infos = zf.infolist()
        if keys is not None:
            infos = [i for i in infos if i.filename.endswith(".npy")
                     and i.filename[:-4] in keys]
        total = sum(i.file_size for i in infos)
        if total > MAX_NPZ_BYTES:
            raise MotionFileError(str(p), f"the archive declares {total} bytes of arrays; at "
                                  f"most {MAX_NPZ_BYTES} are read")
        for info in infos:
            if info.is_dir():
                continue
            if not info.filename.endswith(".npy"):
                raise MotionFileError(str(p), f"member {info.filename!r} is not a .npy array: "
                                      f"not a {what}")
            with zf.open(info) as fh:
                version = fmt.read_magic(fh)
                if version == (1, 0):
                    shape, fortran, dtype = fmt.read_array_header_1_0(fh)
                elif version in ((2, 0), (3, 0)):
                    shape, fortran, dtype = fmt.read_array_header_2_0(fh)
                else:
                    raise MotionFileError(str(p), f"member {info.filename!r}: unknown .npy "
                                          f"version {version}")
                if dtype.hasobject:
                    raise MotionFileError(str(p), f"member {info.filename!r} holds Python "
                                          "objects, which imesh does not load")
                nbytes = math.prod(shape) * dtype.itemsize
                header = fh.tell()
                if nbytes != info.file_size - header:
                    raise MotionFileError(str(p), f"member {info.filename!r} declares shape "
                                          f"{shape} ({nbytes} bytes) but holds "
                                          f"{info.file_size - header} bytes")
                data = fh.read(nbytes)
                if len(data) != nbytes:
                    raise MotionFileError(str(p), f"member {info.filename!r} is truncated")
            array = np.frombuffer(data, dtype=dtype, count=math.prod(shape))
            out[info.filename[:-4]] = array.reshape(shape, order="F" if fortran else "C")
    return out


def load_marker_motion(path: str | os.PathLike) -> MarkerMotion:
    """Read a marker .npz written by :func:`save_marker_motion`.

    Raises:
        MotionFileError: unreadable file, missing keys or arrays that do not form a motion.
    """
    what = "imesh marker file"
    data = load_npz(path, what)
    keys = ("positions_m", "fps", "names", "valid", "bones", "source")
    missing = [k for k in keys if k not in data]
    if missing:
        raise MotionFileError(str(path), f"missing keys {missing}; an {what} has {list(keys)}, "
                              f"this file has {sorted(data)}")
    try:
        return MarkerMotion(positions_m=data["positions_m"], fps=float(data["fps"]),
                            names=tuple(str(n) for n in data["names"].reshape(-1)),
                            valid=data["valid"], bones=data["bones"],
                            source=str(data["source"]))
    except (TypeError, ValueError, InvalidMotionError) as exc:
        raise MotionFileError(str(path), f"not an {what} ({exc})") from None
