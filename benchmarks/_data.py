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


def write_and_read(out: Path, stem: str, result, robot):
    """Write a retarget result as ``imesh retarget`` does (``OUT/STEM.npz`` and the adapted
    markers ``OUT/STEM_markers.npz``) and read the motion back, so benchmarks score the written
    file. Returns (the motion read back, the markers' path)."""
    from imesh.export import save_marker_motion
    from imesh.robot_motion import load_robot_motion, save_robot_motion

    path, markers = out / f"{stem}.npz", out / f"{stem}_markers.npz"
    save_robot_motion(path, result.motion)
    save_marker_motion(markers, result.adapted)
    return load_robot_motion(path, robot), markers
