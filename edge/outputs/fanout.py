"""Fan-out: each processing step's fixes go to every configured output, none can stall it.

`Outputs` is what the daemon and the demo hand fixes to. It owns one
`NmeaSerialOutput` per `outputs.nmea[i]` port, the optional IEC 61162-450 UDP
output, the Modbus TCP/RTU servers and the tracks CSV, and it stamps one
health heartbeat per output kind ("nmea", "modbus", "tracks_csv") so a dead
port shows on the status word.

None of the outputs block: NMEA ports queue to their own writer threads,
UDP sends are non-blocking, and a Modbus server only swaps an immutable
register image. A Modbus server that cannot start (port taken, serial device
missing) is counted, logged once, reported as a fault and retried with
back-off from `publish()`; it never stops the appliance.

Modbus shows the NMEA target number of the first NMEA port (each port has
its own allocator: numbers are per receiver); with no NMEA port the field
reads "not available".
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence

from drivers.modbus import ModbusRtuServer, ModbusServer, ModbusTcpServer
from edge import __version__
from edge.config import OutputsConfig
from edge.fix import ShipFix
from edge.health import HealthMonitor, HealthSnapshot, Status
from edge.outputs.nmea_out import NmeaSerialOutput
from edge.outputs.nmea_udp import NmeaUdpOutput
from edge.outputs.tracks_csv import TracksCsvOutput
from edge.registers import Identity, SlotAssignment, WordOrder, build_snapshot

log = logging.getLogger(__name__)

OUTPUT_STAGES: tuple[tuple[str, Status], ...] = (
    ("nmea", Status.NMEA_ACTIVE), ("modbus", Status(0)), ("tracks_csv", Status(0)),
)


def output_stages(cfg: OutputsConfig, *, extra_nmea: bool = False) -> list[tuple[str, Status]]:
    """The health stages of the configured outputs only: an output that is off never beats,
    and a stage that never beats would hold the appliance in DEGRADED."""
    on = {
        "nmea": bool(cfg.nmea) or cfg.udp.enabled or extra_nmea,
        "modbus": cfg.modbus.tcp.enabled or cfg.modbus.rtu.enabled,
        "tracks_csv": cfg.tracks_csv is not None,
    }
    return [(name, bit) for name, bit in OUTPUT_STAGES if on[name]]
RETRY_MIN_S, RETRY_MAX_S = 1.0, 30.0


def firmware_version() -> tuple[int, int, int]:
    major, minor, patch = (int(p) for p in __version__.split(".")[:3])
    return major, minor, patch


class _ServerSlot:
    """A Modbus server with start retries: started lazily, re-tried with doubling back-off."""

    def __init__(self, server: ModbusServer, clock: Callable[[], float]) -> None:
        self.server = server
        self.running = False
        self.failures = 0
        self.error: str | None = None
        self._clock = clock
        self._next_try_s = -float("inf")
        self._backoff_s = RETRY_MIN_S

    def ensure_started(self) -> None:
        now_s = self._clock()
        if self.running or now_s < self._next_try_s:
            return
        try:
            self.server.start()
        except OSError as exc:
            self.failures += 1
            if self.error is None:
                log.error("%s could not start: %s (retrying with back-off)", type(self.server).__name__, exc)
            self.error = f"cannot start: {exc}"
            self._next_try_s = now_s + self._backoff_s
            self._backoff_s = min(RETRY_MAX_S, 2 * self._backoff_s)
            return
        if self.error is not None:
            log.info("%s started after %d failed attempts", type(self.server).__name__, self.failures)
        self.running, self.error, self._backoff_s = True, None, RETRY_MIN_S


class Outputs:
    """Publishes fixes to NMEA ports, UDP and Modbus; see the module docstring."""

    def __init__(
        self,
        nmea: Sequence[NmeaSerialOutput | NmeaUdpOutput],
        modbus: Sequence[ModbusServer],
        identity: Identity,
        health: HealthMonitor,
        clock: Callable[[], float] = time.monotonic,
        tracks_csv: TracksCsvOutput | None = None,
    ) -> None:
        self.nmea = list(nmea)
        self.tracks_csv = tracks_csv
        self.identity = identity
        self.health = health
        self._modbus = [_ServerSlot(s, clock) for s in modbus]
        self._assignment = SlotAssignment.empty(identity.max_tracks)

    @classmethod
    def from_config(cls, cfg: OutputsConfig, health: HealthMonitor, *, max_tracks: int,
                    site_lat_deg: float | None = None, site_lon_deg: float | None = None) -> Outputs:
        nmea: list[NmeaSerialOutput | NmeaUdpOutput] = [NmeaSerialOutput.from_config(p) for p in cfg.nmea]
        if cfg.udp.enabled:
            nmea.append(NmeaUdpOutput.from_config(cfg.udp))
        servers: list[ModbusServer] = []
        if cfg.modbus.tcp.enabled:
            servers.append(ModbusTcpServer(cfg.modbus.tcp.host, cfg.modbus.tcp.port))
        if cfg.modbus.rtu.enabled:
            rtu = cfg.modbus.rtu
            servers.append(ModbusRtuServer(rtu.url, rtu.unit, rtu.baud, rtu.parity, rtu.stopbits))
        order = WordOrder.HIGH_FIRST if cfg.modbus.word_order == "high_first" else WordOrder.LOW_FIRST
        identity = Identity(firmware_version(), max_tracks, order, site_lat_deg, site_lon_deg)
        csv = TracksCsvOutput(cfg.tracks_csv) if cfg.tracks_csv is not None else None
        return cls(nmea, servers, identity, health, tracks_csv=csv)

    def start(self) -> None:
        for out in self.nmea:
            if isinstance(out, NmeaSerialOutput):
                out.start()
        for slot in self._modbus:
            slot.ensure_started()
        if self.tracks_csv is not None:
            self.tracks_csv.start()

    def publish(self, fixes: Sequence[ShipFix], utc_ns: int) -> HealthSnapshot:
        """Hand this step's complete list of live fixes to every output; returns the health used."""
        lines = 0
        for out in self.nmea:
            lines += len(out.publish(fixes))
        self._beat_nmea(lines)
        if self.tracks_csv is not None:
            self.tracks_csv.publish(fixes)
            fault, counters = self.tracks_csv.health()
            self.health.beat("tracks_csv", fault=fault, counters=counters)
        snapshot = self.health.snapshot()
        numbers = self._target_numbers(fixes)
        image = build_snapshot(fixes, snapshot, self.identity, self._assignment,
                               utc_ns=utc_ns, target_numbers=numbers)
        self._assignment = image.assignment
        for slot in self._modbus:
            slot.ensure_started()
            if slot.running:
                slot.server.update(image.registers)
        if self._modbus:
            errors = [s.error for s in self._modbus if s.error]
            self.health.beat("modbus", fault="; ".join(errors) or None,
                             counters={"start_failures": sum(s.failures for s in self._modbus)})
        return snapshot

    def close(self) -> None:
        for out in self.nmea:
            out.close()
        if self.tracks_csv is not None:
            self.tracks_csv.close()
        for slot in self._modbus:
            if slot.running:
                slot.server.stop()
                slot.running = False

    @property
    def modbus_servers(self) -> list[ModbusServer]:
        return [s.server for s in self._modbus]

    def _beat_nmea(self, groups: int) -> None:
        if not self.nmea:
            return
        faults, counters = [], {"groups": groups}
        for out in self.nmea:
            fault, c = out.health()
            if fault:
                faults.append(fault)
            for key, value in c.items():
                counters[key] = counters.get(key, 0) + value
        self.health.beat("nmea", fault="; ".join(faults) or None, counters=counters)

    def _target_numbers(self, fixes: Sequence[ShipFix]) -> dict[int, int]:
        first = next((o for o in self.nmea if isinstance(o, NmeaSerialOutput)), None)
        if first is None:
            return {}
        numbers = first.scheduler.numbers
        found = {fx.track_id: numbers.number_of(fx.track_id) for fx in fixes}
        return {tid: n for tid, n in found.items() if n is not None}
