"""The pymodbus side of the Modbus servers: what reaches the register image, what is refused, and how.

`drivers.modbus` owns the servers' lifecycle; this module holds everything that meets
pymodbus (pinned 3.16.1; its server internals move between minor versions) and the
hostile-client guards: the datastore hook serving the image, framers that count and
resynchronise after malformed input, a decoder that knows only reads and writes (so every
other function, e.g. diagnostics that would change pymodbus' own state, is answered 01), and
a TCP connection handler that enforces `TcpLimits` (client count, idle time, unread answers),
counting each event in `Counters` so health shows it.
"""

from __future__ import annotations

import asyncio
import enum
import logging
import socket
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import cast

from pymodbus.constants import ExcCodes
from pymodbus.datastore import ModbusServerContext
from pymodbus.exceptions import ModbusIOException, NoSuchIdException
from pymodbus.framer import FramerRTU, FramerSocket
from pymodbus.pdu import DecodePDU, ModbusPDU
from pymodbus.server import ModbusTcpServer as _PymodbusTcpServer
from pymodbus.server.requesthandler import ServerRequestHandler

log = logging.getLogger("drivers.modbus")
# pymodbus warns once per malformed frame (10 000 lines for 10 000 frames); `Counters` counts them and
# logs the first of each kind, so only pymodbus' errors (a datastore failure) go through
logging.getLogger("pymodbus").setLevel(logging.ERROR)

READ_FUNCTIONS = {3, 4}  # holding (mirror), input
BIT_READ_FUNCTIONS = {1, 2}  # coils, discrete inputs: not offered
WRITE_FUNCTIONS = {5, 6, 15, 16, 22, 23}  # decoded only to be refused with 02
DECODED_FUNCTIONS = READ_FUNCTIONS | BIT_READ_FUNCTIONS | WRITE_FUNCTIONS  # all else: 01
MAX_READ_COUNT = 125
class ExceptionCode(enum.IntEnum):
    ILLEGAL_FUNCTION = 0x01
    ILLEGAL_ADDRESS = 0x02
    ILLEGAL_VALUE = 0x03
    DEVICE_BUSY = 0x06


@dataclass(frozen=True, slots=True)
class ModbusStats:
    requests: int  # requests that reached the register image
    exceptions: int  # of those, answered with an exception
    garbage: int  # malformed frames or bytes dropped
    clients: int  # connections open now (TCP); 1 while the port is open (RTU)
    port_losses: int  # RTU: times the port went away (each followed by reopen attempts)
    writes: int = 0  # write requests refused (exception 02); also in requests and exceptions
    refused_clients: int = 0  # TCP connections closed at once: max_clients already open
    idle_closed: int = 0  # TCP connections closed after idle_timeout_s without a request
    unread_closed: int = 0  # TCP connections closed: max_unread_bytes of answers not read


@dataclass(frozen=True, slots=True)
class TcpLimits:
    """What one TCP server allows its clients (a PLC or SCADA poller needs one or two)."""

    max_clients: int = 64
    idle_timeout_s: float = 120.0  # a poller that keeps its connection polls far more often
    max_unread_bytes: int = 65536  # answers waiting for a client, in our buffer (and its socket's)


class Counters:
    """Mutated only on the server's loop thread (or the caller's, for the virtual one)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.requests = self.exceptions = self.garbage = self.clients = self.port_losses = 0
        self.writes = self.refused_clients = self.idle_closed = self.unread_closed = 0
        self._logged: set[str] = set()

    def count(self, event: str, text: str) -> None:
        """Count a guard event (an attribute name); log the first of each kind."""
        if event not in self._logged:
            self._logged.add(event)
            log.warning("%s: %s (counted in stats.%s from now on)", self.name, text, event)
        setattr(self, event, getattr(self, event) + 1)

    def count_garbage(self) -> None:
        if self.garbage == 0:
            log.warning("%s: malformed Modbus traffic dropped (counted in stats.garbage from now on)",
                        self.name)
        self.garbage += 1

    def stats(self) -> ModbusStats:
        return ModbusStats(self.requests, self.exceptions, self.garbage, self.clients, self.port_losses,
                           self.writes, self.refused_clients, self.idle_closed, self.unread_closed)


class ImageContext(ModbusServerContext):
    """pymodbus 3.16 datastore hook serving the image.

    The 3.16 server calls `async_getValues` / `async_setValues` on a
    `ModbusServerContext` whose `old_simulator` flag is set, passing the unit id.
    The parent constructor is skipped on purpose: it only wraps SimDevices and
    logs a deprecation warning, and nothing of it is used here.
    """

    def __init__(self, serve: Callable[[int, int, int, bool], list[int] | ExceptionCode],
                 unit: int | None) -> None:
        # pylint: disable=super-init-not-called
        self.old_simulator = True
        self.simdevices = []
        self._serve = serve
        self._unit = unit

    def device_ids(self) -> list[int]:
        return [self._unit or 0]

    def _check_unit(self, device_id: int) -> None:
        if self._unit is not None and device_id != self._unit:
            raise NoSuchIdException(f"unit {device_id} is not ours")  # silent with ignore_missing_devices

    async def async_getValues(self, device_id: int, func_code: int, address: int,
                              count: int = 1) -> list[int] | ExcCodes:
        self._check_unit(device_id)
        result = self._serve(func_code, address, count, False)
        return ExcCodes(result) if isinstance(result, ExceptionCode) else result

    async def async_setValues(self, device_id: int, func_code: int, address: int,
                              values: Sequence[int] | Sequence[bool]) -> ExcCodes | None:
        self._check_unit(device_id)
        result = self._serve(func_code, address, len(values), True)
        assert isinstance(result, ExceptionCode)  # writes are always refused
        return ExcCodes(result)


class GuardedFramer:
    """Framer mixin: counts malformed input, resynchronises, keeps other RTU units silent."""

    def __init__(self, decoder: DecodePDU, on_garbage: Callable[[], None], unit: int | None) -> None:
        super().__init__(decoder)  # type: ignore[call-arg]
        self._on_garbage = on_garbage
        self._unit = unit
        self._last_fc: int | None = None

    def _remember(self, result: tuple[int, int, int, bytes]) -> tuple[int, int, int, bytes]:
        used, _dev, _tid, frame = result
        self._last_fc = frame[0] if frame else None
        if used and not frame:  # bytes consumed without a frame: CRC error or out of step
            self._on_garbage()
        return result

    def handleFrame(self, data: bytes, exp_devid: int, exp_tid: int):  # noqa: N802 (pymodbus name)
        try:
            return super().handleFrame(data, exp_devid, exp_tid)  # type: ignore[misc]
        except ModbusIOException as exc:  # frame intact but not a request we can decode
            self._on_garbage()
            if self._unit is not None and exc.dev_id != self._unit:
                return len(data), None  # someone else's frame on the bus: no reply
            raise ModbusIOException("undecodable request", self._last_fc,
                                    transaction_id=exc.transaction_id, dev_id=exc.dev_id) from exc


class GuardedSocketFramer(GuardedFramer, FramerSocket):
    def decode(self, data: bytes) -> tuple[int, int, int, bytes]:
        # MBAP: protocol id 0 and a length of unit + function + at most 252 bytes, else the
        # stream is out of step and cannot be resynchronised: drop what arrived so far.
        if len(data) >= 6 and (data[2:4] != b"\0\0" or not 2 <= int.from_bytes(data[4:6]) <= 254):
            return self._remember((len(data), 0, 0, self.EMPTY))
        return self._remember(super().decode(data))


class GuardedRtuFramer(GuardedFramer, FramerRTU):
    def decode(self, data: bytes) -> tuple[int, int, int, bytes]:
        return self._remember(super().decode(data))


class ReadOnlyDecoder(DecodePDU):
    """Decodes reads and writes only: any other function is undecodable, so it is answered 01."""

    def decode(self, frame: bytes) -> ModbusPDU | None:
        return super().decode(frame) if frame and frame[0] in DECODED_FUNCTIONS else None


class _GuardedHandler(ServerRequestHandler):
    """One TCP connection, held to the server's `TcpLimits` (see the module docstring)."""

    def __init__(self, owner: GuardedTcpServer) -> None:
        super().__init__(owner, owner.trace_packet, owner.trace_pdu, owner.trace_connect)
        self._limits, self._counters = owner.limits, owner.counters
        self._last_s = 0.0
        self._timer: asyncio.TimerHandle | None = None

    def callback_connected(self) -> None:
        super().callback_connected()
        self._last_s = self.loop.time()
        if self._counters.clients > self._limits.max_clients:
            self._counters.count("refused_clients",
                                 f"more than {self._limits.max_clients} clients, closing the newest")
            self._drop()
            return
        sock = self.transport.get_extra_info("socket")
        if sock is not None:  # the kernel's share of a non-reader's backlog: ~2x this (Linux doubles it)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, self._limits.max_unread_bytes)
        self._timer = self.loop.call_later(self._limits.idle_timeout_s, self._check_idle)

    def _check_idle(self) -> None:
        idle_s = self.loop.time() - self._last_s
        if idle_s >= self._limits.idle_timeout_s:
            self._counters.count("idle_closed", f"client silent {self._limits.idle_timeout_s:g} s, closed")
            self._drop()
        else:
            self._timer = self.loop.call_later(self._limits.idle_timeout_s - idle_s, self._check_idle)

    def _drop(self, abort: bool = False) -> None:
        transport = cast(asyncio.Transport | None, self.transport)
        if transport is not None and not transport.is_closing():
            transport.abort() if abort else transport.close()  # connection_lost does the accounting

    def callback_disconnected(self, exc: Exception | None) -> None:
        if self._timer is not None:
            self._timer.cancel()
        super().callback_disconnected(exc)

    def callback_data(self, data: bytes, addr: tuple | None = None) -> int:
        self._last_s = self.loop.time()
        return super().callback_data(data, addr)

    def server_send(self, pdu: ModbusPDU, addr: tuple | None) -> None:
        transport = cast(asyncio.Transport | None, self.transport)
        if transport is not None and transport.get_write_buffer_size() > self._limits.max_unread_bytes:
            self._counters.count("unread_closed", "client does not read its answers, closed")
            self._drop(abort=True)  # close() would wait to flush what it never reads
            return
        super().server_send(pdu, addr)


class GuardedTcpServer(_PymodbusTcpServer):
    limits: TcpLimits
    counters: Counters

    def callback_new_connection(self) -> ServerRequestHandler:
        return _GuardedHandler(self)
