"""Looking at results: the 3D viewer, its self-contained page, videos and the HTML report.

- :func:`~imesh.viz.scene.build_scene`: everything the viewer draws for a robot motion (meshes
  from the URDF, link poses per frame, markers, interaction mesh, soles, support polygon, ZMP,
  self-collisions and limit violations, and the props of its scene);
  :func:`~imesh.viz.scene.build_robots_scene` for several robots in one world (the two of a
  pair, :class:`~imesh.viz.scene.SceneRobot`, :class:`~imesh.viz.scene.PairView`).
- :func:`~imesh.viz.html.write_viewer`: one HTML file with three.js and the scene inlined (no
  server, no network); :class:`~imesh.viz.server.ViewerServer` serves the same page.
- :func:`~imesh.viz.video.write_video`: an mp4 rendered in headless Chromium
  (``pip install 'imesh-retarget[viz]'`` and Debian's ``chromium``).
- :func:`~imesh.viz.report.write_report`: the HTML report of a written motion file;
  :func:`~imesh.viz.report.write_pair_report` of a pair's two files.

Solvers never import this package (tested); its heavy parts import lazily.
"""

from __future__ import annotations

from ..core.lazy import lazy_exports

__getattr__, __dir__ = lazy_exports(__name__, {
    "build_scene": ".scene", "build_robots_scene": ".scene", "SceneRobot": ".scene",
    "PairView": ".scene", "write_viewer": ".html", "viewer_html": ".html",
    "ViewerServer": ".server", "write_video": ".video", "write_report": ".report",
    "write_pair_report": ".report",
}, globals())
__all__ = ["build_scene", "build_robots_scene", "SceneRobot", "PairView", "write_viewer",
           "viewer_html", "ViewerServer", "write_video", "write_report", "write_pair_report"]
