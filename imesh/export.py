"""Writing results, and reading the .npz files imesh writes.

Outputs are checked before any work starts (:func:`check_outputs`: extension, the folder exists
and is writable) and written atomically (:func:`atomic_path`: a temporary file renamed onto the
final name), so a failure never leaves a partial file. Inside :func:`output_transaction` (the
command line opens one per command) all outputs of one command are kept together or none: when
the command fails after writing some of them, those are removed again (and files they replaced
are put back). Files get the permissions a plain ``open()`` would give them (the umask).

:func:`load_npz` reads every array of an .npz file after checking the archive's declared sizes,
so a corrupt or hostile file raises :class:`~imesh.errors.MotionFileError` instead of a
traceback or a huge allocation.
"""

from __future__ import annotations

import contextlib
import contextvars
import json
import logging
import math
import os
import stat
import struct
import tempfile
import tokenize
import zipfile
import zlib
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import MotionFileError, OptionError, OutputPathError
from .motion import MarkerMotion

log = logging.getLogger(__name__)

#: Extensions of the output files, by kind.
MOTION_EXTENSIONS = (".npz", ".csv")
JSON_EXTENSIONS = (".json",)
FIGURE_EXTENSIONS = (".png", ".pdf", ".svg")
#: Largest uncompressed size of an .npz archive :func:`load_npz` accepts [bytes].
MAX_NPZ_BYTES = 1 << 30


# ----------------------------------------------------------------------------------------------
# output paths, checked before the work


@dataclass(frozen=True)
class Output:
    """One output of a command.

    Attributes:
        path: where it goes.
        option: the option that named it (``-o``, ``--json``, ``--plots``...), for messages.
        extensions: valid file extensions (lower case, with the dot); empty for a folder.
        folder: True when the output is a folder (created if missing; its parent must exist).
    """

    path: str | os.PathLike
    option: str = ""
    extensions: Sequence[str] = ()
    folder: bool = False


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _probe_writable(folder: Path, output: Output) -> None:
    """Create and remove a file in ``folder`` (the only check that is right for root, ACLs and
    read-only mounts alike)."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".imesh-probe-", dir=folder)
    except OSError as exc:
        raise OutputPathError(output.path, f"folder {str(folder)!r} is not writable "
                              f"({exc.strerror or exc})", option=output.option,
                              valid="a path in a folder you can write") from None
    os.close(fd)
    os.unlink(tmp)


def check_output(output: Output) -> list[Path]:
    """Check one output before the work; returns the folders that do not exist yet and will be
    created (the output folder itself).

    Raises:
        OutputPathError: wrong extension, an existing folder where a file goes (or a file where
            a folder goes), a parent folder that is missing or is a file, or not writable.
    """
    path = Path(output.path)
    text = str(output.path)
    if not text or text.endswith(("/", os.sep)) and not output.folder:
        raise OutputPathError(text, "no file name", option=output.option,
                              valid="a file name ending in " + ", ".join(output.extensions))
    if output.folder:
        if path.exists() and not path.is_dir():
            raise OutputPathError(text, "exists and is not a folder", option=output.option,
                                  valid="a folder (created if missing)")
        target = path if path.is_dir() else path.parent
        created = [] if path.is_dir() else [path]
    else:
        suffix = path.suffix.lower()
        if output.extensions and suffix not in output.extensions:
            raise OutputPathError(text, f"extension {suffix or '(none)'!r} not supported",
                                  option=output.option, valid=", ".join(output.extensions))
        if path.is_dir():
            raise OutputPathError(text, "is a folder", option=output.option,
                                  valid="a file name inside an existing folder")
        target = path.parent
        created = []
    target = target if str(target) else Path(".")
    if not target.exists():
        raise OutputPathError(text, f"folder {str(target)!r} does not exist",
                              option=output.option, valid="a path in an existing folder "
                              "(create it first)")
    if not target.is_dir():
        raise OutputPathError(text, f"{str(target)!r} is a file, not a folder",
                              option=output.option, valid="a path in an existing folder")
    _probe_writable(target, output)
    return created


def check_outputs(outputs: Iterable[Output]) -> None:
    """Check every output of a command before it starts (see :func:`check_output`); two outputs
    naming the same file are refused too. Folders that will be created are registered with the
    current :func:`output_transaction`, which removes them again (when empty) if the command
    fails."""
    seen: dict[str, Output] = {}
    tx = _TRANSACTION.get()
    for output in outputs:
        if output.path is None or str(output.path) == "":
            continue
        key = os.path.abspath(str(output.path))
        if key in seen:
            raise OutputPathError(output.path, f"also given as {seen[key].option}",
                                  option=output.option, valid="a different file per output")
        seen[key] = output
        created = check_output(output)
        if tx is not None:
            tx.created_dirs.extend(created)


# ----------------------------------------------------------------------------------------------
# atomic writes, all outputs of a command together


@dataclass
class _Transaction:
    installed: list[tuple[Path, Path | None]] = field(default_factory=list)
    created_dirs: list[Path] = field(default_factory=list)

    def install(self, tmp: Path, final: Path) -> None:
        backup = None
        if final.is_file():
            fd, name = tempfile.mkstemp(prefix=f".{final.name}.", suffix=".bak",
                                        dir=final.parent)
            os.close(fd)
            backup = Path(name)
            os.replace(final, backup)
        try:
            os.replace(tmp, final)
        except OSError:
            if backup is not None:
                os.replace(backup, final)
            raise
        self.installed.append((final, backup))

    def commit(self) -> None:
        for _, backup in self.installed:
            if backup is not None:
                with contextlib.suppress(OSError):
                    backup.unlink()

    def rollback(self) -> None:
        for final, backup in reversed(self.installed):
            with contextlib.suppress(OSError):
                if backup is not None:
                    os.replace(backup, final)
                else:
                    final.unlink()
            log.info("removed %s: the command failed", final)
        for folder in reversed(self.created_dirs):
            with contextlib.suppress(OSError):
                for leftover in folder.glob("*"):  # files written straight into the folder
                    if leftover.is_file():
                        leftover.unlink()
                folder.rmdir()


_TRANSACTION: contextvars.ContextVar[_Transaction | None] = contextvars.ContextVar(
    "imesh_output_transaction", default=None)


@contextlib.contextmanager
def output_transaction() -> Iterator[None]:
    """All files written through :func:`atomic_path` inside this block are kept together: if the
    block raises, they are removed (files they replaced are restored) and folders registered by
    :func:`check_outputs` are removed when empty."""
    tx = _Transaction()
    token = _TRANSACTION.set(tx)
    try:
        yield
    except BaseException:
        tx.rollback()
        raise
    else:
        tx.commit()
    finally:
        _TRANSACTION.reset(token)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` only on success.

    Missing parent folders are created. The file gets the permissions of the file it replaces,
    or ``0o666`` less the umask. Inside :func:`output_transaction` the file is removed again if
    the transaction fails.

    Raises:
        OutputPathError: the folder cannot be created or written, or writing failed (an
            OSError of the body).
    """
    final = Path(path)
    parent = final.parent if str(final.parent) else Path(".")
    tx = _TRANSACTION.get()
    try:
        missing = [p for p in [parent, *parent.parents] if not p.exists()]
        parent.mkdir(parents=True, exist_ok=True)
        if tx is not None:
            tx.created_dirs.extend(reversed(missing))
        fd, tmp = tempfile.mkstemp(prefix=f".{final.name}.", suffix=final.suffix or ".tmp",
                                   dir=parent)
    except OSError as exc:
        raise OutputPathError(final, f"cannot write into {str(parent)!r} "
                              f"({exc.strerror or exc})",
                              valid="a path in a folder you can write") from None
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        try:
            yield tmp_path
        except OSError as exc:
            raise OutputPathError(final, f"writing failed ({exc.strerror or exc})") from None
        try:
            mode = (stat.S_IMODE(final.stat().st_mode) if final.is_file()
                    else 0o666 & ~_umask())
            os.chmod(tmp_path, mode)
            if tx is not None:
                tx.install(tmp_path, final)
            else:
                os.replace(tmp_path, final)
        except OSError as exc:
            raise OutputPathError(final, f"cannot rename the written file into place "
                                  f"({exc.strerror or exc})") from None
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


# ----------------------------------------------------------------------------------------------
# writers


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def write_json(path: str | os.PathLike, data: dict) -> None:
    """Write ``data`` as indented JSON, atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(_jsonable(data), indent=2, allow_nan=True) + "\n")


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


def load_npz(path: str | os.PathLike, what: str = ".npz file") -> dict[str, np.ndarray]:
    """Every array of an .npz archive, read after checking what the archive declares.

    Each member must be an ``.npy`` array of a plain (non-object) dtype whose header's shape
    times item size equals the member's size; the archive may hold at most
    :data:`MAX_NPZ_BYTES` uncompressed. Nothing larger than the archive declares is allocated.

    Args:
        path: the file.
        what: what the file should be, for messages ("robot motion .npz").

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
        return _read_npz_members(p, what)
    except MotionFileError:
        raise
    except MemoryError:
        raise MotionFileError(str(p), f"not a readable .npz file ({what}): too large to load"
                              ) from None
    except _NPZ_ERRORS as exc:
        raise MotionFileError(str(p), f"not a readable .npz file ({what}; "
                              f"{type(exc).__name__}: {str(exc)[:200]})") from None


def _read_npz_members(p: Path, what: str) -> dict[str, np.ndarray]:
    fmt = np.lib.format
    out: dict[str, np.ndarray] = {}
    with zipfile.ZipFile(p) as zf:
        infos = zf.infolist()
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
    from .errors import InvalidMotionError

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
