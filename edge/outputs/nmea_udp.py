"""IEC 61162-450 output: the scheduled NMEA sentences as ``UdPbC`` datagrams over UDP multicast.

Optional and off by default. Each sentence travels in its own datagram,
``UdPbC\\0`` + tag block ``\\s:RA0001,n:<line count>*hh\\`` + sentence; the
``n:`` counter runs 1..999 per output so receivers can detect losses. Which
track updates go out when is decided by the same `NmeaScheduler` as on
serial; by default without a byte budget (the network is not the limit), so
every live track is refreshed once per ``min_refresh_s``. The socket is
non-blocking (`drivers.udp`): `publish()` never waits. Tag blocks are never
put on a serial line; this module is the only place that frames them.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any

from drivers.udp import MulticastUdpSender, UdpSenderBase
from edge.encode.nmea import next_line_count, tag_block, udpbc_datagram
from edge.fix import ShipFix
from edge.outputs.schedule import (
    DEFAULT_SCHEDULE,
    NmeaSchedule,
    NmeaScheduler,
    fix_counters,
    schedule_from_config,
)

if TYPE_CHECKING:
    from edge.config.app import UdpConfig

TGTD_GROUP = "239.192.0.2"  # IEC 61162-450 transmission group for target data (verify against the standard)
TGTD_PORT = 60002


class NmeaUdpOutput:
    """Scheduler + UDP sender for IEC 61162-450 datagrams."""

    stage = "nmea"
    unit = "nmea_udp_datagrams"

    def __init__(
        self,
        schedule: NmeaSchedule = DEFAULT_SCHEDULE,
        *,
        group: str = TGTD_GROUP,
        port: int = TGTD_PORT,
        interface: str | None = None,
        ttl: int = 1,
        source: str = "RA0001",
        bytes_per_s: float | None = None,
        sender: UdpSenderBase | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        tag_block(source, 1)  # refuse a bad source now, not at the first send
        self.source = source
        self.scheduler = NmeaScheduler(schedule, bytes_per_s, clock)
        self.sender = sender if sender is not None else MulticastUdpSender(
            group, port, interface=interface, ttl=ttl
        )
        self._line_count = 1

    @classmethod
    def from_config(cls, cfg: UdpConfig, dark_prefix: str = "DARK",
                    **kwargs: Any) -> NmeaUdpOutput:
        """Build from the `outputs.udp` entry of the appliance configuration."""
        return cls(schedule_from_config(cfg, dark_prefix), group=cfg.group, port=cfg.port,
                   interface=cfg.interface, ttl=cfg.ttl, source=cfg.source, **kwargs)

    def start(self) -> None:
        """Nothing to open: the socket is made at construction and never blocks."""

    def publish(self, fixes: Iterable[ShipFix], utc_ns: int = 0) -> list[bytes]:
        """Schedule this step's fixes and send one datagram per sentence; returns the datagrams."""
        return self._send(self.scheduler.step(fixes))

    def publish_alerts(self) -> list[bytes]:
        """Only the alert sentences due now (the fan-out's call while no pair comes)."""
        return self._send(self.scheduler.step_alerts())

    def _send(self, groups: list[tuple[str, ...]]) -> list[bytes]:
        datagrams = []
        for group in groups:
            for line in group:
                datagram = udpbc_datagram(line, self.source, self._line_count)
                self._line_count = next_line_count(self._line_count)
                self.sender.send(datagram)
                datagrams.append(datagram)
        return datagrams

    def close(self) -> None:
        self.sender.close()

    def health(self) -> tuple[str | None, dict[str, int]]:
        """(fault text or None, counters) for `HealthMonitor.beat(..., fault=, counters=)`."""
        stats = self.sender.stats()
        fault = "UDP output failing" if stats.fault else None
        return fault, {"udp_datagrams": stats.sent_datagrams, "udp_dropped": stats.dropped,
                       "udp_errors": stats.errors, "nmea_refused": self.scheduler.stats().refused,
                       **fix_counters(self.scheduler.stats())}
