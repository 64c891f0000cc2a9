"""imesh's user cache folder: fitted capsules (imesh.robot.capsules) and configurations
generated from URDFs (imesh.robot.generate_files)."""

from __future__ import annotations

import os
from pathlib import Path

#: The environment variable naming the cache folder ("" turns the capsule cache off).
CACHE_ENV = "IMESH_CACHE_DIR"


def cache_root() -> Path:
    """``$IMESH_CACHE_DIR``, else ``$XDG_CACHE_HOME/imesh``, else ``~/.cache/imesh``."""
    env = os.environ.get(CACHE_ENV, "").strip()
    if env:
        return Path(env).expanduser()
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "imesh"
