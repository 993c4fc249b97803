"""`Page`: the maintenance page of one running appliance: its routes, its server and encoder threads.

Routes (all read-only, GET and HEAD):

    /                 the page (static/index.html, page.js, page.css)
    /state.json       everything the page shows (edge.appliance.page.state)
    /left.jpg         the latest overlaid left picture (503 until the first one)
    /right.jpg        the same for the right camera
    /metrics          Prometheus text format (edge.appliance.page.metrics)
    /docs/...         the built documentation site (`page.docs_dir`), read-only

The server thread binds at start; if the port is taken (another service), the page logs it once
and retries every `BIND_RETRY_S` without touching processing. `close` stops both threads.
"""

from __future__ import annotations

import logging
import threading
from importlib import resources
from pathlib import Path

from drivers.camera.base import FramePair
from edge.appliance.page.metrics import CONTENT_TYPE, Metrics
from edge.appliance.page.picture import Pictures
from edge.appliance.page.server import CSP, PageServer, Reply, docs_file, json_reply, static_type, text
from edge.appliance.page.state import Watched, page_state
from edge.config.page import PageConfig
from edge.fix import ShipFix

log = logging.getLogger(__name__)

BIND_RETRY_S = 10.0
STATIC = ("index.html", "page.js", "page.css")
NO_DOCS = (b"<!doctype html><title>documentation</title><p>The documentation site is not installed on this "
           b"appliance (page.docs_dir). tools/install puts it in /opt/mast-stereo/docs.</p>")


class Page:
    def __init__(self, app: Watched, cfg: PageConfig, token: str | None) -> None:
        self.app, self.cfg, self.token = app, cfg, token
        self.pictures = Pictures(app.pipeline, app.plan.search_mask, cfg.image_hz, cfg.image_width)
        self.metrics = Metrics(app, self.counters)
        self.docs = None if cfg.docs_dir is None else Path(cfg.docs_dir)
        files = resources.files("edge.appliance.page") / "static"
        self.static = {"/" if name == "index.html" else f"/{name}": (files / name).read_bytes()
                       for name in STATIC}
        self.server: PageServer | None = None
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    @property
    def address(self) -> str:
        host = f"[{self.cfg.host}]" if ":" in self.cfg.host else self.cfg.host
        return f"http://{host}:{self.cfg.port}/"

    # ---------------------------------------------------------------- lifecycle
    def start(self) -> None:
        for name, target in (("page-server", self._serve), ("page-pictures", self.pictures.run)):
            thread = threading.Thread(target=target, args=(self._stop,), name=name, daemon=True)
            thread.start()
            self._threads.append(thread)

    def _serve(self, stop: threading.Event) -> None:
        logged = False
        while not stop.is_set():
            try:
                server = PageServer((self.cfg.host, self.cfg.port), self.route, self.token,
                                    self.cfg.max_clients)
            except OSError as exc:
                if not logged:
                    log.error("maintenance page: cannot listen on %s:%d (retrying every %.0f s): %s",
                              self.cfg.host, self.cfg.port, BIND_RETRY_S, exc)
                    logged = True
                stop.wait(BIND_RETRY_S)
                continue
            self.server = server
            log.info("maintenance page on %s%s", self.address,
                     "" if self.token is None else " (token needed)")
            try:
                server.serve_forever(poll_interval=0.2)
            finally:
                server.server_close()
            return

    def close(self) -> None:
        self._stop.set()
        if self.server is not None:
            self.server.shutdown()
        for thread in self._threads:
            thread.join(timeout=1.0)

    # ---------------------------------------------------------------- processing thread
    def offer(self, pair: FramePair, fixes: list[ShipFix], utc_ns: int) -> None:
        self.pictures.offer(pair, fixes, utc_ns)

    def pipeline_changed(self) -> None:
        """After a reload that rebuilt the pipeline (another rig, site or masks)."""
        self.pictures.pipeline = self.app.pipeline
        self.pictures.search_mask = self.app.plan.search_mask

    # ---------------------------------------------------------------- HTTP threads
    def counters(self) -> dict[str, int]:
        out = {} if self.server is None else self.server.counters()
        return {**out, "pictures": self.pictures.seq, "picture_errors": self.pictures.errors}

    def route(self, path: str) -> Reply | None:
        if path in self.static:
            name = "index.html" if path == "/" else path[1:]
            headers = (CSP,) if path == "/" else ()
            return Reply(200, static_type(Path(name)), self.static[path], headers)
        if path == "/state.json":
            pics = {side: jpeg.seq for side, jpeg in self.pictures.latest.items()}
            return json_reply(page_state(self.app, pics))
        if path in ("/left.jpg", "/right.jpg"):
            jpeg = self.pictures.get(path[1:-4])
            return text(503, "no picture yet") if jpeg is None else Reply(200, "image/jpeg", jpeg.data)
        if path == "/metrics":
            return Reply(200, CONTENT_TYPE, self.metrics.render())
        if path == "/docs":
            return Reply(301, "text/plain; charset=utf-8", b"", (("Location", "/docs/"),))
        if path.startswith("/docs/"):
            return self._docs(path[len("/docs/"):])
        return None

    def _docs(self, rel: str) -> Reply | None:
        if self.docs is None or not self.docs.is_dir():
            return Reply(200, "text/html; charset=utf-8", NO_DOCS) if rel in ("", "index.html") else None
        found = docs_file(self.docs, rel)
        if isinstance(found, str):
            return Reply(301, "text/plain; charset=utf-8", b"", (("Location", found),))
        return None if found is None else Reply(200, static_type(found), found)
