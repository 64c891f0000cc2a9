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


@pytest.fixture(scope="session")
def mocap():
    """Function mocap(name) -> Path of a clip in IMESH_DATA/mocap (fails if absent)."""
    return mocap_path
