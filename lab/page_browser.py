"""Open the maintenance page in a real browser: headless Chromium, driven over its DevTools protocol.

`open_page(url)` starts Debian's `chromium` headless with a new empty profile (the flags below keep
it off the network: no updates, no sync, no QUIC), loads the page, waits until each live picture
has loaded `min_loads` times and the track table has rows (or `timeout_s` passes), reads what the
browser shows (picture load counts, the track table's cells, the health state) and saves a PNG
screenshot. The DevTools protocol is spoken over a minimal WebSocket client written here (RFC 6455,
client side: masked text frames out, unmasked frames in), so nothing beyond the standard library is
needed. Used by the browser test (tests/edge/appliance/page) and `tools/page-screenshot`.
"""

from __future__ import annotations

import base64
import json
import os
import shutil
import socket
import struct
import subprocess
import tempfile
import time
import urllib.request
from dataclasses import dataclass
from pathlib import Path
from typing import Any

FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync")
READ_DOM = """JSON.stringify({
  loads: {left: Number(document.getElementById('left').dataset.loads),
          right: Number(document.getElementById('right').dataset.loads)},
  tracks: [...document.querySelectorAll('#tracks tbody tr')]
    .map(tr => [...tr.cells].map(td => td.textContent)),
  state: document.getElementById('state').textContent,
  outputs: document.querySelectorAll('#outputs tbody tr').length,
  stages: document.querySelectorAll('#stages tbody tr').length,
  width: document.getElementById('left').naturalWidth})"""


def chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


class WebSocket:
    """Just enough of a WebSocket client for the DevTools protocol."""

    def __init__(self, url: str, timeout_s: float = 10.0) -> None:
        assert url.startswith("ws://")
        hostport, _, path = url[len("ws://"):].partition("/")
        host, _, port = hostport.partition(":")
        self.sock = socket.create_connection((host, int(port)), timeout=timeout_s)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall(f"GET /{path} HTTP/1.1\r\nHost: {hostport}\r\nUpgrade: websocket\r\n"
                          f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                          "Sec-WebSocket-Version: 13\r\n\r\n".encode())
        head = b""
        while b"\r\n\r\n" not in head:
            chunk = self.sock.recv(4096)
            if not chunk:
                raise ConnectionError("DevTools closed the handshake")
            head += chunk
        head, _, self.pending = head.partition(b"\r\n\r\n")
        if b" 101 " not in head.split(b"\r\n", 1)[0]:
            raise ConnectionError(f"DevTools refused the WebSocket: {head[:200]!r}")

    def _exact(self, n: int) -> bytes:
        while len(self.pending) < n:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise ConnectionError("DevTools closed the connection")
            self.pending += chunk
        out, self.pending = self.pending[:n], self.pending[n:]
        return out

    def send(self, text: str) -> None:
        data = text.encode()
        head = bytes([0x81])
        n = len(data)
        if n < 126:
            head += bytes([0x80 | n])
        elif n < 1 << 16:
            head += bytes([0x80 | 126]) + struct.pack(">H", n)
        else:
            head += bytes([0x80 | 127]) + struct.pack(">Q", n)
        mask = os.urandom(4)
        self.sock.sendall(head + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(data)))

    def recv(self) -> str:
        parts = []
        while True:
            b0, b1 = self._exact(2)
            n = b1 & 0x7F
            if n == 126:
                n = struct.unpack(">H", self._exact(2))[0]
            elif n == 127:
                n = struct.unpack(">Q", self._exact(8))[0]
            payload = self._exact(n)
            opcode = b0 & 0x0F
            if opcode == 8:
                raise ConnectionError("DevTools closed the WebSocket")
            if opcode in (0, 1, 2):
                parts.append(payload)
                if b0 & 0x80:
                    return b"".join(parts).decode()

    def close(self) -> None:
        self.sock.close()


class DevTools:
    """Commands to one page target; events are skipped."""

    def __init__(self, ws: WebSocket) -> None:
        self.ws, self.next_id = ws, 0

    def call(self, method: str, **params: Any) -> dict[str, Any]:
        self.next_id += 1
        self.ws.send(json.dumps({"id": self.next_id, "method": method, "params": params}))
        while True:
            msg = json.loads(self.ws.recv())
            if msg.get("id") == self.next_id:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return dict(msg.get("result", {}))


@dataclass(frozen=True)
class Seen:
    """What the browser showed."""

    loads: dict[str, int]  # picture loads per side
    tracks: list[list[str]]  # the track table's cells
    state: str  # the health state shown
    outputs: int  # rows of the outputs table
    stages: int  # rows of the health stages table
    picture_width: int
    seconds: float


def open_page(url: str, screenshot: Path | None, *, min_loads: int = 3, timeout_s: float = 30.0,
              window: tuple[int, int] = (1200, 900), token: str | None = None) -> Seen:
    """Load `url` in headless Chromium, wait for `min_loads` picture loads per side and track rows,
    save a screenshot; what it showed (RuntimeError if Chromium is missing or does not start)."""
    exe = chromium()
    if exe is None:
        raise RuntimeError("no chromium (apt-get install chromium; tools/_setup.sh does)")
    with tempfile.TemporaryDirectory(prefix="page-browser-") as profile:
        proc = subprocess.Popen([exe, *FLAGS, f"--user-data-dir={profile}", "--remote-debugging-port=0",
                                 f"--window-size={window[0]},{window[1]}", "about:blank"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            return _drive(proc, Path(profile), url, screenshot, min_loads, timeout_s, window, token)
        finally:
            proc.terminate()
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def _drive(proc: subprocess.Popen[bytes], profile: Path, url: str, screenshot: Path | None, min_loads: int,
           timeout_s: float, window: tuple[int, int], token: str | None) -> Seen:
    t0 = time.monotonic()
    port_file = profile / "DevToolsActivePort"
    while not port_file.exists() or not port_file.read_text().strip():
        if proc.poll() is not None or time.monotonic() - t0 > 20:
            raise RuntimeError(f"chromium did not start (exit {proc.poll()})")
        time.sleep(0.1)
    port = int(port_file.read_text().split()[0])
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10) as r:
        targets = json.load(r)
    page = next(t for t in targets if t.get("type") == "page")
    ws = WebSocket(page["webSocketDebuggerUrl"])
    try:
        tools = DevTools(ws)
        tools.call("Emulation.setDeviceMetricsOverride", width=window[0], height=window[1],
                   deviceScaleFactor=1, mobile=False)
        if token is not None:
            tools.call("Network.enable")
            tools.call("Network.setExtraHTTPHeaders", headers={"Authorization": f"Bearer {token}"})
        start = time.monotonic()
        tools.call("Page.navigate", url=url)
        seen: dict[str, Any] = {}
        while time.monotonic() - start < timeout_s:
            time.sleep(0.5)
            got = tools.call("Runtime.evaluate", expression=READ_DOM, returnByValue=True)
            value = got.get("result", {}).get("value")
            if not isinstance(value, str):
                continue
            seen = json.loads(value)
            if min(seen["loads"].values()) >= min_loads and seen["tracks"]:
                break
        elapsed = time.monotonic() - start
        if screenshot is not None:
            shot = tools.call("Page.captureScreenshot", format="png")
            screenshot.parent.mkdir(parents=True, exist_ok=True)
            screenshot.write_bytes(base64.b64decode(shot["data"]))
        try:
            tools.call("Browser.close")
        except (ConnectionError, OSError, RuntimeError):
            pass
    finally:
        ws.close()
    if not seen:
        raise RuntimeError(f"the page never rendered in {timeout_s:.0f} s")
    return Seen(seen["loads"], seen["tracks"], seen["state"], seen["outputs"], seen["stages"], seen["width"],
                elapsed)
