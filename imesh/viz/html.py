"""The viewer page: one HTML file with three.js, the viewer script and the scene inlined
(:func:`imesh.viz.scene.build_robots_scene`: one robot or a pair, and the props).

The page needs no server and no network (``imesh view --html``); :mod:`imesh.viz.server`
serves the same page with the scene as ``scene.json``. three.js (MIT) is vendored in
``imesh/viz/static`` (see the README there).
"""

from __future__ import annotations

import json
import os
from importlib import resources
from pathlib import Path

from ..io.atomic import atomic_path

PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title}</title>
<link rel="icon" href="data:,">
<style>
html, body {{ margin: 0; height: 100%; font: 13px/1.35 system-ui, sans-serif; color: #222; }}
body {{ display: flex; flex-direction: column; }}
#bar {{ display: flex; gap: 10px; align-items: center; padding: 6px 10px; background: #fff;
        border-bottom: 1px solid #ddd; flex-wrap: wrap; }}
#bar input[type=range] {{ flex: 1; min-width: 200px; }}
#title {{ font-weight: 600; }}
#view {{ flex: 1; position: relative; min-height: 200px; }}
#view canvas {{ width: 100%; height: 100%; display: block; }}
#info {{ position: absolute; left: 8px; top: 8px; white-space: pre; background: #ffffffcc;
         padding: 4px 6px; border-radius: 4px; pointer-events: none; }}
#info.warn {{ color: #b00; }}
#legend {{ position: absolute; right: 8px; bottom: 8px; background: #ffffffcc; padding: 4px 6px;
           border-radius: 4px; pointer-events: none; }}
#legend span {{ display: inline-block; width: 10px; height: 10px; margin: 0 3px 0 8px; }}
#legend i {{ font-style: normal; }}
button {{ min-width: 56px; }}
#banner {{ padding: 3px 10px; font-weight: 600; }}
#banner.fell {{ background: #fbe1e1; color: #a00; }}
#banner.stood {{ background: #dff3e4; color: #12632a; }}
</style>
</head>
<body>
<div id="bar">
  <span id="title"></span>
  <button id="play">play</button>
  <input id="frame" type="range" min="0" max="0" value="0" step="1" aria-label="frame">
  <span id="label"></span>
  <label>speed <select id="speed"><option>0.25</option><option>0.5</option>
    <option selected>1</option><option>2</option></select></label>
  <label><input id="opt-human" type="checkbox" checked> markers</label>
  <label><input id="opt-edges" type="checkbox"> interaction mesh</label>
  <label><input id="opt-source" type="checkbox" checked> human source</label>
  <label><input id="opt-beside" type="checkbox"> markers beside</label>
  <label><input id="opt-floor" type="checkbox" checked> soles, support, ZMP</label>
  <label><input id="opt-props" type="checkbox" checked> props</label>
  <label><input id="opt-follow" type="checkbox" checked> follow</label>
  <label title="key s"><input id="opt-sim" type="checkbox" checked> DART simulation</label>
  <label><input id="opt-sim-over" type="checkbox"> overlaid</label>
  <button id="to-fall" style="display:none">go to the fall</button>
</div>
<div id="banner"></div>
<div id="view"><div id="info"></div>
<div id="legend"><i id="legend-markers"><span style="background:#1a5af2"></span>adapted markers
</i><i id="legend-source"><span style="background:#8c33bf"></span>human source</i><i id="legend-b">
&nbsp;| robot b's <span style="background:#0f9f8f"></span>markers
<span style="background:#d0407a"></span>source |</i><i id="legend-props">
<span style="background:#c8a165"></span>props</i>
<span style="background:#1aa64d"></span>support polygon
<span style="background:#d91a1a"></span>ZMP <span style="background:#1a73e6"></span>desired ZMP
<span style="background:#f21a1a"></span>self-collision<i id="legend-sim">
<span style="background:#5b8ef0;opacity:0.7"></span>DART simulation
<span style="background:#d94a4a;opacity:0.7"></span>fallen</i></div></div>
<script type="application/json" id="imesh-scene">{scene}</script>
<script>{three}</script>
<script>{viewer}</script>
</body>
</html>
"""


def _static(name: str) -> str:
    return resources.files("imesh.viz").joinpath("static", name).read_text(encoding="utf-8")


def _escape_html(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def viewer_html(scene: dict | None) -> str:
    """The viewer page; ``scene`` (:func:`imesh.viz.scene.build_scene`) inlined, or None for a
    page that loads ``scene.json`` from its server."""
    data = ""
    if scene is not None:
        # "</" cannot close the script element inside a JSON string written as "<\\/"
        data = json.dumps(scene, separators=(",", ":")).replace("</", "<\\/")
    title = _escape_html(scene["title"] if scene else "imesh viewer")
    return PAGE.format(title=title, scene=data, three=_static("three.min.js"),
                       viewer=_static("viewer.js"))


def write_viewer(path: str | os.PathLike, scene: dict) -> Path:
    """Write the self-contained viewer page of ``scene`` to ``path`` (atomically)."""
    with atomic_path(path) as tmp:
        tmp.write_text(viewer_html(scene), encoding="utf-8")
    return Path(path)
