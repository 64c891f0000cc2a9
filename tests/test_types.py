"""Static types: mypy passes on imesh/ with the settings in pyproject.toml ([tool.mypy]: no
blanket ignores; untyped third-party libraries listed by name)."""

from __future__ import annotations

from pathlib import Path

from mypy import api  # the test extra: pip install -e '.[test]'

ROOT = Path(__file__).resolve().parents[1]


def test_mypy_passes_on_the_package(monkeypatch):
    monkeypatch.chdir(ROOT)  # the settings and `files` of pyproject.toml
    stdout, stderr, status = api.run(["--config-file", str(ROOT / "pyproject.toml")])
    assert status == 0, f"mypy found errors:\n{stdout}{stderr}"
    assert "no issues found" in stdout
