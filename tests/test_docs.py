"""The docs site: every python block of the tutorial pages runs (in a folder holding the shared
clips), and ``mkdocs build --strict`` passes."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import data_root

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: Pages whose python blocks are executed (one namespace per page, blocks in order).
TUTORIALS = ("quickstart.md", "clips.md", "evaluating.md", "batch.md", "exports.md",
             "byo-robot.md", "fitting.md", "interaction-mesh.md", "motion-import.md")
_BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def python_blocks(page: str) -> list[str]:
    return _BLOCK.findall((DOCS / page).read_text())


@pytest.mark.parametrize("page", TUTORIALS)
def test_tutorial_code_runs(page, tmp_path, monkeypatch):
    blocks = python_blocks(page)
    assert blocks, f"docs/{page} has no python block"
    for clip in (data_root() / "mocap").iterdir():
        (tmp_path / clip.name).symlink_to(clip)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": f"docs_{page}"}
    for i, block in enumerate(blocks):
        code = compile(block, f"docs/{page} (python block {i + 1})", "exec")
        exec(code, namespace)  # noqa: S102 - the documentation's own examples


def test_every_page_in_nav():
    nav = (ROOT / "mkdocs.yml").read_text()
    missing = [p.name for p in DOCS.glob("*.md") if p.name not in nav]
    assert missing == []


def test_mkdocs_build_strict(tmp_path):
    if shutil.which("mkdocs") is None:
        pytest.importorskip("mkdocs")
    result = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-d",
                             str(tmp_path / "site")], cwd=ROOT, capture_output=True, text=True,
                            timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "site" / "api" / "index.html").is_file()
