"""NMEA 0183 on a serial line: the schedule's track updates queued to a serial port.

The byte budget is the line's character rate (baud over start + data + parity + stop bits)
times a utilisation margin; `edge.outputs.schedule` decides what fits, and the port
(`drivers.serial_port`: its own writer thread, a bounded queue, reconnection) writes it, so a
slow or lost line never holds up processing.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any

from drivers.serial_port import PySerialPort, SerialPortBase
from edge.fix import ShipFix
from edge.outputs.schedule import (
    DEFAULT_SCHEDULE,
    NmeaSchedule,
    NmeaScheduler,
    fix_counters,
    schedule_from_config,
)

if TYPE_CHECKING:
    from edge.config.app import NmeaPort


def serial_bytes_per_s(baud: int, bytesize: int = 8, parity: str = "N", stopbits: float = 1) -> float:
    """Characters per second of an asynchronous serial line: baud / (start + data + parity + stop bits)."""
    bits = 1 + bytesize + (0 if parity == "N" else 1) + stopbits
    return baud / bits


CLOSE_DRAIN_S = 0.3  # at shutdown; the daemon must be gone within 2 s of SIGTERM


class NmeaSerialOutput:
    """Scheduler + serial port. `publish()` is the processing thread's only call; it never blocks.

    The byte budget is ``utilisation`` times the line's character rate (baud
    over start + data + parity + stop bits). Each track update (TTM+TLL...) is
    one queue entry, so a full queue drops whole updates, oldest first. Pass
    `port` to use a `VirtualSerialPort`; by default a `PySerialPort` is built
    from `url` and the framing.
    """

    stage = "nmea"
    unit = "nmea_serial_groups"

    def __init__(
        self,
        url: str,
        schedule: NmeaSchedule = DEFAULT_SCHEDULE,
        *,
        baud: int = 38400,
        bytesize: int = 8,
        parity: str = "N",
        stopbits: float = 1,
        xonxoff: bool = False,
        rtscts: bool = False,
        utilisation: float = 0.9,
        queue_max: int = 32,
        write_timeout_s: float = 1.0,
        read_lines: bool = False,
        port: SerialPortBase | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if not 0 < utilisation <= 1:
            raise ValueError(f"utilisation must be in (0, 1], got {utilisation}")
        self.bytes_per_s = utilisation * serial_bytes_per_s(baud, bytesize, parity, stopbits)
        self.scheduler = NmeaScheduler(schedule, self.bytes_per_s, clock)
        self.port = port if port is not None else PySerialPort(
            url, baudrate=baud, bytesize=bytesize, parity=parity, stopbits=stopbits, xonxoff=xonxoff,
            rtscts=rtscts, write_timeout_s=write_timeout_s, queue_max=queue_max, read_lines=read_lines,
        )  # fmt: skip
        self.received_ignored = 0  # input lines with no alerts to apply them to (issue 18)

    @classmethod
    def from_config(cls, cfg: NmeaPort, dark_prefix: str = "DARK", **kwargs: Any) -> NmeaSerialOutput:
        """Build from one `outputs.nmea[i]` entry of the appliance configuration."""
        return cls(cfg.url, schedule_from_config(cfg, dark_prefix), baud=cfg.baud, bytesize=cfg.bytesize,
                   parity=cfg.parity, stopbits=cfg.stopbits, read_lines=cfg.accept_acn, **kwargs)

    def start(self) -> None:
        self.port.start()

    def publish(self, fixes: Iterable[ShipFix], utc_ns: int = 0) -> list[tuple[str, ...]]:
        """Schedule this step's fixes and queue what fits the budget; returns the queued groups.
        Lines the port received (`accept_acn`) go to the port's alerts first (an ACN), or are counted."""
        if self.port.read_lines:
            for line in self.port.received():
                if self.scheduler.alerts is not None:
                    self.scheduler.alerts.receive(line)
                else:
                    self.received_ignored += 1
        groups = self.scheduler.step(fixes)
        for group in groups:
            self.port.submit("".join(group).encode("ascii"))
        return groups

    def publish_alerts(self) -> list[tuple[str, ...]]:
        """Only the alert sentences due now (the fan-out's call while no pair comes)."""
        groups = self.scheduler.step_alerts()
        for group in groups:
            self.port.submit("".join(group).encode("ascii"))
        return groups

    def close(self) -> None:
        """Give the writer CLOSE_DRAIN_S to send what is queued (the shutdown's L sentences);
        what is left then is counted as dropped, so every scheduled group is accounted for."""
        self.port.close(timeout_s=CLOSE_DRAIN_S, drain=True)

    def health(self) -> tuple[str | None, dict[str, int]]:
        """(fault text or None, counters) for `HealthMonitor.beat(..., fault=, counters=)`."""
        port, sched = self.port.stats(), self.scheduler.stats()
        fault = (
            "serial port lost" if port.fault
            else "serial port stalled" if port.stalled
            else "serial port not open" if not port.connected
            else None
        )  # fmt: skip
        counters = {
            "nmea_groups": sched.groups_sent, "nmea_refused": sched.refused, "nmea_waiting": sched.waiting,
            "serial_bytes": port.written_bytes, "serial_dropped": port.dropped,
            "serial_timeouts": port.write_timeouts, "serial_errors": port.errors,
            "serial_submitted": port.submitted, "serial_written": port.written_messages,
            **fix_counters(sched),
        }  # fmt: skip
        if self.scheduler.alerts is not None:  # issue 18: alert sentences and what was received
            counters.update(self.scheduler.alerts.counts)
            counters["alert_bytes"] = self.scheduler.alert_bytes_sent
        if self.port.read_lines:  # input: lines read, dropped, and those with no alerts to go to
            counters.update(serial_received=port.received_lines,
                            serial_received_dropped=port.received_dropped,
                            received_without_alerts=self.received_ignored)
        return fault, counters
