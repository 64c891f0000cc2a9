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
             "byo-robot.md", "fitting.md", "interaction-mesh.md", "motion-import.md",
             "partners.md")
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
    site = tmp_path / "site"
    assert (site / "api" / "index.html").is_file()
    # offline: no script, style or font from another host in any page or local stylesheet
    external = re.compile(r"""<(?:script|link|img|iframe)\b[^>]*\b(?:src|href)\s*=\s*["']?"""
                          r"""(?:https?:)?//""", re.I)
    css_url = re.compile(r"""url\(\s*["']?(?:https?:)?//|@import\s+["']?(?:https?:)?//""", re.I)
    pages = sorted(site.rglob("*.html"))
    assert len(pages) > 25
    found = [f"{p.relative_to(site)}: {m[0]}" for p in pages
             for m in external.finditer(p.read_text())]
    found += [f"{c.relative_to(site)}: {m[0]}" for c in site.rglob("*.css")
              for m in css_url.finditer(c.read_text())]
    inline = re.compile(r"<script\b[^>]*>(.*?)</script>", re.S | re.I)
    found += [f"{p.relative_to(site)}: inline script loads {u}" for p in pages
              for body in inline.findall(p.read_text())
              for u in re.findall(r"https?://[^\s'\"]+", body)]
    assert found == [], found[:10]
    # the equations are MathML (no TeX left for a script to typeset)
    method = (site / "method" / "index.html").read_text()
    assert method.count("<math") >= 20 and 'class="arithmatex"' not in method
