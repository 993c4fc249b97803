"""Test helper: a real pty pair from socat (a virtual null-modem cable) and a reader in another process.

Loaded by path from the serial tests (they live in different directories):
``socat -d -d pty,raw,echo=0,link=A pty,raw,echo=0,link=B`` prints both
/dev/pts paths on stderr; the links give stable paths so socat can be killed
and restarted "at the same port". `start_reader` runs a separate Python
process that reads one end and prints ``[monotonic_s, line]`` JSON per line
(CLOCK_MONOTONIC is system-wide, so its times compare with ours).
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time
from pathlib import Path

READER = r"""
import json, os, select, sys, time
path, idle_s, max_s, xoff = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), sys.argv[4] == "1"
fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
if xoff:
    os.write(fd, b"\x13")  # XOFF: with xonxoff on the other end its writes now block
print(json.dumps(["ready", 0]), flush=True)
start = last = time.monotonic()
buf, got = b"", False
while True:
    ready, _, _ = select.select([fd], [], [], 0.02)
    now = time.monotonic()
    if ready and not xoff:
        try:
            data = os.read(fd, 4096)
        except OSError:
            break
        if not data:
            break
        buf += data
        got, last = True, now
        *lines, buf = buf.split(b"\n")
        for line in lines:
            print(json.dumps([now, (line + b"\n").decode("latin-1")]), flush=True)
    elif (got and now - last > idle_s) or now - start > max_s:
        break
if buf:
    print(json.dumps([time.monotonic(), buf.decode("latin-1")]), flush=True)
"""


class SocatPair:
    """``socat`` joining two ptys; `a` and `b` are stable symlinks to them."""

    def __init__(self, directory: Path) -> None:
        self.a, self.b = str(directory / "ttyA"), str(directory / "ttyB")
        self.proc: subprocess.Popen[str] | None = None
        self.pts: list[str] = []

    def start(self) -> SocatPair:
        self.proc = subprocess.Popen(
            ["socat", "-d", "-d", f"pty,raw,echo=0,link={self.a}", f"pty,raw,echo=0,link={self.b}"],
            stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
        self.pts = []
        deadline = time.monotonic() + 5.0
        while len(self.pts) < 2 and time.monotonic() < deadline:
            line = self.proc.stderr.readline()  # type: ignore[union-attr]
            match = re.search(r"PTY is (\S+)", line)
            if match:
                self.pts.append(match.group(1))
        while not (Path(self.a).exists() and Path(self.b).exists()) and time.monotonic() < deadline:
            time.sleep(0.01)
        assert len(self.pts) == 2, "socat did not report two ptys"
        return self

    def kill(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(5)

    def __enter__(self) -> SocatPair:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.kill()


def start_reader(
    path: str, *, idle_s: float = 1.5, max_s: float = 30.0, xoff: bool = False
) -> subprocess.Popen:
    """A separate process reading `path`; returns once it has opened the port."""
    args = [path, str(idle_s), str(max_s), "1" if xoff else "0"]
    proc = subprocess.Popen([sys.executable, "-c", READER, *args], stdout=subprocess.PIPE, text=True)
    assert json.loads(proc.stdout.readline())[0] == "ready"  # type: ignore[union-attr]
    return proc


def reader_lines(proc: subprocess.Popen, timeout_s: float = 30.0) -> list[tuple[float, str]]:
    """Wait for the reader to finish; its (monotonic time, line) pairs."""
    out, _ = proc.communicate(timeout=timeout_s)
    return [tuple(json.loads(row)) for row in out.splitlines()]  # type: ignore[misc]
