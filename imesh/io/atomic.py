"""Writing results safely: outputs checked before the work, written atomically, all or none.

Outputs are checked before any work starts (:func:`check_outputs`: extension, the folder exists
and is writable) and written atomically (:func:`atomic_path`: a temporary file renamed onto the
final name), so a failure never leaves a partial file. Inside :func:`output_transaction` (the
command line opens one per command) all outputs of one command are kept together or none: when
the command fails after writing some of them, those are removed again (and files they replaced
are put back). Files get the permissions a plain ``open()`` would give them (the umask).
"""

from __future__ import annotations

import contextlib
import contextvars
import json
import logging
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import OutputPathError

log = logging.getLogger(__name__)

#: Extensions of the output files, by kind.
MOTION_EXTENSIONS = (".npz", ".csv")
JSON_EXTENSIONS = (".json",)
FIGURE_EXTENSIONS = (".png", ".pdf", ".svg")

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
