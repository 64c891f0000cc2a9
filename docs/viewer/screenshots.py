"""Screenshots of the demo's viewer page and report for docs/viewer.md.

    imesh demo -o out/demo && python docs/viewer/screenshots.py out/demo
"""

from __future__ import annotations

import sys
from pathlib import Path

from PIL import Image

from imesh.viz.browser import chromium_page, open_viewer

HERE = Path(__file__).parent


def main(demo: Path) -> None:
    with chromium_page(1100, 700) as (page, errors):
        open_viewer(page, (demo / "viewer.html").as_uri())
        page.click("#opt-edges")
        page.evaluate("window.imeshViewer.setFrame(62)")
        page.screenshot(path=str(HERE / "viewer.png"))
        page.set_viewport_size({"width": 1260, "height": 900})
        page.goto((demo / "report.html").as_uri())
        page.wait_for_timeout(2000)
        full = HERE / "report_full.png"
        page.screenshot(path=str(full), full_page=True)
        assert not errors, errors
    img = Image.open(full)
    img.crop((0, 0, 1260, 1650)).save(HERE / "report.png", optimize=True)
    img.crop((0, 1650, 1260, min(img.size[1], 3500))).save(HERE / "report_figures.png",
                                                           optimize=True)
    full.unlink()


if __name__ == "__main__":
    main(Path(sys.argv[1]))
