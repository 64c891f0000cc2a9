"""Shared fixtures: real data from IMESH_DATA (default ../shared/data beside the project)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def data_root() -> Path:
    return Path(os.environ.get("IMESH_DATA", ROOT.parent / "shared" / "data")).resolve()


def mocap_path(name: str) -> Path:
    path = data_root() / "mocap" / name
    if not path.is_file():
        pytest.fail(f"test data {path} not found: set IMESH_DATA to the shared data folder")
    return path


def hrp4c_urdf() -> Path:
    """The HRP-4C URDF beside the shared data (a user-supplied model; never copied here)."""
    path = data_root().parent / "robots" / "hrp4c" / "HRP4Cmain_reduced.urdf"
    if not path.is_file():
        pytest.fail(f"HRP-4C URDF {path} not found: set IMESH_DATA to the shared data folder")
    return path


_ROBOTS: dict = {}


def load_test_robot(name: str):
    """A robot by name, loaded once per session (HRP-4C from :func:`hrp4c_urdf`)."""
    from imesh.robot import load_robot

    if name not in _ROBOTS:
        _ROBOTS[name] = load_robot(name, urdf=hrp4c_urdf() if name == "hrp4c" else None)
    return _ROBOTS[name]


@pytest.fixture(scope="session")
def mocap():
    """Function mocap(name) -> Path of a clip in IMESH_DATA/mocap (fails if absent)."""
    return mocap_path
