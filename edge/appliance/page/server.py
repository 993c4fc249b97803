"""The page's HTTP server: the standard library's ThreadingHTTPServer, bounded, read-only, with a token.

Why the standard library (docs/decisions.md): the page serves a handful of fixed routes to one or
two technicians and a Prometheus scraper; http.server does that with no new dependency, no event
loop to share with the daemon, and nothing to import while the page is off. Its weak points for a
network-facing service are bounded here:

- clients: at most `max_clients` connections are served at once. When all are taken, the oldest
  connection still sending its request head is closed to make room (a slowloris flood cannot keep
  a technician out: a real client sends its head at once); failing that the new one is closed at
  accept, counted (`refused_connections`), so a flood costs the daemon an accept and a close;
- requests: one request per connection (HTTP/1.0 style, no keep-alive); its head (request line and
  headers) must arrive within `HEAD_TIMEOUT_S` in at most `MAX_HEAD_BYTES`, or the connection gets
  400/431 and is closed; a body is never read; only GET and HEAD exist (others: 501);
- writes: every socket operation times out after `IO_TIMEOUT_S`, so a client that never reads
  holds its slot that long at most; responses are bytes already made (pictures, state), so a slow
  client holds up no one else;
- files: only /docs/ serves files, from one directory, resolved (symlinks followed) and refused
  unless the real path is a regular file inside it; no directory listings;
- auth: with a token, every request needs `Authorization: Bearer TOKEN` or HTTP Basic with the
  token as the password (any user name), compared in constant time; otherwise 401.
Nothing a request does changes the daemon's state: every route reads.
"""

from __future__ import annotations

import base64
import binascii
import hmac
import io
import json
import logging
import mimetypes
import shutil
import socket
import threading
import time
import urllib.parse
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

MAX_HEAD_BYTES = 8192
HEAD_TIMEOUT_S = 5.0
IO_TIMEOUT_S = 5.0
REALM = 'Basic realm="mast-stereo maintenance page", charset="UTF-8"'
STATIC_TYPES = {".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8",
                ".css": "text/css; charset=utf-8", ".json": "application/json", ".png": "image/png",
                ".jpg": "image/jpeg", ".svg": "image/svg+xml", ".ico": "image/x-icon", ".woff2": "font/woff2",
                ".txt": "text/plain; charset=utf-8", ".xml": "application/xml", ".gz": "application/gzip"}
PAGE_HEADERS = {"Cache-Control": "no-store", "X-Content-Type-Options": "nosniff", "X-Frame-Options": "DENY",
                "Referrer-Policy": "no-referrer"}
# the page's own (not the documentation site's, whose theme may need inline scripts)
CSP = ("Content-Security-Policy", "default-src 'self'; img-src 'self'; frame-ancestors 'none'")


@dataclass(frozen=True)
class Reply:
    status: int
    content_type: str
    body: bytes | Path  # a Path is streamed from disk
    headers: tuple[tuple[str, str], ...] = ()


Route = Callable[[str], Reply | None]  # URL path (query removed) -> reply, or None: not found


def text(status: int, message: str) -> Reply:
    return Reply(status, "text/plain; charset=utf-8", (message + "\n").encode())


def json_reply(data: Any) -> Reply:
    return Reply(200, "application/json", json.dumps(data, separators=(",", ":"), allow_nan=False).encode())


def docs_file(root: Path, rel: str) -> Path | str | None:
    """The file under `root` that the URL path `rel` (after /docs/, still %-encoded) names; a str
    is a redirect target (a directory without its slash); None: not served."""
    decoded = urllib.parse.unquote(rel, errors="strict") if "%" in rel else rel
    if "\x00" in decoded or "\\" in decoded:
        return None
    parts = decoded.split("/")
    if any(p in ("..", ".") or p.startswith(".") for p in parts if p):
        return None
    try:
        base = root.resolve(strict=True)
        path = base.joinpath(*[p for p in parts if p])
        if path.is_dir():
            if decoded and not decoded.endswith("/"):
                return rel.rsplit("/", 1)[-1] + "/"
            path = path / "index.html"
        real = path.resolve(strict=True)
    except (OSError, RuntimeError, ValueError):
        return None
    return real if real.is_relative_to(base) and real.is_file() else None


class PageServer(ThreadingHTTPServer):
    """ThreadingHTTPServer with a bound on concurrent clients and the page's counters."""

    daemon_threads = True
    request_queue_size = 64
    allow_reuse_address = True

    def __init__(self, address: tuple[str, int], routes: Route, token: str | None, max_clients: int) -> None:
        self.address_family = socket.AF_INET6 if ":" in address[0] else socket.AF_INET
        self.routes, self.token = routes, token
        self._slots = threading.BoundedSemaphore(max_clients)
        self._lock = threading.Lock()
        self._reading: dict[socket.socket, float] = {}  # connections still sending their head: since
        self.counts: Counter[str] = Counter()
        super().__init__(address, Handler)

    def count(self, what: str) -> None:
        with self._lock:
            self.counts[what] += 1

    def counters(self) -> dict[str, int]:
        with self._lock:
            return dict(self.counts)

    def reading(self, conn: socket.socket, started: bool) -> None:
        with self._lock:
            if started:
                self._reading[conn] = time.monotonic()
            else:
                self._reading.pop(conn, None)

    def _evict(self) -> bool:
        """Close the oldest connection still sending its head; whether there was one."""
        with self._lock:
            if not self._reading:
                return False
            conn = min(self._reading, key=self._reading.__getitem__)
            del self._reading[conn]
            self.counts["evicted_connections"] += 1
        try:
            conn.shutdown(socket.SHUT_RDWR)  # its recv returns at once; its thread frees the slot
        except OSError:
            pass
        return True

    def process_request(self, request: Any, client_address: Any) -> None:
        room = self._slots.acquire(blocking=False) or (self._evict() and self._slots.acquire(timeout=0.2))
        if not room:
            self.count("refused_connections")
            self.shutdown_request(request)
            return
        try:
            super().process_request(request, client_address)  # a thread, which releases the slot
        except Exception:
            self._slots.release()
            raise

    def process_request_thread(self, request: Any, client_address: Any) -> None:
        try:
            super().process_request_thread(request, client_address)
        finally:
            self._slots.release()

    def handle_error(self, request: Any, client_address: Any) -> None:
        self.count("errors")  # a client's broken connection: counted, not a traceback on stderr


class Handler(BaseHTTPRequestHandler):
    server: PageServer
    server_version = "mast-stereo"
    sys_version = ""
    protocol_version = "HTTP/1.0"
    default_request_version = "HTTP/1.0"  # a garbage request line still gets a status line
    timeout = IO_TIMEOUT_S

    def handle(self) -> None:
        self.close_connection = True
        head = self._read_head()
        if head is None:
            return
        self.rfile = io.BytesIO(head)
        self.handle_one_request()

    def _read_head(self) -> bytes | None:
        """The request head within the time and size bounds (else 400/431, connection closed)."""
        conn: socket.socket = self.connection
        self.server.reading(conn, True)
        try:
            return self._receive_head(conn)
        finally:
            self.server.reading(conn, False)

    def _receive_head(self, conn: socket.socket) -> bytes | None:
        buf = b""
        end_s = time.monotonic() + HEAD_TIMEOUT_S
        while b"\r\n\r\n" not in buf and b"\n\n" not in buf:
            left_s = end_s - time.monotonic()
            if left_s <= 0:
                self.server.count("head_timeouts")
                return None
            try:
                conn.settimeout(left_s)
                chunk = conn.recv(4096)
            except OSError:
                self.server.count("head_timeouts")
                return None
            if not chunk:
                self.server.count("incomplete_requests")
                return None
            buf += chunk
            if len(buf) > MAX_HEAD_BYTES:
                self._refuse(431, "request head too large")
                return None
        conn.settimeout(IO_TIMEOUT_S)
        return buf

    def _refuse(self, status: int, message: str) -> None:
        self.server.count(f"status_{status}")
        try:
            self.wfile.write(f"HTTP/1.0 {status} {HTTPStatus(status).phrase}\r\nConnection: close\r\n"
                             f"Content-Length: 0\r\n\r\n".encode())
        except OSError:
            pass

    def send_error(self, code: int, message: str | None = None, explain: str | None = None) -> None:
        self.server.count(f"status_{code}")  # garbage request lines, unknown methods
        super().send_error(code, message, explain)

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - the base class's name
        pass  # counted instead: a flood must not flood the journal

    def _authorised(self) -> bool:
        token = self.server.token
        if token is None:
            return True
        given = self.headers.get("Authorization", "")
        scheme, _, value = given.partition(" ")
        secret = ""
        if scheme.lower() == "bearer":
            secret = value.strip()
        elif scheme.lower() == "basic":
            try:
                secret = base64.b64decode(value.strip(), validate=True).decode("utf-8").partition(":")[2]
            except (binascii.Error, UnicodeDecodeError):
                secret = ""
        return hmac.compare_digest(secret.encode(), token.encode())

    def do_HEAD(self) -> None:
        self._serve(body=False)

    def do_GET(self) -> None:
        self._serve(body=True)

    def _serve(self, body: bool) -> None:
        if not self._authorised():
            self.server.count("status_401")
            self._send(Reply(401, "text/plain; charset=utf-8", b"token needed\n",
                             (("WWW-Authenticate", REALM),)), body)
            return
        path = urllib.parse.urlsplit(self.path).path
        try:
            reply = self.server.routes(path)
        except Exception:  # a bug behind one route must not end the server
            log.exception("page: %s failed", path)
            reply = text(500, "internal error")
        reply = reply or text(404, "not found")
        self.server.count(f"status_{reply.status}")
        self._send(reply, body)

    def _send(self, reply: Reply, body: bool) -> None:
        size = reply.body.stat().st_size if isinstance(reply.body, Path) else len(reply.body)
        self.send_response(reply.status)
        self.send_header("Content-Type", reply.content_type)
        self.send_header("Content-Length", str(size))
        for name, value in (*PAGE_HEADERS.items(), *reply.headers):
            self.send_header(name, value)
        self.end_headers()
        if not body:
            return
        if isinstance(reply.body, Path):
            with reply.body.open("rb") as f:
                shutil.copyfileobj(f, self.wfile, 65536)
        else:
            self.wfile.write(reply.body)


def static_type(path: Path) -> str:
    known = STATIC_TYPES.get(path.suffix.lower()) or mimetypes.guess_type(path.name)[0]
    return known or "application/octet-stream"
