"""The screenshot of a pair's viewer page for docs/partners.md.

    imesh retarget cmu_60_10_salsa_partnerA_sl_scaled.bvh --partner \\
        cmu_61_10_salsa_partnerB_sl_scaled.bvh --robot g1 --frames 520:580 -o salsa.npz
    imesh view salsa.pair.json --source --html pair.html
    python docs/partners/screenshot.py pair.html
"""

from __future__ import annotations

import sys
from pathlib import Path

from imesh.viz.browser import chromium_page, open_viewer

HERE = Path(__file__).parent


def main(page_path: Path, frame: int = 45) -> None:
    with chromium_page(1100, 700) as (page, errors):
        open_viewer(page, page_path.resolve().as_uri())
        page.evaluate(f"window.imeshViewer.setFrame({frame})")
        page.screenshot(path=str(HERE / "viewer_pair.png"))
        assert not errors, errors


if __name__ == "__main__":
    main(Path(sys.argv[1]))
