"""The page's HTTP server against hostile and broken clients, over real sockets: the token (Bearer or
Basic, else 401), the bounds on request heads and clients, a client that never reads, nothing but GET
and HEAD, and no file outside the documentation directory."""

from __future__ import annotations

import base64
import http.client
import os
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from edge.appliance.page.server import MAX_HEAD_BYTES, PageServer, Reply, docs_file, text

TOKEN = "s3cret-token-0123456789"
BIG = os.urandom(4 << 20)  # 4 MiB: more than the kernel buffers a client that never reads


def route(path: str) -> Reply | None:
    if path == "/":
        return text(200, "page")
    if path == "/big":
        return Reply(200, "application/octet-stream", BIG)
    return None


@pytest.fixture
def server(request: pytest.FixtureRequest) -> Iterator[PageServer]:
    token, clients = getattr(request, "param", (None, 4))
    srv = PageServer(("127.0.0.1", 0), route, token, clients)
    thread = threading.Thread(target=srv.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    thread.start()
    yield srv
    srv.shutdown()
    srv.server_close()


def get(srv: PageServer, path: str = "/", headers: dict[str, str] | None = None,
        method: str = "GET") -> tuple[int, bytes, http.client.HTTPResponse]:
    conn = http.client.HTTPConnection("127.0.0.1", srv.server_address[1], timeout=10)
    conn.request(method, path, headers=headers or {})
    r = conn.getresponse()
    body = r.read()
    conn.close()
    return r.status, body, r


def raw(srv: PageServer, data: bytes, timeout_s: float = 10.0) -> bytes:
    with socket.create_connection(("127.0.0.1", srv.server_address[1]), timeout=timeout_s) as s:
        s.sendall(data)
        out = b""
        while chunk := s.recv(65536):
            out += chunk
        return out


def test_serves_read_only_routes(server: PageServer) -> None:
    status, body, r = get(server)
    assert (status, body) == (200, b"page\n")
    assert r.getheader("Cache-Control") == "no-store" and r.getheader("X-Frame-Options") == "DENY"
    assert get(server, "/nothing")[0] == 404
    assert get(server, "/", method="HEAD")[1] == b""
    for method in ("POST", "PUT", "DELETE", "PATCH"):  # nothing can change the daemon
        assert get(server, "/", method=method)[0] == 501


@pytest.mark.parametrize("server", [(TOKEN, 4)], indirect=True)
def test_token(server: PageServer) -> None:
    assert get(server)[0] == 401
    status, _, r = get(server, headers={"Authorization": "Bearer wrong-token-0123456789"})
    assert status == 401 and r.getheader("WWW-Authenticate", "").startswith("Basic realm=")
    basic = base64.b64encode(f"anyone:{TOKEN}x".encode()).decode()
    assert get(server, headers={"Authorization": f"Basic {basic}"})[0] == 401
    assert get(server, headers={"Authorization": "Basic !!notbase64"})[0] == 401
    assert get(server, headers={"Authorization": f"Bearer {TOKEN}"})[0] == 200
    basic = base64.b64encode(f"technician:{TOKEN}".encode()).decode()
    assert get(server, headers={"Authorization": f"Basic {basic}"})[0] == 200
    assert server.counters()["status_401"] == 4


def test_bounded_request_head(server: PageServer) -> None:
    answer = raw(server, b"GET / HTTP/1.1\r\nX: " + b"a" * (2 * MAX_HEAD_BYTES) + b"\r\n\r\n")
    assert answer.startswith(b"HTTP/1.0 431")
    assert raw(server, b"\x16\x03\x01garbage\r\n\r\n").startswith(b"HTTP/1.0 400")
    assert get(server)[0] == 200  # still serving


def test_slow_and_silent_clients_cannot_lock_it_out(server: PageServer) -> None:
    """Four slots, eight connections that send half a head and wait: the oldest is closed for each
    newcomer, and a real request still gets its answer at once."""
    port = server.server_address[1]
    idle = [socket.create_connection(("127.0.0.1", port)) for _ in range(8)]
    for s in idle:
        s.sendall(b"GET / HTTP/1.1\r\n")
    time.sleep(0.3)
    t0 = time.monotonic()
    assert get(server)[0] == 200
    assert time.monotonic() - t0 < 2.0
    assert server.counters().get("evicted_connections", 0) >= 4
    for s in idle:
        s.close()


def test_a_client_that_never_reads_blocks_nothing(server: PageServer) -> None:
    port = server.server_address[1]
    stuck = []
    for _ in range(2):  # asks for 4 MiB, reads none of it
        s = socket.create_connection(("127.0.0.1", port))
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        s.sendall(b"GET /big HTTP/1.0\r\n\r\n")
        stuck.append(s)
    time.sleep(0.5)
    t0 = time.monotonic()
    for _ in range(5):
        assert get(server)[0] == 200
    assert time.monotonic() - t0 < 2.0
    for s in stuck:
        s.close()


def test_docs_files_stay_inside_their_directory(tmp_path: Path) -> None:
    root = tmp_path / "site"
    (root / "page").mkdir(parents=True)
    (root / "index.html").write_text("home")
    (root / "page" / "index.html").write_text("page")
    (tmp_path / "secret.txt").write_text("no")
    (root / ".hidden").write_text("no")
    (root / "link").symlink_to(tmp_path / "secret.txt")
    assert docs_file(root, "") == (root / "index.html").resolve()
    assert docs_file(root, "page/") == (root / "page" / "index.html").resolve()
    assert docs_file(root, "page") == "page/"  # a directory: redirected to its slash
    for bad in ("../secret.txt", "%2e%2e/secret.txt", "page/../../secret.txt", "link", ".hidden",
                "..%2fsecret.txt", "page%00", "%2e%2e%5csecret.txt", "missing.html", "/etc/passwd"):
        assert docs_file(root, bad) is None, bad
