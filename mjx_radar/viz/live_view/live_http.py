"""The live view's HTTP routes (standard library ``http.server``; docs/viewer.md).

``/`` the page, ``/plotly.min.js`` the plotly.js of the installed ``plotly`` package
(offline, no CDN), ``/figure.json`` the initial figure, ``/state.json?trial=J&since=SEQ``
the layers at the latest step of trial position J; answered from a
:class:`mjx_radar.viz.live_view.live.LiveView` (``page_bytes``, ``figure_bytes``, ``state_bytes``).
"""

from __future__ import annotations

import functools
from http.server import BaseHTTPRequestHandler
from urllib.parse import parse_qs, urlsplit


@functools.cache
def plotly_js() -> bytes:
    from plotly.offline import get_plotlyjs

    return get_plotlyjs().encode()


def handler(live):
    """The request handler class of ``live`` (a :class:`~mjx_radar.viz.live_view.live.LiveView`)."""

    class Handler(BaseHTTPRequestHandler):
        def do_GET(self):  # noqa: N802 (http.server's name)
            url = urlsplit(self.path)
            q = parse_qs(url.query)
            try:
                if url.path in ("/", "/index.html"):
                    body, kind = live.page_bytes, "text/html; charset=utf-8"
                elif url.path == "/plotly.min.js":
                    body, kind = plotly_js(), "application/javascript"
                elif url.path == "/figure.json":
                    body, kind = live.figure_bytes(), "application/json"
                elif url.path == "/state.json":
                    j, since = int(q.get("trial", ["0"])[0]), int(q.get("since", ["-1"])[0])
                    step = int(q["step"][0]) if "step" in q else None
                    if not 0 <= j < len(live.trials):
                        raise ValueError(j)
                    body, kind = live.state_bytes(j, since, step), "application/json"
                else:
                    self.send_error(404)
                    return
            except ValueError:
                self.send_error(400)
                return
            self.send_response(200)
            self.send_header("Content-Type", kind)
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args):  # quiet: the progress bar owns stderr
            pass

    return Handler
