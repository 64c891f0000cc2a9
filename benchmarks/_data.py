"""Where benchmarks find the shared data and the robots (IMESH_DATA, default ../shared/data)."""

from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def data_root() -> Path:
    return Path(os.environ.get("IMESH_DATA", ROOT.parent / "shared" / "data")).resolve()


def load(name: str):
    """A robot by name (HRP-4C from the shared URDF, as a user-supplied model)."""
    from imesh.robot import load_robot

    urdf = data_root().parent / "robots" / "hrp4c" / "HRP4Cmain_reduced.urdf"
    return load_robot(name, urdf=urdf if name == "hrp4c" else None)
