"""Serial test rig: a real pty pair from socat (a virtual null-modem cable), a reader in another
process, and the step-rate measurement used to show that a bad port never slows processing.

Shared by the serial tests and the `lab.faults` serial cases (so `tools/faults` can run them
outside pytest). ``socat -d -d pty,raw,echo=0,link=A pty,raw,echo=0,link=B`` prints both
/dev/pts paths on stderr; the links give stable paths so socat can be killed and restarted "at
the same port". `start_reader` runs a separate Python process that reads one end and prints
``[monotonic_s, line]`` JSON per line (CLOCK_MONOTONIC is system-wide, so its times compare
with ours); with `xoff` it sends XOFF and does not read, and with `xon_after_s` it sends XON
that long after starting, prints ``["xon", monotonic_s]`` and reads from then on. `step_times` runs
processing-like steps publishing to an output and returns each step's duration, so a test
compares a faulty output's step rate with a healthy one's in the same run (a ratio, never an
absolute time). No shell is involved: socat and the reader get argument lists.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from edge.fix import ShipFix, TrackStatus

T0_NS = 1_780_000_000 * 10**9
SITE_LAT, SITE_LON = 53.54, 9.96

READER = r"""
import json, os, select, sys, time
path, idle_s, max_s, xoff = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), sys.argv[4] == "1"
xon_after_s = float(sys.argv[5])
fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
if xoff:
    os.write(fd, b"\x13")  # XOFF: with xonxoff on the other end its writes now block
print(json.dumps(["ready", 0]), flush=True)
start = last = time.monotonic()
buf, got = b"", False
while True:
    ready, _, _ = select.select([fd], [], [], 0.02)
    now = time.monotonic()
    if xoff and 0 <= xon_after_s <= now - start:
        os.write(fd, b"\x11")  # XON: the writer may send again; from now on read
        print(json.dumps(["xon", now]), flush=True)
        xoff, last = False, now
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
    path: str, *, idle_s: float = 1.5, max_s: float = 30.0, xoff: bool = False,
    xon_after_s: float = -1.0,
) -> subprocess.Popen:
    """A separate process reading `path`; returns once it has opened the port."""
    args = [path, str(idle_s), str(max_s), "1" if xoff else "0", str(xon_after_s)]
    proc = subprocess.Popen([sys.executable, "-c", READER, *args], stdout=subprocess.PIPE, text=True)
    assert json.loads(proc.stdout.readline())[0] == "ready"  # type: ignore[union-attr]
    return proc


def reader_lines(proc: subprocess.Popen, timeout_s: float = 30.0) -> list[tuple[Any, Any]]:
    """Wait for the reader to finish; its (monotonic time, line) pairs."""
    out, _ = proc.communicate(timeout=timeout_s)
    return [(row[0], row[1]) for row in map(json.loads, out.splitlines())]


def fix(track_id: int, t_s: float, status: TrackStatus = TrackStatus.TRACKING, **kw: object) -> ShipFix:
    """Track `track_id` at time `t_s`: a ship 1-5 km out, moving; all fields plausible."""
    range_m = 1000.0 + 97.0 * (track_id % 40) + 3.0 * t_s
    bearing = (17.0 * track_id + 0.1 * t_s) % 360.0
    north, east = range_m * math.cos(math.radians(bearing)), range_m * math.sin(math.radians(bearing))
    values = dict(
        t_ns=T0_NS + int(t_s * 1e9), track_id=track_id, status=status, x_m=east, y_m=0.0, z_m=north,
        range_m=range_m, bearing_deg=bearing, lat_deg=SITE_LAT + north / 111_320.0,
        lon_deg=SITE_LON + east / (111_320.0 * math.cos(math.radians(SITE_LAT))), sog_kn=9.5,
        cog_deg=(bearing + 90.0) % 360.0, sigma_m=4.0, disparity_px=3.0,
    )  # fmt: skip
    values.update(kw)
    return ShipFix(**values)  # type: ignore[arg-type]


def step_times(
    publish: Callable[[Sequence[ShipFix]], object], seconds: float, t_offset: float, tracks: int = 20
) -> tuple[list[float], float]:
    """Run processing steps (~2 ms of numpy + `tracks` fixes to `publish`) for `seconds`.

    Returns each step's duration and the longest single publish() call.
    """
    rng = np.random.default_rng(0)
    durations: list[float] = []
    longest_publish_s, start = 0.0, time.perf_counter()
    while (t := time.perf_counter()) - start < seconds:
        np.sort(rng.random(80_000))  # stands in for matching and triangulation
        fixes = [fix(i, t_offset + len(durations) / 30) for i in range(1, tracks + 1)]
        before = time.perf_counter()
        publish(fixes)
        longest_publish_s = max(longest_publish_s, time.perf_counter() - before)
        durations.append(time.perf_counter() - t)
    return durations, longest_publish_s
