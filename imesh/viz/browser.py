"""Headless Chromium for screenshots of the viewer (docs, tests, ``imesh view --video``).

Uses Playwright (PyPI ``playwright``) to drive the system's Chromium (Debian ``chromium``); no
browser is downloaded. WebGL runs on SwiftShader (software), so no GPU or display is needed.
"""

from __future__ import annotations

import logging
import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

from ..core.lazy import optional
from ..errors import ImeshError

if TYPE_CHECKING:  # pragma: no cover - typing only (Playwright is the optional viz extra)
    from playwright.sync_api import Page

log = logging.getLogger(__name__)

#: Flags for a headless Chromium on a machine with no GPU and a closed network.
CHROMIUM_ARGS = (
    "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
    "--disable-quic", "--no-first-run", "--disable-background-networking",
    "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage",
)


def find_chromium() -> str | None:
    """Path of a Chromium/Chrome executable (``IMESH_CHROMIUM``, then the PATH), or None."""
    env = os.environ.get("IMESH_CHROMIUM")
    if env:
        return env
    for name in ("chromium", "chromium-browser", "google-chrome", "chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


@contextmanager
def chromium_page(width: int = 1000, height: int = 700) -> Iterator[tuple[Page, list[str]]]:
    """A Playwright page in headless Chromium, and the list its console errors and page errors
    are appended to.

    Raises:
        ImeshError: Playwright or Chromium missing (with the commands that install them).
    """
    sync_playwright = optional("playwright.sync_api", "pip install 'imesh-retarget[viz]'",
                               "a screenshot or video of the viewer").sync_playwright
    exe = find_chromium()
    if exe is None:
        raise ImeshError("screenshots and videos of the viewer need Chromium: "
                         "apt-get install chromium (or set IMESH_CHROMIUM to a Chrome binary)")
    errors: list[str] = []
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=exe, headless=True,
                                     args=list(CHROMIUM_ARGS))
        try:
            page = browser.new_page(viewport={"width": width, "height": height})
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            yield page, errors
        finally:
            browser.close()


def open_viewer(page, url: str, timeout_s: float = 60.0) -> None:
    """Load a viewer page and wait until it has drawn its first frame."""
    page.goto(url)
    page.wait_for_function("window.imeshViewer && window.imeshViewer.ready",
                           timeout=timeout_s * 1e3)
