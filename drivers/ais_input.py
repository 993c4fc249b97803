"""AIS input: lines from an AIS receiver (serial at 38400 baud, or UDP datagrams), each stamped
with its receive time, into a bounded queue the tracking side drains without ever blocking.

A reader thread owns the device: it opens it (retrying with exponential backoff up to
MAX_BACKOFF_S while it is absent, counting failures, logging once per outage and once when it
is back, like the serial outputs), reads, splits the bytes into lines, and puts
(receive time ns, line bytes) into a queue of at most `max_lines`; when the queue is full the
oldest line is dropped and counted (a slow consumer loses old AIS, never new). Lines longer
than MAX_LINE_BYTES without an end are cut and counted as overlong.

`SerialAisInput` (pyserial URL: /dev/ttyUSB0, socket://, rfc2217://) and `UdpAisInput` (one or
more lines per datagram; IEC 61162-450 `UdPbC` framing is left to the decoder) are the real
kinds, `VirtualAisInput` the one for tests and the demo: it is fed lines by hand and can be made
to fail. The clock is injectable (`time.time_ns` by default: the fixes are stamped in UTC).
"""

from __future__ import annotations

import abc
import collections
import logging
import socket
import struct
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import serial

log = logging.getLogger(__name__)

MAX_LINE_BYTES = 512
MAX_BACKOFF_S = 5.0
READ_TIMEOUT_S = 0.2


@dataclass(frozen=True, slots=True)
class AisInputStats:
    connected: bool
    fault: str | None  # why the input is not receiving, None while it is
    lines: int  # lines queued since start
    dropped: int  # lines dropped because the queue was full
    overlong: int  # lines cut at MAX_LINE_BYTES
    errors: int  # failed opens and reads
    reconnects: int


class AisInputBase(abc.ABC):
    """Reader thread + bounded drop-oldest queue + reconnect; subclasses open and read."""

    def __init__(self, name: str, max_lines: int = 2000, clock: Callable[[], int] = time.time_ns) -> None:
        self.name, self.clock = name, clock
        self._queue: collections.deque[tuple[int, bytes]] = collections.deque(maxlen=max(1, max_lines))
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._partial = b""
        self._counts = dict.fromkeys(("lines", "dropped", "overlong", "errors", "reconnects"), 0)
        self._connected = False
        self._fault: str | None = "not started"
        self._was_down = False

    def start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name=f"ais-{self.name}", daemon=True)
            self._thread.start()

    def close(self, timeout_s: float = 1.0) -> None:
        self._stop.set()
        self._cancel()
        if self._thread is not None:
            self._thread.join(timeout_s)
        self._close_quietly()

    def drain(self) -> list[tuple[int, bytes]]:
        """Every queued (t_ns, line), oldest first; never blocks."""
        with self._lock:
            out = list(self._queue)
            self._queue.clear()
        return out

    def stats(self) -> AisInputStats:
        with self._lock:
            c = dict(self._counts)
            return AisInputStats(self._connected, self._fault, c["lines"], c["dropped"], c["overlong"],
                                 c["errors"], c["reconnects"])

    # ------------------------------------------------------------ thread
    def _run(self) -> None:
        backoff = 0.1
        while not self._stop.is_set():
            if not self._connected:
                try:
                    self._open()
                except Exception as exc:
                    self._down(f"cannot open: {exc}")
                    self._stop.wait(backoff)
                    backoff = min(MAX_BACKOFF_S, backoff * 2.0)
                    continue
                self._up()
                backoff = 0.1
            try:
                data = self._read()
            except Exception as exc:
                if self._stop.is_set():
                    break
                self._down(f"read failed: {exc}")
                self._close_quietly()
                continue
            if data:
                self._bytes(data, self.clock())

    def _bytes(self, data: bytes, t_ns: int) -> None:
        buf = self._partial + data
        *lines, rest = buf.replace(b"\r", b"\n").split(b"\n")
        while len(rest) > MAX_LINE_BYTES:
            lines.append(rest[:MAX_LINE_BYTES])
            rest = rest[MAX_LINE_BYTES:]
            self._count("overlong")
        self._partial = rest
        for line in lines:
            if len(line) > MAX_LINE_BYTES:
                line = line[:MAX_LINE_BYTES]
                self._count("overlong")
            if line:
                self._put(t_ns, line)

    def _put(self, t_ns: int, line: bytes) -> None:
        with self._lock:
            if len(self._queue) == self._queue.maxlen:
                self._counts["dropped"] += 1
            self._queue.append((t_ns, line))
            self._counts["lines"] += 1

    def _count(self, key: str) -> None:
        with self._lock:
            self._counts[key] += 1

    def _down(self, why: str) -> None:
        with self._lock:
            self._counts["errors"] += 1
            first = not self._was_down
            self._connected, self._fault, self._was_down = False, why, True
        if first:
            log.warning("AIS input %s: %s (retrying, logged once)", self.name, why)

    def _up(self) -> None:
        with self._lock:
            back = self._was_down
            if back:
                self._counts["reconnects"] += 1
            self._connected, self._fault, self._was_down = True, None, False
        if back:
            log.info("AIS input %s is back", self.name)

    def _close_quietly(self) -> None:
        try:
            self._close_port()
        except Exception:  # closing a port already gone
            pass
        with self._lock:
            self._connected = False

    # ------------------------------------------------------------ subclass hooks
    @abc.abstractmethod
    def _open(self) -> None: ...

    @abc.abstractmethod
    def _read(self) -> bytes:
        """Some bytes (b"" after READ_TIMEOUT_S without any); raise when the device is gone."""

    @abc.abstractmethod
    def _close_port(self) -> None: ...

    def _cancel(self) -> None:  # noqa: B027  (a hook: most kinds need nothing)
        """Unblock a read in progress (called from another thread)."""


class SerialAisInput(AisInputBase):
    def __init__(self, url: str, baud: int = 38400, **kwargs) -> None:
        super().__init__(url, **kwargs)
        self.url, self.baud = url, baud
        self._port: serial.SerialBase | None = None

    def _open(self) -> None:
        self._port = serial.serial_for_url(self.url, baudrate=self.baud, timeout=READ_TIMEOUT_S)

    def _read(self) -> bytes:
        port = self._port
        if port is None:
            raise OSError("port closed")
        return port.read(max(1, port.in_waiting or 1))

    def _close_port(self) -> None:
        if self._port is not None:
            self._port.close()
            self._port = None

    def _cancel(self) -> None:
        port = self._port
        if port is not None and hasattr(port, "cancel_read"):
            try:
                port.cancel_read()
            except Exception:  # not every URL handler supports it
                pass


class UdpAisInput(AisInputBase):
    def __init__(self, port: int, host: str = "0.0.0.0", group: str | None = None, **kwargs) -> None:
        super().__init__(f"udp:{port}", **kwargs)
        self.port, self.host, self.group = port, host, group
        self._sock: socket.socket | None = None

    def _open(self) -> None:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((self.host if self.group is None else "", self.port))
        if self.group is not None:
            mreq = struct.pack("4s4s", socket.inet_aton(self.group), socket.inet_aton(self.host))
            sock.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, mreq)
        sock.settimeout(READ_TIMEOUT_S)
        self._sock = sock

    def _read(self) -> bytes:
        sock = self._sock
        if sock is None:
            raise OSError("socket closed")
        try:
            data = sock.recv(65535)
        except TimeoutError:
            return b""
        self._partial = b""  # a datagram holds whole lines: none continues into the next
        return data + b"\n"

    def _close_port(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None


class VirtualAisInput(AisInputBase):
    """Fed by `push`; `set_present(False)` makes it fail like an unplugged receiver."""

    def __init__(self, name: str = "virtual", **kwargs) -> None:
        super().__init__(name, **kwargs)
        self._pending: collections.deque[bytes] = collections.deque()
        self._present = True
        self._wake = threading.Event()

    def push(self, data: bytes) -> None:
        self._pending.append(data)
        self._wake.set()

    def set_present(self, present: bool) -> None:
        self._present = present
        self._wake.set()

    def _open(self) -> None:
        if not self._present:
            raise OSError("no such device")

    def _read(self) -> bytes:
        if not self._present:
            raise OSError("device gone")
        if not self._pending:
            self._wake.wait(READ_TIMEOUT_S)
            self._wake.clear()
        return self._pending.popleft() if self._pending else b""

    def _close_port(self) -> None:
        pass

    def _cancel(self) -> None:
        self._wake.set()
