"""Serial output ports: a writer thread behind a bounded queue, so a port can never stall its caller.

Used for NMEA 0183 output. The caller (the processing thread) only ever calls
`submit()`, which never blocks: when the queue is full the oldest message is
dropped and counted. A writer thread owns the port and:

- opens it (a pyserial URL: ``/dev/ttyS1``, ``loop://``, ``socket://host:port``,
  ``spy:///dev/ttyS1``); if it is absent, or is lost later (unplugged, EIO,
  the pty's peer gone), it retries with exponential backoff, counts every
  failure, sets the `fault` flag and logs once per outage (not every retry),
  and logs once more when the port is back;
- writes with a timeout: a port stalled by flow control (XOFF, CTS low) or by
  nobody reading costs only this thread's time; each timeout is counted and
  the `stalled` flag stays set until a write succeeds. A timed-out write may
  have sent part of its message; the receiver's checksum rejects that line.

Input (optional, `read_lines=True`; issue 18's ACN acknowledgements): between writes the same
thread reads what the peer sent, splits it into lines (CR/LF) and keeps at most `MAX_RECEIVED`
of them (oldest dropped, counted) for the caller's `received()`; a line longer than
`MAX_LINE_BYTES` is garbage, dropped and counted. A read failure is a port loss like a write's.

`PySerialPort` is the real implementation, `VirtualSerialPort` an in-memory
one for tests and the demo (records bytes, simulates stalls and port loss).
"""

from __future__ import annotations

import abc
import collections
import errno
import logging
import threading
from dataclasses import dataclass
from typing import Any

import serial

log = logging.getLogger(__name__)
MAX_LINE_BYTES = 164  # an input line longer than two NMEA sentences is garbage
MAX_RECEIVED = 64  # input lines kept for the caller


class PortStalled(Exception):
    """A write did not complete within the write timeout (flow control or nobody reading)."""


@dataclass(frozen=True, slots=True)
class PortStats:
    """Counters of one port since it was created."""

    connected: bool  # the port is open
    fault: bool  # the port is absent or lost; retrying
    stalled: bool  # the last write timed out
    submitted: int  # messages handed to submit()
    written_messages: int
    written_bytes: int
    dropped: int  # messages dropped: queue full (oldest first) or lost with the port
    write_timeouts: int
    errors: int  # failed opens and failed writes
    reconnects: int  # times the port came back after a fault
    queued: int
    received_lines: int = 0  # input lines handed to received() (read_lines)
    received_dropped: int = 0  # input lines dropped: too long, or not collected in time


class SerialPortBase(abc.ABC):
    """Bounded drop-oldest queue + writer thread + reconnect with backoff; subclasses do the I/O."""

    def __init__(
        self, name: str, *, queue_max: int = 32, retry_initial_s: float = 0.2, retry_max_s: float = 5.0,
        read_lines: bool = False,
    ) -> None:
        if queue_max < 1:
            raise ValueError(f"queue_max must be >= 1, got {queue_max}")
        if not 0 < retry_initial_s <= retry_max_s:
            raise ValueError(f"need 0 < retry_initial_s <= retry_max_s, got {retry_initial_s}, {retry_max_s}")
        self.name = name
        self.queue_max = queue_max
        self.retry_initial_s = retry_initial_s
        self.retry_max_s = retry_max_s
        self._queue: collections.deque[bytes] = collections.deque()
        self._cond = threading.Condition()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._connected = False
        self._fault = False
        self._stalled = False
        keys = ("submitted", "written_messages", "written_bytes", "dropped", "write_timeouts", "errors")
        self._counts = dict.fromkeys((*keys, "reconnects", "received_lines", "received_dropped"), 0)
        self.read_lines = read_lines
        self._partial = bytearray()  # input after the last line end
        self._lines: collections.deque[str] = collections.deque()

    # -- the caller's side (never blocks) ---------------------------------------------------
    def submit(self, data: bytes) -> bool:
        """Queue one message; returns False if the oldest queued message had to be dropped."""
        with self._cond:
            self._counts["submitted"] += 1
            room = len(self._queue) < self.queue_max
            if not room:
                self._queue.popleft()
                self._counts["dropped"] += 1
            self._queue.append(bytes(data))
            self._cond.notify()
        return room

    def start(self) -> None:
        """Start the writer thread (it opens the port itself, retrying until it is there)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name=f"serial-writer {self.name}", daemon=True)
            self._thread.start()

    def close(self, timeout_s: float = 2.0, *, drain: bool = False) -> None:
        """Stop the writer thread (unblocking a stalled write) and close the port.

        With `drain`, first give the writer up to `timeout_s` to empty the queue (a log file at
        shutdown); what is still queued after that is counted as dropped.
        """
        if drain and self._thread is not None:
            with self._cond:
                self._cond.wait_for(lambda: not self._queue, timeout_s)
        with self._cond:
            self._counts["dropped"] += len(self._queue) if drain else 0
        self._stop.set()
        with self._cond:
            self._cond.notify_all()
        self._cancel()
        if self._thread is not None:
            self._thread.join(timeout_s)
        self._close_quietly()

    def received(self) -> list[str]:
        """The input lines read since the last call (without their line ends), oldest first."""
        with self._cond:
            lines, self._lines = list(self._lines), collections.deque()
        return lines

    @property
    def healthy(self) -> bool:
        """True while the port is open and writes complete."""
        return self._connected and not self._fault and not self._stalled

    def stats(self) -> PortStats:
        with self._cond:
            return PortStats(
                connected=self._connected,
                fault=self._fault,
                stalled=self._stalled,
                queued=len(self._queue),
                **self._counts,
            )

    # -- the writer thread ------------------------------------------------------------------
    def _run(self) -> None:
        delay_s = self.retry_initial_s
        while not self._stop.is_set():
            if not self._connected:
                try:
                    self._open()
                except Exception as exc:  # any open failure means: retry later
                    self._failed("open", exc)
                    self._stop.wait(delay_s)
                    delay_s = min(2 * delay_s, self.retry_max_s)
                    continue
                delay_s = self.retry_initial_s
                self._up()
            if self.read_lines:
                try:
                    self._take_input(self._read())
                except Exception as exc:  # a lost port, as for a write
                    self._failed("read", exc)
                    self._close_quietly()
                    continue
            data = self._next(timeout_s=0.2)
            if data is None:
                continue
            try:
                self._write(data)
            except PortStalled:
                self._count("write_timeouts")
                if not self._stalled:
                    log.warning("serial port %s stalled: write timed out", self.name)
                self._stalled = True
            except Exception as exc:  # a lost port must never end the thread
                if self._stop.is_set():
                    break
                self._count("dropped")
                self._failed("write", exc)
                self._close_quietly()
            else:
                with self._cond:
                    self._counts["written_messages"] += 1
                    self._counts["written_bytes"] += len(data)
                    self._cond.notify_all()  # a draining close() waits for the queue to empty
                if self._stalled:
                    log.info("serial port %s writes again", self.name)
                self._stalled = False
        self._close_quietly()

    def _next(self, timeout_s: float) -> bytes | None:
        with self._cond:
            if not self._queue:
                self._cond.wait(timeout_s)
            return self._queue.popleft() if self._queue else None

    def _take_input(self, data: bytes) -> None:
        """Split received bytes into lines; keep the last MAX_RECEIVED, drop over-long ones."""
        if not data:
            return
        self._partial += data
        *done, rest = self._partial.replace(b"\r", b"\n").split(b"\n")
        self._partial = bytearray(rest)
        with self._cond:
            if len(self._partial) > MAX_LINE_BYTES:  # no line end in sight: garbage
                self._partial.clear()
                self._counts["received_dropped"] += 1
            for raw in done:
                if not raw:
                    continue
                if len(raw) > MAX_LINE_BYTES:
                    self._counts["received_dropped"] += 1
                    continue
                if len(self._lines) >= MAX_RECEIVED:
                    self._lines.popleft()
                    self._counts["received_dropped"] += 1
                self._lines.append(raw.decode("ascii", errors="replace"))
                self._counts["received_lines"] += 1

    def _count(self, key: str) -> None:
        with self._cond:
            self._counts[key] += 1

    def _failed(self, what: str, exc: BaseException) -> None:
        self._count("errors")
        if not self._fault:
            log.warning("serial port %s unavailable (%s: %s); retrying with backoff", self.name, what, exc)
        self._fault = True

    def _up(self) -> None:
        self._connected = True
        if self._fault:
            self._count("reconnects")
            log.info("serial port %s is back after %d errors in all", self.name, self._counts["errors"])
        self._fault = False
        self._stalled = False

    def _close_quietly(self) -> None:
        self._connected = False
        try:
            self._close_port()
        except Exception:  # closing a lost port may fail again
            pass

    # -- subclass hooks (called from the writer thread, except _cancel) ---------------------
    @abc.abstractmethod
    def _open(self) -> None:
        """Open the port; raise if it is not there."""

    @abc.abstractmethod
    def _write(self, data: bytes) -> None:
        """Write all of `data`; raise PortStalled on timeout, anything else on port loss."""

    @abc.abstractmethod
    def _close_port(self) -> None:
        """Close the port (may be called when it is already closed)."""

    @abc.abstractmethod
    def _cancel(self) -> None:
        """Unblock a write in progress (called from close(), another thread)."""

    def _read(self) -> bytes:
        """What the peer sent since the last call, without waiting (only with read_lines)."""
        return b""


class PySerialPort(SerialPortBase):
    """A real port through pyserial's ``serial_for_url``; baud rate and framing configurable."""

    def __init__(
        self,
        url: str,
        *,
        baudrate: int = 38400,
        bytesize: int = 8,
        parity: str = "N",
        stopbits: float = 1,
        xonxoff: bool = False,
        rtscts: bool = False,
        write_timeout_s: float = 1.0,
        **base: Any,
    ) -> None:
        super().__init__(url, **base)
        if bytesize not in serial.Serial.BYTESIZES:
            raise ValueError(f"bytesize must be one of {serial.Serial.BYTESIZES}, got {bytesize}")
        if parity not in serial.Serial.PARITIES:
            raise ValueError(f"parity must be one of {serial.Serial.PARITIES}, got {parity!r}")
        if stopbits not in serial.Serial.STOPBITS:
            raise ValueError(f"stopbits must be one of {serial.Serial.STOPBITS}, got {stopbits}")
        if baudrate <= 0 or write_timeout_s <= 0:
            raise ValueError(f"baudrate and write_timeout_s must be > 0, got {baudrate}, {write_timeout_s}")
        self.url = url
        self.settings = dict(
            baudrate=baudrate, bytesize=bytesize, parity=parity, stopbits=stopbits,
            xonxoff=xonxoff, rtscts=rtscts, write_timeout=write_timeout_s, timeout=0,
        )  # fmt: skip
        self._serial: serial.SerialBase | None = None

    def _open(self) -> None:
        self._serial = serial.serial_for_url(self.url, **self.settings)

    def _write(self, data: bytes) -> None:
        port = self._serial
        if port is None:
            raise OSError(errno.EBADF, "port not open")
        try:
            port.write(data)
        except serial.SerialTimeoutException as exc:
            raise PortStalled(str(exc)) from exc

    def _read(self) -> bytes:
        port = self._serial
        if port is None:
            raise OSError(errno.EBADF, "port not open")
        return bytes(port.read(4096))  # timeout=0: what is there, at once

    def _close_port(self) -> None:
        port, self._serial = self._serial, None
        if port is not None:
            port.close()

    def _cancel(self) -> None:
        port = self._serial
        cancel = getattr(port, "cancel_write", None)
        if cancel is not None:
            try:
                cancel()
            except (OSError, serial.SerialException):
                pass


class VirtualSerialPort(SerialPortBase):
    """In-memory port: records every byte written; can be absent, lost (EIO) or stalled.

    `stall()` makes writes block until `resume()` or `close()` (a port whose
    flow control never releases); with `write_timeout_s` they raise
    `PortStalled` after that long instead, like `PySerialPort`.
    """

    def __init__(self, name: str = "virtual", *, present: bool = True, write_timeout_s: float | None = None,
                 **base: Any) -> None:  # fmt: skip
        super().__init__(name, **base)
        self.write_timeout_s = write_timeout_s
        self._present = present
        self._open_now = False
        self._released = threading.Event()
        self._released.set()
        self._lock = threading.Lock()
        self._data = bytearray()
        self._input = bytearray()
        self.opens = 0

    def set_present(self, present: bool) -> None:
        """Plug (True) or unplug (False) the port; unplugged, opens fail and writes raise EIO."""
        self._present = present

    def stall(self) -> None:
        self._released.clear()

    def resume(self) -> None:
        self._released.set()

    def feed(self, data: bytes) -> None:
        """Bytes the peer sends (read by the writer thread with read_lines)."""
        with self._lock:
            self._input += data

    def _read(self) -> bytes:
        with self._lock:
            data, self._input = bytes(self._input), bytearray()
        return data

    def data(self) -> bytes:
        """Every byte written so far."""
        with self._lock:
            return bytes(self._data)

    def _open(self) -> None:
        if not self._present:
            raise FileNotFoundError(errno.ENOENT, "virtual port not present", self.name)
        self._open_now = True
        self.opens += 1

    def _write(self, data: bytes) -> None:
        if not self._released.wait(self.write_timeout_s):
            raise PortStalled("virtual port stalled")
        if self._stop.is_set():
            raise OSError(errno.ECANCELED, "closed while stalled")
        if not (self._present and self._open_now):
            raise OSError(errno.EIO, "virtual port lost")
        with self._lock:
            self._data += data

    def _close_port(self) -> None:
        self._open_now = False

    def _cancel(self) -> None:
        self._released.set()
