"""Modbus servers (TCP and RTU) that publish one register image, atomically.

The appliance's only input here is `update(registers)`: a complete image of
u16 values (address 0 .. n-1, built by edge/registers.py) that replaces the
previous one in a single reference swap. Every read is served from the one
image that was current when the request arrived, so a client never sees half
an update. The image is served as input registers (FC4) and mirrored
read-only as holding registers (FC3). Writes of any kind and reads outside
the image get exception 02 (illegal data address) and are counted
(`stats.writes`); coil and discrete-input reads, and every other function
(diagnostics, device identification, FIFO, file records: pymodbus would
answer some of them or change its own state) get 01 (illegal function); a
read before the first update gets 06 (busy). TCP answers any unit id; RTU
answers only its own unit id and stays silent for others and for broadcasts, as a bus member must.

Kinds (house rule): `ModbusServer` is the base; `ModbusTcpServer` and
`ModbusRtuServer` run pymodbus (pinned 3.16.1, whose server API moves between
minor versions: every pymodbus name is confined to this module and
drivers/modbus_guard.py) on an asyncio
loop in their own thread; `VirtualModbusServer` answers in memory with the
same rules. Malformed traffic never stops a server: it is counted
(`stats.garbage`), logged once, and the server keeps serving. TCP guards
against hostile or broken clients (`TcpLimits`): at most `max_clients`
connections (more are closed at once, `stats.refused_clients`), a connection
silent for `idle_timeout_s` is closed (`stats.idle_closed`), and one that
sends requests but does not read the answers is closed once
`max_unread_bytes` wait for it (`stats.unread_closed`), so no client can
hold memory, descriptors or the loop. Listening on a non-loopback address is
logged as a warning naming it.
"""

from __future__ import annotations

import asyncio
import ipaddress
import logging
import threading
from abc import ABC, abstractmethod
from array import array
from collections.abc import Callable, Sequence
from functools import partial

from pymodbus.datastore import ModbusServerContext
from pymodbus.server import ModbusBaseServer, ModbusSerialServer

from drivers.modbus_guard import (
    BIT_READ_FUNCTIONS,
    MAX_READ_COUNT,
    READ_FUNCTIONS,
    Counters,
    ExceptionCode,
    GuardedFramer,
    GuardedRtuFramer,
    GuardedSocketFramer,
    GuardedTcpServer,
    ImageContext,
    ModbusStats,
    ReadOnlyDecoder,
    TcpLimits,
)

__all__ = ["ExceptionCode", "ModbusRtuServer", "ModbusServer", "ModbusStats", "ModbusTcpServer",
           "RegisterImage", "TcpLimits", "VirtualModbusServer"]
_ImageContext = ImageContext  # the name the tests use
log = logging.getLogger(__name__)
DEFAULT_LIMITS = TcpLimits()


class RegisterImage:
    """The published registers: an immutable tuple, replaced by reference."""

    def __init__(self) -> None:
        self._registers: tuple[int, ...] | None = None

    def update(self, registers: Sequence[int]) -> None:
        image = tuple(array("H", registers))  # OverflowError unless every value is a u16
        self._registers = image  # one reference assignment: readers see old or new, whole

    def request(self, function_code: int, address: int, count: int,
                write: bool) -> list[int] | ExceptionCode:
        """Serve one request; writes never change anything."""
        if write:
            return ExceptionCode.ILLEGAL_ADDRESS
        if function_code in BIT_READ_FUNCTIONS:
            return ExceptionCode.ILLEGAL_FUNCTION
        if function_code not in READ_FUNCTIONS:
            return ExceptionCode.ILLEGAL_ADDRESS  # e.g. the read half of mask write (22)
        if not 1 <= count <= MAX_READ_COUNT:
            return ExceptionCode.ILLEGAL_VALUE
        image = self._registers  # read the reference once; everything below uses this image
        if image is None:
            return ExceptionCode.DEVICE_BUSY
        if address < 0 or address + count > len(image):
            return ExceptionCode.ILLEGAL_ADDRESS
        return list(image[address:address + count])


class ModbusServer(ABC):
    """A Modbus server publishing a `RegisterImage`; `update()` is its only input."""

    def __init__(self, name: str) -> None:
        self._image = RegisterImage()
        self._counters = Counters(name)

    def update(self, registers: Sequence[int]) -> None:
        """Publish a complete new image (u16 values from address 0); atomic, thread-safe."""
        self._image.update(registers)

    @property
    def stats(self) -> ModbusStats:
        return self._counters.stats()

    @abstractmethod
    def start(self) -> None: ...

    @abstractmethod
    def stop(self) -> None: ...

    def __enter__(self) -> ModbusServer:
        self.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.stop()

    def _serve(self, function_code: int, address: int, count: int,
               write: bool) -> list[int] | ExceptionCode:
        self._counters.requests += 1
        if write:
            self._counters.count("writes", f"write refused (function {function_code}): read-only server")
        result = self._image.request(function_code, address, count, write)
        if isinstance(result, ExceptionCode):
            self._counters.exceptions += 1
        return result


class VirtualModbusServer(ModbusServer):
    """In-memory server for tests and the demo: `request()` plays the client."""

    def __init__(self, unit: int | None = None) -> None:
        super().__init__("virtual modbus")
        self._unit = unit  # None answers every unit id (like TCP)
        self.running = False

    def start(self) -> None:
        self.running = True

    def stop(self) -> None:
        self.running = False

    def request(self, unit: int, function_code: int, address: int, count: int = 1,
                values: Sequence[int] | None = None) -> list[int] | ExceptionCode | None:
        """A read (values None) or write; None = no reply (stopped, other unit, broadcast)."""
        if not self.running or (self._unit is not None and unit != self._unit):
            return None
        n = count if values is None else len(values)
        return self._serve(function_code, address, n, values is not None)


class _ThreadedServer(ModbusServer):
    """Runs a pymodbus server on an asyncio loop in a thread of its own.

    With `_reopen_on_loss` (RTU), losing the port (unplugged adapter, EIO) closes
    the server, counts `port_losses`, and reopens it with backoff (1 s doubling
    to 30 s) until the port is back or the server is stopped.
    """

    _framer: type[GuardedFramer]
    _reopen_on_loss = False

    def __init__(self, name: str, unit: int | None) -> None:
        super().__init__(name)
        self._unit = unit
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._wake: asyncio.Event | None = None
        self._stop_requested = self._port_lost = False
        self._ready = threading.Event()
        self._error: BaseException | None = None

    @abstractmethod
    def _make_server(self, context: ModbusServerContext,
                     trace_connect: Callable[[bool], None]) -> ModbusBaseServer: ...

    def start(self, timeout_s: float = 5.0) -> None:
        """Start serving; raises OSError if the port cannot be opened."""
        if self._thread is not None:
            raise RuntimeError(f"{self._counters.name} already started")
        self._ready.clear()
        self._error = None
        self._stop_requested = self._port_lost = False
        self._thread = threading.Thread(target=asyncio.run, args=(self._run(),),
                                        name=self._counters.name, daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout_s):
            self._error = TimeoutError(f"{self._counters.name} did not start in {timeout_s} s")
        if self._error is not None:
            self.stop()
            raise self._error

    def stop(self, timeout_s: float = 5.0) -> None:
        thread, loop = self._thread, self._loop
        if thread is None:
            return
        if loop is not None:
            try:
                loop.call_soon_threadsafe(self._signal, "stop")
            except RuntimeError:  # loop already finished (start failed)
                pass
        thread.join(timeout_s)
        self._thread = self._loop = self._wake = None

    def _signal(self, what: str) -> None:
        """On the loop thread: note a stop request or a lost port and wake the supervisor."""
        if what == "stop":
            self._stop_requested = True
        else:
            self._port_lost = True
        if self._wake is not None:
            self._wake.set()

    def _trace_connect(self, connected: bool) -> None:
        self._counters.clients = max(0, self._counters.clients + (1 if connected else -1))
        if not connected and self._reopen_on_loss and not self._stop_requested:
            self._signal("lost")

    async def _open(self) -> ModbusBaseServer:
        server = self._make_server(ImageContext(self._serve, self._unit), self._trace_connect)
        # pymodbus types framer as a class; it only calls it with the decoder, which the partial takes
        server.framer = partial(self._framer, on_garbage=self._counters.count_garbage, unit=self._unit)  # type: ignore[assignment]
        server.decoder = ReadOnlyDecoder(True)
        await server.serve_forever(background=True)  # RuntimeError if it cannot listen/open
        return server

    async def _run(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._wake = asyncio.Event()
        try:
            server = await self._open()
        except Exception as exc:  # noqa: BLE001 - handed to start()'s caller
            self._error = OSError(f"{self._counters.name}: cannot start: {exc}")
            self._ready.set()
            return
        self._ready.set()
        while True:
            await self._wake.wait()
            self._wake.clear()
            if self._port_lost and not self._stop_requested:
                self._counters.port_losses += 1
                log.warning("%s: port lost, reopening with backoff", self._counters.name)
                await server.shutdown()
                reopened = await self._reopen()
                if reopened is None:
                    return
                server = reopened
            if self._stop_requested:
                await server.shutdown()
                return

    async def _reopen(self) -> ModbusBaseServer | None:
        assert self._wake is not None  # set by _run, the only caller
        delay_s = 1.0
        while not self._stop_requested:
            try:
                await asyncio.wait_for(self._wake.wait(), delay_s)  # a stop request cuts the wait
            except TimeoutError:
                pass
            self._wake.clear()
            if self._stop_requested:
                return None
            self._port_lost = False
            try:
                return await self._open()
            except Exception:  # noqa: BLE001 - port still missing: retry later
                delay_s = min(2 * delay_s, 30.0)
        return None


class ModbusTcpServer(_ThreadedServer):
    """Modbus TCP on host:port; answers any unit id."""

    _framer = GuardedSocketFramer

    def __init__(self, host: str = "0.0.0.0", port: int = 502, limits: TcpLimits = DEFAULT_LIMITS) -> None:
        super().__init__(f"modbus tcp {host}:{port}", None)
        self.host, self.port, self.limits = host, port, limits

    def start(self, timeout_s: float = 5.0) -> None:
        if not _is_loopback(self.host):
            log.warning("%s: listening on %s, a non-loopback address: reachable from the network",
                        self._counters.name, self.host)
        super().start(timeout_s)

    def _make_server(self, context: ModbusServerContext,
                     trace_connect: Callable[[bool], None]) -> ModbusBaseServer:
        server = GuardedTcpServer(context, address=(self.host, self.port), trace_connect=trace_connect)
        server.limits, server.counters = self.limits, self._counters
        return server


def _is_loopback(host: str) -> bool:
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return host == "localhost"


class ModbusRtuServer(_ThreadedServer):
    """Modbus RTU on a serial port; serial-line default 19200 8E1, parity always explicit."""

    _framer = GuardedRtuFramer
    _reopen_on_loss = True

    def __init__(self, port: str, unit: int = 1, baudrate: int = 19200, parity: str = "E",
                 stopbits: int = 1, bytesize: int = 8) -> None:
        if not 1 <= unit <= 247:
            raise ValueError(f"RTU unit id must be 1..247, got {unit}")
        if parity not in ("N", "E", "O"):
            raise ValueError(f"parity must be 'N', 'E' or 'O', got {parity!r}")
        super().__init__(f"modbus rtu {port} unit {unit}", unit)
        self.port, self.unit, self.baudrate = port, unit, baudrate
        self.parity, self.stopbits, self.bytesize = parity, stopbits, bytesize

    def _make_server(self, context: ModbusServerContext,
                     trace_connect: Callable[[bool], None]) -> ModbusBaseServer:
        return ModbusSerialServer(context, port=self.port, baudrate=self.baudrate, parity=self.parity,
                                  stopbits=self.stopbits, bytesize=self.bytesize,
                                  ignore_missing_devices=True, trace_connect=trace_connect)
