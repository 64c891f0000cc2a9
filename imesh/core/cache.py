"""imesh's user cache folder: fitted proxies and capsules, built robot models
(imesh.robot.model_cache) and configurations generated from URDFs (imesh.robot.generate_files).

Every entry is an ``.npz`` of plain arrays (read with ``allow_pickle=False``), written atomically
(:func:`write_cached`), keyed by a hash of what it is computed from; an entry that
does not read is computed and written again, never trusted.
"""

from __future__ import annotations

import logging
import os
import tempfile
import zipfile
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

#: The environment variable naming the cache folder ("" turns the capsule and robot caches off).
CACHE_ENV = "IMESH_CACHE_DIR"

#: What a damaged or foreign cache file raises when read (it is then computed again).
READ_ERRORS = (OSError, ValueError, KeyError, IndexError, TypeError, EOFError,
               zipfile.BadZipFile)


def cache_root() -> Path:
    """``$IMESH_CACHE_DIR``, else ``$XDG_CACHE_HOME/imesh``, else ``~/.cache/imesh``."""
    env = os.environ.get(CACHE_ENV, "").strip()
    if env:
        return Path(env).expanduser()
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "imesh"


def cache_enabled() -> bool:
    """False when ``$IMESH_CACHE_DIR`` is set to an empty string (no capsule or robot cache)."""
    env = os.environ.get(CACHE_ENV)
    return env is None or bool(env.strip())


def cache_file(kind: str, key: str) -> Path:
    """``<cache>/<kind>/<key>.npz``."""
    return cache_root() / kind / f"{key}.npz"


def read_cached(kind: str, key: str) -> dict | None:
    """The arrays stored under ``<cache>/<kind>/<key>.npz``, or None when absent or unreadable
    (a damaged file is then simply computed and written again)."""
    path = cache_file(kind, key)
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            return {k: data[k] for k in data.files}
    except READ_ERRORS as exc:
        log.warning("cache file %s unreadable (%s): computing it again", path, exc)
        return None


def write_cached(kind: str, key: str, **arrays) -> None:
    """Store arrays under ``<cache>/<kind>/<key>.npz`` atomically: a temporary file in the same
    folder renamed into place, so that concurrent processes never read a partial file (the
    scheme of :func:`imesh.io.atomic.atomic_path`, which core/ may not import, without its
    output transaction: a cache entry stays when the command fails later). A read-only cache
    folder is no error (the next run computes again)."""
    path = cache_file(kind, key)
    tmp: str | None = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=".tmp", dir=path.parent)
        with os.fdopen(fd, "wb") as f:
            np.savez(f, **arrays)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
        tmp = None
    except OSError as exc:
        log.debug("cache file %s not written: %s", path, exc)
    finally:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
