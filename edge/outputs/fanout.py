"""Fan-out: each processing step's fixes go to every configured output, none can stall it.

`Outputs` is what the daemon and the demo hand fixes to. It owns one output per configured
transport (an NMEA serial port per `outputs.nmea[i]`, the optional IEC 61162-450 UDP output,
the Modbus TCP/RTU servers, the tracks CSV, the optional ASTERIX output, and any extra NMEA
stream such as the demo's stdout), all behind the one `edge.outputs.base.Output` contract, and
beats one health stage per output kind ("nmea", "modbus", "tracks_csv", "asterix") so a dead
port shows on the status word.

None of the outputs block: NMEA ports queue to their own writer threads, UDP sends are
non-blocking, the CSV has its own writer, and a Modbus server only swaps an immutable register
image. Stages are served in order (NMEA, CSV, ASTERIX, then Modbus), so the register image carries the
health of this step's other outputs. Modbus shows the NMEA target number of the first NMEA
serial port (each port has its own allocator: numbers are per receiver); with no NMEA port the
field reads "not available".

Alerts (`alerts.enabled`): the chain (`edge.chain`) steps the one `AlertManager` with each step's
fixes and the health before any output publishes; the outputs only render it: every NMEA output
whose port does not say `alerts: none` gets its own `PortAlerts` (its target numbers, its
sentences), and Modbus shows the alert block with the first serial port's numbers.
"""

from __future__ import annotations

import logging
import time
from collections import Counter
from collections.abc import Callable, Sequence

from drivers.modbus import ModbusRtuServer, ModbusServer, ModbusTcpServer
from edge import __version__
from edge.alerts.manager import AlertManager, AlertState
from edge.alerts.port import PortAlerts
from edge.appliance.health import HealthMonitor, HealthSnapshot, Status
from edge.config.app import OutputsConfig
from edge.encode.alert_rows import AlertImage, AlertRow
from edge.encode.registers import ALERT_SLOTS, Identity, WordOrder
from edge.fix import ShipFix
from edge.outputs.asterix import AsterixOutput
from edge.outputs.base import Output
from edge.outputs.modbus import ModbusOutput
from edge.outputs.nmea_serial import NmeaSerialOutput
from edge.outputs.nmea_stream import NmeaStreamOutput
from edge.outputs.nmea_udp import NmeaUdpOutput
from edge.outputs.tracks_csv import TracksCsvOutput

log = logging.getLogger(__name__)

OUTPUT_STAGES: tuple[tuple[str, Status], ...] = (
    ("nmea", Status.NMEA_ACTIVE), ("tracks_csv", Status(0)), ("asterix", Status(0)), ("modbus", Status(0)),
)
STAGE_ORDER = {name: k for k, (name, _) in enumerate(OUTPUT_STAGES)}
HEALTH_ORDER = ("nmea", "modbus", "tracks_csv", "asterix")  # the FAULT_CODE numbering (stages 4, 5, ...)


def output_stages(cfg: OutputsConfig, *, extra_nmea: bool = False) -> list[tuple[str, Status]]:
    """The health stages of the configured outputs only: an output that is off never beats,
    and a stage that never beats would hold the appliance in DEGRADED."""
    on = {
        "nmea": bool(cfg.nmea) or cfg.udp.enabled or extra_nmea,
        "modbus": cfg.modbus.tcp.enabled or cfg.modbus.rtu.enabled,
        "tracks_csv": cfg.tracks_csv is not None,
        "asterix": cfg.asterix.enabled,
    }
    bits = dict(OUTPUT_STAGES)
    return [(name, bits[name]) for name in HEALTH_ORDER if on[name]]


def firmware_version() -> tuple[int, int, int]:
    major, minor, patch = (int(p) for p in __version__.split(".")[:3])
    return major, minor, patch


class Outputs:
    """Publishes fixes to every output and reports their health; see the module docstring."""

    def __init__(self, outputs: Sequence[Output], health: HealthMonitor,
                 alerts: AlertManager | None = None) -> None:
        self.health = health
        self.alerts = alerts
        self.outputs: list[Output] = []
        self.sent: Counter[str] = Counter()  # items published since start, per unit
        self.health_images = 0  # Modbus images republished while no pair came (publish_health)
        for out in outputs:
            self.add(out)

    @classmethod
    def from_config(cls, cfg: OutputsConfig, health: HealthMonitor, *, max_tracks: int,
                    site_lat_deg: float | None = None, site_lon_deg: float | None = None,
                    clock: Callable[[], float] = time.monotonic,
                    alerts: AlertManager | None = None, dark_prefix: str = "DARK",
                    asterix_site: tuple[float, float, float] | None = None) -> Outputs:
        """The configured transports; with `alerts` (the chain's manager) the NMEA ports render its
        alert sentences and Modbus its alert block; `asterix_site` is what CAT 034 I034/120 states
        (`edge.outputs.asterix.sensor_position`)."""
        manager = alerts
        outputs: list[Output] = []
        for port in cfg.nmea:
            serial = NmeaSerialOutput.from_config(port, dark_prefix)
            if manager is not None and port.alerts != "none":
                serial.scheduler.alerts = PortAlerts(manager, manager.cfg, talker=port.talker,
                                                     mode=port.alerts, digits=serial.scheduler.numbers.digits)
            outputs.append(serial)
        if cfg.udp.enabled:
            udp = NmeaUdpOutput.from_config(cfg.udp, dark_prefix)
            if manager is not None:
                udp.scheduler.alerts = PortAlerts(manager, manager.cfg, talker=cfg.udp.source[:2],
                                                  digits=udp.scheduler.numbers.digits)
            outputs.append(udp)
        if cfg.tracks_csv is not None:
            outputs.append(TracksCsvOutput(cfg.tracks_csv))
        if cfg.asterix.enabled:
            outputs.append(AsterixOutput.from_config(cfg.asterix, health.snapshot, asterix_site))
        servers: list[ModbusServer] = []
        if cfg.modbus.tcp.enabled:
            servers.append(ModbusTcpServer(cfg.modbus.tcp.host, cfg.modbus.tcp.port))
        if cfg.modbus.rtu.enabled:
            rtu = cfg.modbus.rtu
            servers.append(ModbusRtuServer(rtu.url, rtu.unit, rtu.baud, rtu.parity, rtu.stopbits))
        fanout = cls(outputs, health, manager)
        if servers:
            order = WordOrder.HIGH_FIRST if cfg.modbus.word_order == "high_first" else WordOrder.LOW_FIRST
            fanout.add_modbus(servers, Identity(firmware_version(), max_tracks, order, site_lat_deg,
                                                site_lon_deg, ALERT_SLOTS if manager is not None else 0),
                              clock)
        return fanout

    def add(self, output: Output) -> None:
        """One more output (e.g. the demo's NMEA stream), served with the others of its stage; an
        NMEA stream gets the alert sentences too when alerts are on."""
        if self.alerts is not None and isinstance(output, NmeaStreamOutput):
            if output.scheduler.alerts is None:
                output.scheduler.alerts = PortAlerts(self.alerts, self.alerts.cfg,
                                                     digits=output.scheduler.numbers.digits)
        self.outputs.append(output)
        self.outputs.sort(key=lambda o: STAGE_ORDER[o.stage])  # stable: configuration order kept

    def add_modbus(self, servers: Sequence[ModbusServer], identity: Identity,
                   clock: Callable[[], float] = time.monotonic) -> None:
        """The Modbus servers as one output, publishing this fan-out's health and target numbers."""
        self.add(ModbusOutput(servers, identity, self.health.snapshot, self.target_numbers, clock,
                              None if self.alerts is None else self.alert_image))

    def alert_image(self) -> AlertImage | None:
        """The alert manager's state for Modbus, with the first serial port's target numbers."""
        manager = self.alerts
        if manager is None:
            return None
        first = next((o for o in self.outputs if isinstance(o, NmeaSerialOutput)), None)
        port = None if first is None else first.scheduler.alerts
        numbers = None if first is None else first.scheduler.numbers
        rows = []
        for a in manager.active():
            tracks = (a.tracks + (None, None))[:2]
            targets = tuple(None if t is None or numbers is None else numbers.reserved_for(t) for t in tracks)
            instance = a.instance if not a.tracks else None if port is None else port.instance(a)
            rows.append(AlertRow(int(a.alert_id), instance, a.state is AlertState.ACTIVE_ACK, a.priority,
                                 a.revision, (targets[0], targets[1]), (tracks[0], tracks[1]), a.cpa_m,
                                 a.tcpa_s, max(0.0, (manager.last_utc_ns - a.raised_ns) / 1e9)))
        unack = sum(a.state is AlertState.ACTIVE_UNACK for a in manager.active())
        return AlertImage(tuple(rows), unack, manager.raised, manager.health_ok)

    def start(self) -> None:
        for out in self.outputs:
            out.start()

    def publish(self, fixes: Sequence[ShipFix], utc_ns: int) -> HealthSnapshot:
        """Hand this step's complete list of live fixes to every output; returns the health after it."""
        stage: str | None = None
        faults: list[str] = []
        counters: Counter[str] = Counter()
        for out in self.outputs:
            if out.stage != stage:
                self._beat(stage, faults, counters)
                stage, faults, counters = out.stage, [], Counter()
            self.sent[out.unit] += len(out.publish(fixes, utc_ns))
            fault, c = out.health()
            if fault:
                faults.append(fault)
            counters.update(c)
            counters[out.unit] = self.sent[out.unit]
        self._beat(stage, faults, counters)
        return self.health.snapshot()

    def publish_health(self, fixes: Sequence[ShipFix], utc_ns: int) -> None:
        """Only the Modbus image, with the health as it is now (no pair came: nothing new to send on
        NMEA or to the CSV, but the PLC must see a camera gone as soon as the health does); with
        alerts on, the NMEA ports also send what alert sentences are due (HBT, a camera-lost ALF)."""
        if self.alerts is not None:  # the chain stepped the alerts' health: send what is due (HBT, ALF)
            for nmea in self.outputs:
                if isinstance(nmea, NmeaSerialOutput | NmeaUdpOutput | NmeaStreamOutput):
                    nmea.publish_alerts()
        for out in self.outputs:  # ASTERIX status: NOGO in the next message after a camera went
            if isinstance(out, AsterixOutput):
                self.sent[out.unit] += len(out.publish_status(utc_ns))
                fault, counters = out.health()
                self.health.beat(out.stage, fault=fault, counters={**counters, out.unit: self.sent[out.unit]})
        mine = [out for out in self.outputs if isinstance(out, ModbusOutput)]
        for out in mine:  # counted apart: `sent` stays one image per processed pair
            self.health_images += len(out.publish(fixes, utc_ns))
        if mine:
            fault, counters = mine[0].health()
            counters = {**counters, mine[0].unit: self.sent[mine[0].unit],
                        "health_images": self.health_images}
            self.health.beat("modbus", fault=fault, counters=counters)

    def _beat(self, stage: str | None, faults: list[str], counters: Counter[str]) -> None:
        if stage is not None:
            self.health.beat(stage, fault="; ".join(faults) or None, counters=dict(counters))

    def close(self) -> None:
        for out in self.outputs:
            out.close()

    @property
    def modbus_servers(self) -> list[ModbusServer]:
        return [s for out in self.outputs if isinstance(out, ModbusOutput) for s in out.servers]

    def target_numbers(self, fixes: Sequence[ShipFix]) -> dict[int, int]:
        """NMEA target number per track id, from the first serial port's allocator."""
        first = next((o for o in self.outputs if isinstance(o, NmeaSerialOutput)), None)
        if first is None:
            return {}
        numbers = first.scheduler.numbers
        found = {fx.track_id: numbers.number_of(fx.track_id) for fx in fixes}
        return {tid: n for tid, n in found.items() if n is not None}
