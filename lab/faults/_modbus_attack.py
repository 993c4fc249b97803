"""Hostile Modbus TCP traffic and an independent probe, for the `modbus-hostile` fault case.

Everything here speaks raw MBAP over sockets, written from the Modbus spec (no pymodbus on the
client side, so the server is checked by something that does not share its bugs):

- `Probe`: a thread reading a few input registers every `period_s` on its own connection, as a
  PLC would, recording each answer's latency and any wrong value, timeout or error;
- `malformed_frames(n, rng)`: n frames mixing random bytes, wrong MBAP lengths and protocol ids,
  odd unit ids, illegal and diagnostic functions, writes, bad counts, and frames cut short;
- `blast`, `crowd`, `non_readers`, `silent`: the attacks, bounded in count and time, on
  127.0.0.1 only. They run in the probe's and the server's process, so the probe's latency
  includes the attackers' share of the GIL (as the daemon's processing thread would take it);
- `open_fds` / `thread_names`: what a leak would show.
"""

from __future__ import annotations

import asyncio
import os
import random
import socket
import struct
import threading
import time
from dataclasses import dataclass, field

HOST = "127.0.0.1"
WRITE_FUNCTIONS = (5, 6, 15, 16, 22, 23)
OTHER_FUNCTIONS = (0, 7, 8, 11, 12, 17, 20, 21, 24, 43, 0x41, 0x64, 0x7F, 0x81, 0xFF)


def mbap(tid: int, unit: int, pdu: bytes, length: int | None = None, protocol: int = 0) -> bytes:
    """One MBAP frame; `length` (default: the true one) and `protocol` may be made wrong."""
    n = len(pdu) + 1 if length is None else length
    return struct.pack(">HHHB", tid & 0xFFFF, protocol, n & 0xFFFF, unit & 0xFF) + pdu


def read_request(tid: int, fc: int, address: int, count: int, unit: int = 1) -> bytes:
    return mbap(tid, unit, struct.pack(">BHH", fc, address, count))


def write_pdu(fc: int, rng: random.Random) -> bytes:
    """A well-formed write request PDU of function `fc` (all are refused by a read-only server)."""
    address = rng.randrange(0, 800)
    if fc in (5, 6):
        return struct.pack(">BHH", fc, address, rng.choice((0xFF00, 0, rng.randrange(0x10000))))
    if fc == 15:
        return struct.pack(">BHHB", fc, address, 8, 1) + bytes([rng.randrange(256)])
    if fc == 16:
        return struct.pack(">BHHB", fc, address, 2, 4) + rng.randbytes(4)
    if fc == 22:
        return struct.pack(">BHHH", fc, address, 0xFFFF, 0)
    return struct.pack(">BHHHHB", fc, 0, 2, address, 1, 2) + rng.randbytes(2)  # 23


def malformed_frames(n: int, rng: random.Random) -> list[bytes]:
    """n hostile frames, the kinds in rotation (see the module docstring)."""
    frames = []
    for i in range(n):
        kind = i % 8
        if kind == 0:
            frames.append(rng.randbytes(rng.randrange(1, 300)))
        elif kind == 1:  # right header, lying length
            length = rng.choice((0, 1, 2, 255, 300, 0xFFFF))
            frames.append(mbap(i, 1, struct.pack(">BHH", 4, 0, 10), length=length))
        elif kind == 2:  # wrong protocol id
            frames.append(mbap(i, 1, struct.pack(">BHH", 4, 0, 10), protocol=rng.randrange(1, 0x10000)))
        elif kind == 3:  # any unit id, including broadcast 0 and 255
            frames.append(read_request(i, 4, 0, 10, unit=rng.choice((0, 2, 247, 248, 255))))
        elif kind == 4:
            fc = rng.choice(OTHER_FUNCTIONS)
            frames.append(mbap(i, 1, bytes([fc]) + rng.randbytes(rng.randrange(0, 8))))
        elif kind == 5:
            frames.append(mbap(i, 1, write_pdu(rng.choice(WRITE_FUNCTIONS), rng)))
        elif kind == 6:  # counts and addresses out of range
            count = rng.choice((0, 126, 2000))
            frames.append(read_request(i, rng.choice((3, 4)), rng.randrange(0x10000), count))
        else:  # a good request cut short
            good = read_request(i, 4, 0, 10)
            frames.append(good[: rng.randrange(1, len(good))])
    return frames


def recv_exact(sock: socket.socket, n: int) -> bytes:
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            raise ConnectionError("server closed the connection")
        data += chunk
    return data


def transact(sock: socket.socket, frame: bytes) -> tuple[int, bytes]:
    """Send one frame, return (function code of the answer, rest of its PDU)."""
    sock.sendall(frame)
    _tid, _pid, length, _unit = struct.unpack(">HHHB", recv_exact(sock, 7))
    body = recv_exact(sock, length - 1)
    return body[0], body[1:]


@dataclass
class Probe:
    """An independent client polling `count` input registers from `address` (see module docstring)."""

    port: int
    expected: list[int]  # the registers it must read back
    address: int = 0
    period_s: float = 0.01
    timeout_s: float = 1.0
    latencies_s: list[float] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._stop = threading.Event()
        self._sock = socket.create_connection((HOST, self.port), timeout=self.timeout_s)
        self._thread = threading.Thread(target=self._run, name="modbus probe", daemon=True)

    def start(self) -> Probe:
        self._thread.start()
        return self

    def mark(self) -> int:
        """The number of answers so far, to cut the latencies into phases."""
        return len(self.latencies_s)

    def _run(self) -> None:
        tid = 0
        while not self._stop.is_set():
            tid += 1
            t0 = time.perf_counter()
            try:
                fc, body = transact(self._sock, read_request(tid, 4, self.address, len(self.expected)))
            except (OSError, struct.error) as exc:
                self.problems.append(f"read {tid}: {type(exc).__name__}: {exc}")
                return
            self.latencies_s.append(time.perf_counter() - t0)
            values = list(struct.unpack(f">{len(self.expected)}H", body[1:])) if fc == 4 else None
            if values != self.expected:
                self.problems.append(f"read {tid}: function {fc}, values {values}")
            self._stop.wait(self.period_s)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(5)
        self._sock.close()


async def _drain(reader: asyncio.StreamReader) -> None:
    try:
        while await reader.read(65536):
            pass
    except OSError:
        pass


async def _answered(reader: asyncio.StreamReader, tid: int, timeout_s: float) -> bool:
    """Read answers until the one to transaction `tid`; False if it does not come in time."""
    try:
        async with asyncio.timeout(timeout_s):
            while True:
                head = await reader.readexactly(7)
                await reader.readexactly(max(0, struct.unpack(">H", head[4:6])[0] - 1))
                if struct.unpack(">H", head[:2])[0] == tid:
                    return True
    except (TimeoutError, asyncio.IncompleteReadError, OSError):
        return False


def well_framed_tid(frame: bytes) -> int | None:
    """The transaction id of a frame the server must answer (complete MBAP, protocol 0, true
    length, a function code), else None (the server may drop it)."""
    if len(frame) < 8:
        return None
    tid, protocol, length = struct.unpack(">HHH", frame[:6])
    return tid if protocol == 0 and length == len(frame) - 6 and 2 <= length <= 254 else None


async def blast(port: int, frames: list[bytes], connections: int = 10) -> tuple[int, int, int]:
    """Send the frames one at a time, so the server handles every frame on its own: a well-framed
    one must be answered (data or an exception); after any other, a valid read must be answered,
    and when two are not (the stream is out of step) the client reconnects, as a real one would.
    Returns (frames sent, well-framed frames left unanswered, reconnects)."""

    async def one(part: list[bytes]) -> tuple[int, int, int]:
        reader, writer = await asyncio.open_connection(HOST, port)
        marker, unanswered, reconnects = 0xF000, 0, 0
        for frame in part:
            writer.write(frame)
            tid = well_framed_tid(frame)
            if tid is not None:
                await writer.drain()
                if await _answered(reader, tid, 0.5):
                    continue
                unanswered += 1
            await writer.drain()
            await asyncio.sleep(0.001)  # a separate segment: a dropped frame should not take the read along
            for _ in range(2):
                marker = 0xF000 + (marker + 1) % 0x1000  # tids the frames themselves do not use
                writer.write(read_request(marker, 4, 0, 1))
                await writer.drain()
                if await _answered(reader, marker, 0.015):
                    break
            else:
                writer.close()
                reader, writer = await asyncio.open_connection(HOST, port)
                reconnects += 1
        writer.close()
        return len(part), unanswered, reconnects

    results = await asyncio.gather(*(one(frames[i::connections]) for i in range(connections)))
    return tuple(sum(r[k] for r in results) for k in range(3))  # type: ignore[return-value]


async def crowd(port: int, clients: int, seconds: float, expected: list[int], period_s: float = 0.05
                ) -> tuple[int, int]:
    """`clients` concurrent readers polling every `period_s` for `seconds` (50 clients at 20 Hz:
    ten times a busy SCADA's load); returns (right answers, wrong answers)."""
    until = time.monotonic() + seconds

    async def one(i: int) -> tuple[int, int]:
        reader, writer = await asyncio.open_connection(HOST, port)
        good = bad = 0
        tid = 0
        while time.monotonic() < until:
            tid += 1
            writer.write(read_request(tid, 4, 0, len(expected), unit=i % 248))
            head = await reader.readexactly(7)
            body = await reader.readexactly(struct.unpack(">H", head[4:6])[0] - 1)
            ok = body[0] == 4 and list(struct.unpack(f">{len(expected)}H", body[2:])) == expected
            good, bad = good + ok, bad + (not ok)
            await asyncio.sleep(period_s)
        writer.close()
        return good, bad

    results = await asyncio.gather(*(one(i) for i in range(clients)))
    return sum(g for g, _ in results), sum(b for _, b in results)


def non_readers(port: int, clients: int, seconds: float) -> int:
    """Clients that keep asking for 125 registers and never read; returns how many the server closed."""
    socks = []
    for _ in range(clients):
        s = socket.socket()
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # before connect: a small window
        s.connect((HOST, port))
        s.setblocking(False)
        socks.append(s)
    request = read_request(1, 4, 0, 125)  # one at a time, as a poller sends them
    closed: set[int] = set()
    until = time.monotonic() + seconds
    while time.monotonic() < until and len(closed) < clients:
        for k, s in enumerate(socks):
            if k in closed:
                continue
            try:
                s.send(request)
            except BlockingIOError:
                pass  # our own send buffer is full: the server stopped reading us too
            except OSError:
                closed.add(k)
        time.sleep(0.001)
    for s in socks:
        s.close()
    return len(closed)


def silent(port: int, clients: int, gap_s: float = 0.001) -> list[socket.socket]:
    """Clients that connect and send nothing, `gap_s` apart (the caller closes them)."""
    socks = []
    for _ in range(clients):
        socks.append(socket.create_connection((HOST, port)))
        time.sleep(gap_s)  # a burst, not one GIL-holding loop: the probe shares this process
    return socks


def wait_closed(socks: list[socket.socket], seconds: float) -> int:
    """How many of `socks` the server closed (EOF) within `seconds`."""
    closed: set[int] = set()
    until = time.monotonic() + seconds
    for s in socks:
        s.settimeout(0.05)
    while time.monotonic() < until and len(closed) < len(socks):
        for k, s in enumerate(socks):
            if k in closed:
                continue
            try:
                if s.recv(1) == b"":
                    closed.add(k)
            except TimeoutError:
                pass
            except OSError:
                closed.add(k)
    return len(closed)


def open_fds() -> int:
    return len(os.listdir("/proc/self/fd"))


def thread_names() -> list[str]:
    return sorted(t.name for t in threading.enumerate())


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else float("nan")
