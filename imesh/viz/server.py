"""``imesh view`` without ``--html``: the viewer page served on this machine (standard library
HTTP server on 127.0.0.1), the scene fetched as ``/scene.json``."""

from __future__ import annotations

import json
import logging
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

from .html import viewer_html

log = logging.getLogger(__name__)


class ViewerServer:
    """A viewer server running in a background thread.

    Args:
        scene: the scene (:func:`imesh.viz.scene.build_scene`).
        host: address to bind (default loopback only).
        port: TCP port (0: a free one).

    Attributes:
        url: the page's address.
    """

    def __init__(self, scene: dict, host: str = "127.0.0.1", port: int = 0):
        page = viewer_html(None).encode("utf-8")
        data = json.dumps(scene, separators=(",", ":")).encode("utf-8")
        routes: dict[str, tuple[bytes, str]] = {
            "/": (page, "text/html; charset=utf-8"),
            "/index.html": (page, "text/html; charset=utf-8"),
            "/scene.json": (data, "application/json")}

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self):  # noqa: N802 (http.server's name)
                route = routes.get(self.path.split("?")[0])
                if route is None:
                    self.send_error(404)
                    return
                body, kind = route
                self.send_response(200)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, fmt, *args):
                log.debug("viewer server: " + fmt, *args)

        self._httpd = ThreadingHTTPServer((host, port), Handler)
        self._httpd.daemon_threads = True
        h, p = self._httpd.server_address[:2]
        assert isinstance(h, str)  # an AF_INET server's host (typeshed allows bytes for others)
        self.url = f"http://{h}:{p}/"
        self._thread = threading.Thread(target=self._httpd.serve_forever, daemon=True)
        self._thread.start()

    def close(self) -> None:
        """Stop serving."""
        self._httpd.shutdown()
        self._httpd.server_close()

    def __enter__(self) -> ViewerServer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
