"""Modbus servers (TCP and RTU) that publish one register image, atomically.

The appliance's only input here is `update(registers)`: a complete image of
u16 values (address 0 .. n-1, built by edge/registers.py) that replaces the
previous one in a single reference swap. Every read is served from the one
image that was current when the request arrived, so a client never sees half
an update. The image is served as input registers (FC4) and mirrored
read-only as holding registers (FC3). Writes of any kind and reads outside
the image get exception 02 (illegal data address); coil and discrete-input
reads get 01 (illegal function); a read before the first update gets 06
(busy). TCP answers any unit id; RTU answers only its own unit id and stays
silent for others and for broadcasts, as a bus member must.

Kinds (house rule): `ModbusServer` is the base; `ModbusTcpServer` and
`ModbusRtuServer` run pymodbus (pinned 3.16.1, whose server API moves between
minor versions: every pymodbus name is confined to this module) on an asyncio
loop in their own thread; `VirtualModbusServer` answers in memory with the
same rules. Malformed traffic never stops a server: it is counted
(`stats.garbage`), logged once, and the server keeps serving.
"""

from __future__ import annotations

import asyncio
import enum
import logging
import threading
from abc import ABC, abstractmethod
from array import array
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial

from pymodbus.constants import ExcCodes
from pymodbus.datastore import ModbusServerContext
from pymodbus.exceptions import ModbusIOException, NoSuchIdException
from pymodbus.framer import FramerRTU, FramerSocket
from pymodbus.pdu import DecodePDU
from pymodbus.server import ModbusBaseServer, ModbusSerialServer
from pymodbus.server import ModbusTcpServer as _PymodbusTcpServer

log = logging.getLogger(__name__)
READ_FUNCTIONS = {3, 4}  # holding (mirror), input
BIT_READ_FUNCTIONS = {1, 2}  # coils, discrete inputs: not offered
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


class _Counters:
    """Mutated only on the server's loop thread (or the caller's, for the virtual one)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.requests = self.exceptions = self.garbage = self.clients = self.port_losses = 0

    def count_garbage(self) -> None:
        if self.garbage == 0:
            log.warning("%s: malformed Modbus traffic dropped (counted in stats.garbage from now on)",
                        self.name)
        self.garbage += 1

    def stats(self) -> ModbusStats:
        return ModbusStats(self.requests, self.exceptions, self.garbage, self.clients, self.port_losses)


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
        self._counters = _Counters(name)

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


class _ImageContext(ModbusServerContext):
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


class _GuardedFramer:
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


class _GuardedSocketFramer(_GuardedFramer, FramerSocket):
    def decode(self, data: bytes) -> tuple[int, int, int, bytes]:
        # MBAP: protocol id 0 and a length of unit + function + at most 252 bytes, else the
        # stream is out of step and cannot be resynchronised: drop what arrived so far.
        if len(data) >= 6 and (data[2:4] != b"\0\0" or not 2 <= int.from_bytes(data[4:6]) <= 254):
            return self._remember((len(data), 0, 0, self.EMPTY))
        return self._remember(super().decode(data))


class _GuardedRtuFramer(_GuardedFramer, FramerRTU):
    def decode(self, data: bytes) -> tuple[int, int, int, bytes]:
        return self._remember(super().decode(data))


class _ThreadedServer(ModbusServer):
    """Runs a pymodbus server on an asyncio loop in a thread of its own.

    With `_reopen_on_loss` (RTU), losing the port (unplugged adapter, EIO) closes
    the server, counts `port_losses`, and reopens it with backoff (1 s doubling
    to 30 s) until the port is back or the server is stopped.
    """

    _framer: type[_GuardedFramer]
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
        server = self._make_server(_ImageContext(self._serve, self._unit), self._trace_connect)
        # pymodbus types framer as a class; it only calls it with the decoder, which the partial takes
        server.framer = partial(self._framer, on_garbage=self._counters.count_garbage, unit=self._unit)  # type: ignore[assignment]
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

    _framer = _GuardedSocketFramer

    def __init__(self, host: str = "0.0.0.0", port: int = 502) -> None:
        super().__init__(f"modbus tcp {host}:{port}", None)
        self.host, self.port = host, port

    def _make_server(self, context: ModbusServerContext,
                     trace_connect: Callable[[bool], None]) -> ModbusBaseServer:
        return _PymodbusTcpServer(context, address=(self.host, self.port),
                                  trace_connect=trace_connect)


class ModbusRtuServer(_ThreadedServer):
    """Modbus RTU on a serial port; serial-line default 19200 8E1, parity always explicit."""

    _framer = _GuardedRtuFramer
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
