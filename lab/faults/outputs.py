"""Fault cases for the outputs: a serial port that goes and comes back, a reader that stops reading,
and hostile Modbus TCP clients.

Each case drives the real output code (`edge.outputs.nmea_serial` over a socat pty pair; the
`drivers.modbus` TCP server on 127.0.0.1) against real peers in other processes or raw
sockets, and reports rows for `tools/faults`:

- `serial-gone`: the pty's far end (socat) is killed for 2 s and started again at the same
  path; the output must report "serial port lost" (health DEGRADED, fault code 42), keep
  publishing without blocking, and deliver checksummed sentences again after the port is back.
- `serial-stalled`: the reader stops reading (XOFF flow control, and a plain reader that
  stops draining the pty); processing steps must keep their rate, measured as a ratio to a
  healthy output in the same run, and sentences flow again once the reader resumes.
- `modbus-hostile`: 10 000 malformed frames, 50 concurrent clients, clients that never read
  and clients that never speak, more clients than allowed; an independent probe must keep
  getting the right registers within 50 ms, writes must be refused with exception 02 and
  other functions with 01, and threads and file descriptors must return to their count.
"""

from __future__ import annotations

import asyncio
import random
import shutil
import struct
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from drivers.modbus import ModbusTcpServer, TcpLimits
from lab.faults import _modbus_attack as attack
from lab.faults._rig import free_port
from lab.faults._serial import serial_gone, serial_stalled
from lab.faults.matrix import Case, Row

LATENCY_BOUND_S = 0.050


def _image() -> list[int]:
    """A register image with a recognisable pattern (the probe checks its first ten words)."""
    return [(0x1357 * a + 11) & 0xFFFF for a in range(740)]


def _phase_rows(probe: attack.Probe, start: int, fault: str, extra: str) -> Row:
    lat = probe.latencies_s[start:]
    p99, worst = attack.percentile(lat, 0.99), max(lat, default=float("nan"))
    ok = bool(lat) and p99 <= LATENCY_BOUND_S and not probe.problems
    observed = (f"{len(lat)} probe reads, p99 {1e3 * p99:.1f} ms, max {1e3 * worst:.1f} ms; {extra}"
                + (f"; {probe.problems[0]}" if probe.problems else ""))
    return Row(fault, f"valid reads answered, p99 <= {1e3 * LATENCY_BOUND_S:.0f} ms", observed, ok)


def _refusals(port: int, image: list[int]) -> tuple[bool, str]:
    """Each write function answered 02 and each other function 01, on a fresh connection; then
    the whole image read back unchanged."""
    import socket

    rng, wrong = random.Random(1), []
    with socket.create_connection(("127.0.0.1", port), timeout=2.0) as sock:
        for tid, fc in enumerate(attack.WRITE_FUNCTIONS, start=1):
            got, body = attack.transact(sock, attack.mbap(tid, 1, attack.write_pdu(fc, rng)))
            if (got, body[:1]) != (fc | 0x80, b"\x02"):
                wrong.append(f"write {fc}: {got:#x} {body[:1].hex()}")
        for tid, fc in enumerate((7, 8, 11, 12, 17, 20, 21, 24, 43, 0x41), start=100):
            args = {8: struct.pack(">HH", 4, 0), 43: b"\x0e\x01\x00"}.get(fc, b"")  # listen-only; device id
            pdu = bytes([fc]) + args
            got, body = attack.transact(sock, attack.mbap(tid, 1, pdu))
            if (got, body[:1]) != (fc | 0x80, b"\x01"):
                wrong.append(f"function {fc}: {got:#x} {body[:1].hex()}")
        for tid, start in enumerate(range(0, len(image), 125), start=200):
            count = min(125, len(image) - start)
            got, body = attack.transact(sock, attack.read_request(tid, 4, start, count))
            if got != 4 or list(struct.unpack(f">{count}H", body[1:])) != image[start:start + count]:
                wrong.append(f"registers {start}..{start + count - 1} changed")
    return not wrong, "; ".join(wrong) or "6 write functions -> 02, 10 other functions -> 01, image intact"


def modbus_hostile(_workdir: Path) -> list[Row]:
    limits = TcpLimits(max_clients=64, idle_timeout_s=1.0, max_unread_bytes=16384)
    image = _image()
    rows: list[Row] = []
    fds0, threads0 = attack.open_fds(), attack.thread_names()
    server = ModbusTcpServer("127.0.0.1", free_port(), limits)
    server.update(image)
    server.start()
    probe = attack.Probe(server.port, image[:10]).start()
    try:
        t0, mark = time.monotonic(), probe.mark()
        frames = attack.malformed_frames(10_000, random.Random(15))
        framed = sum(attack.well_framed_tid(f) is not None for f in frames)
        sent, unanswered, reconnects = asyncio.run(attack.blast(server.port, frames))
        stats = server.stats
        row = _phase_rows(probe, mark, f"{sent} malformed frames, one by one",
                          f"{time.monotonic() - t0:.1f} s; {framed - unanswered}/{framed} well-framed "
                          "answered; "
                          f"garbage {stats.garbage}, writes refused {stats.writes}, reconnects {reconnects}")
        rows.append(replace(row, passed=row.passed and unanswered == 0))
        ok, text = _refusals(server.port, image)
        rows.append(Row("writes and other functions", "writes 02, others 01, image unchanged",
                        text, ok and server.stats.writes > 0))
        mark = probe.mark()
        good, bad = asyncio.run(attack.crowd(server.port, 50, 2.0, image[:10]))
        row = _phase_rows(probe, mark, "50 concurrent clients at 20 Hz, 2 s",
                          f"{good} crowd reads right, {bad} wrong")
        rows.append(replace(row, passed=row.passed and bad == 0 and good >= 1000))
        mark = probe.mark()
        t0 = time.monotonic()
        quiet = attack.silent(server.port, 10)
        closed_readers = attack.non_readers(server.port, 10, 4.0)
        closed_quiet = attack.wait_closed(quiet, 3.0)
        for s in quiet:
            s.close()
        stats = server.stats
        row = _phase_rows(probe, mark, "10 never read + 10 never speak",
                          f"closed: unread {stats.unread_closed}, idle {stats.idle_closed}")
        rows.append(replace(row, passed=row.passed and closed_readers == 10 and closed_quiet == 10,
                            recovery_s=time.monotonic() - t0))
        mark = probe.mark()
        flood = attack.silent(server.port, 80)
        refused = attack.wait_closed(flood, 1.0)
        for s in flood:
            s.close()
        row = _phase_rows(probe, mark, "80 connections, limit 64",
                          f"{refused} closed at once, refused_clients {server.stats.refused_clients}")
        rows.append(replace(row, passed=row.passed and refused >= 16))
    finally:
        probe.stop()
        deadline = time.monotonic() + 5.0
        while server.stats.clients and time.monotonic() < deadline:
            time.sleep(0.05)
        server.stop()
    time.sleep(0.1)
    fds1, threads1 = attack.open_fds(), attack.thread_names()
    rows.append(Row("after the attacks", "threads and fds back to their counts",
                    f"fds {fds0} -> {fds1}, threads {len(threads0)} -> {len(threads1)}",
                    fds1 == fds0 and threads1 == threads0))
    return rows


def _needs_socat(run: Callable[[Path], list[Row]]) -> Callable[[Path], list[Row]]:
    def case(workdir: Path) -> list[Row]:
        if shutil.which("socat") is None:
            return [Row(run.__name__, "", "", False, skipped="socat not installed (tools/test installs it)")]
        return list(run(workdir))

    return case


CASES = [
    Case("serial-gone", "outputs", _needs_socat(serial_gone)),
    Case("serial-stalled", "outputs", _needs_socat(serial_stalled)),
    Case("modbus-hostile", "outputs", modbus_hostile),
]
