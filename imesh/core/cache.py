"""imesh's user cache folder: fitted capsules (imesh.robot.capsules) and configurations
generated from URDFs (imesh.robot.generate_files)."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

#: The environment variable naming the cache folder ("" turns the capsule cache off).
CACHE_ENV = "IMESH_CACHE_DIR"


def cache_root() -> Path:
    """``$IMESH_CACHE_DIR``, else ``$XDG_CACHE_HOME/imesh``, else ``~/.cache/imesh``."""
    env = os.environ.get(CACHE_ENV, "").strip()
    if env:
        return Path(env).expanduser()
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "imesh"


def read_cached(kind: str, key: str) -> dict | None:
    """The arrays stored under ``<cache>/<kind>/<key>.npz``, or None when absent or unreadable
    (a damaged file is then simply computed and written again)."""
    path = cache_root() / kind / f"{key}.npz"
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            return {k: data[k] for k in data.files}
    except (OSError, ValueError, KeyError, EOFError):
        return None


def write_cached(kind: str, key: str, **arrays) -> None:
    """Store arrays under ``<cache>/<kind>/<key>.npz`` atomically; a read-only cache folder is
    no error (the next run computes again)."""
    folder = cache_root() / kind
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=".tmp")
        with os.fdopen(fd, "wb") as f:
            np.savez(f, **arrays)
        os.replace(tmp, folder / f"{key}.npz")
    except OSError:
        return
