"""ASTERIX output: every step's fixes as CAT 010 target reports, and the sensor's status, over UDP.

Each `publish` turns the step's fixes into one type 1 record per T, L and (with `send_acquiring`)
Q track, packed into data blocks of at most 1,472 bytes, one block per datagram to the tracks
destination. A track absent from the step (dropped by the tracker) gets one more report of its
last fix with I010/170 TRE set, and its track number goes into quarantine (`TargetNumbers` with
4,095 numbers and `quarantine_s`): numbers are lent least-recently-used first, so a number comes
back only long after its track ended. `close` (shutdown, reload) ends every track the same way.

Status: a periodic status record (type 3) every `status_period_s` and an event status record
(type 4) at once when I010/550 changes, to the status destination (the tracks one by default);
with `cat034` a CAT 034 service message each period too. I010/550 comes from the health:
NOGO degraded while DEGRADED, NOGO while STALLED, TSV while the clock is not synchronised, OVL
while processing drops pairs or is later than `overload_latency_s`. The fan-out also calls
`publish_status` while no pair comes, so a camera unplugged shows in the next status message.

Sends are non-blocking (`drivers.udp`): a network fault is counted, shown in health and the
socket reopened with backoff; `publish` never waits. Without a sender (replay writing a file)
the blocks are only returned. Accounting: fixes in = reported + dropped (refused: not codable;
no number: all 4,095 busy; not eligible: Q without `send_acquiring`; superseded: a second fix
of one track in a step), and every block handed to a sender is sent or counted dropped there.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from typing import Protocol

from drivers.udp import MulticastUdpSender, UdpStats
from edge.appliance.health import HealthSnapshot, Status
from edge.config.asterix import AsterixConfig, AsterixDestination
from edge.core.geodesy import ellipsoidal_height_m
from edge.core.site import Site
from edge.encode.asterix import cat010, cat034
from edge.encode.asterix.blocks import pack_blocks
from edge.encode.asterix.cat010 import SensorStatus, Source
from edge.encode.asterix.items import TargetType
from edge.encode.target_numbers import TargetNumbers
from edge.fix import ShipFix, TrackStatus

log = logging.getLogger(__name__)

MAX_TRACK_NUMBER = 4095  # I010/161: 12 bits (0 is not used)


class BlockSender(Protocol):
    """What carries a data block: `drivers.udp` senders."""

    def send(self, datagram: bytes) -> bool: ...

    def stats(self) -> UdpStats: ...

    def close(self) -> None: ...


def sensor_position(site: Site) -> tuple[float, float, float]:
    """What CAT 034 I034/120 states: the site's latitude, longitude and height above the WGS-84
    ellipsoid, which needs the site's geoid separation (`site.geoid_separation_m`). Without it the
    height above mean sea level is sent (off by the geoid separation there, at most
    `GEOID_SEPARATION_BOUND_M` anywhere), logged once here."""
    height_m = ellipsoidal_height_m(site)
    if height_m is None:
        log.info("ASTERIX I034/120: site.geoid_separation_m not given, the height above mean sea level "
                 "(%.1f m) goes out as the ellipsoidal height", site.height_m)
        height_m = site.height_m
    return site.lat_deg, site.lon_deg, height_m


def udp_sender(dest: AsterixDestination) -> MulticastUdpSender:
    return MulticastUdpSender(dest.address, dest.port, interface=dest.interface, ttl=dest.ttl)


class AsterixOutput:
    """CAT 010 reports and status to one or two UDP destinations; see the module docstring."""

    stage = "asterix"
    unit = "asterix_blocks"

    def __init__(self, cfg: AsterixConfig, *, tracks: BlockSender | None = None,
                 status: BlockSender | None = None, health: Callable[[], HealthSnapshot] | None = None,
                 site: tuple[float, float, float] | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.cfg = cfg
        typ = TargetType.PSR if cfg.target_type == "psr" else TargetType.OTHER
        self.source = Source(cfg.sac, cfg.sic, typ)
        self.tracks_sender = tracks
        self.status_sender = status if status is not None else tracks
        self.health_source = health
        self.site = site
        self._clock = clock
        self.numbers = TargetNumbers(MAX_TRACK_NUMBER, cfg.quarantine_s)
        self._live: dict[int, tuple[ShipFix, int]] = {}  # track id -> (last fix reported, number)
        self._status: SensorStatus | None = None  # the last I010/550 sent
        self._status_due_s = -float("inf")
        self._dropped_pairs = 0
        keys = ("fixes_in", "fixes_reported", "refused", "no_number", "not_eligible", "superseded",
                "tracks_ended", "records", "blocks", "bytes", "status_periodic", "status_event", "cat034")
        self.counts = dict.fromkeys(keys, 0)
        self.ended: list[tuple[int, int]] = []  # (track id, number) of every TRE sent, for tests and tools

    @classmethod
    def from_config(cls, cfg: AsterixConfig, health: Callable[[], HealthSnapshot] | None = None,
                    site: tuple[float, float, float] | None = None,
                    clock: Callable[[], float] = time.monotonic) -> AsterixOutput:
        """UDP senders for the configured destinations (one socket when status goes with tracks)."""
        tracks = udp_sender(cfg.tracks)
        status = None if cfg.status is None or cfg.status == cfg.tracks else udp_sender(cfg.status)
        return cls(cfg, tracks=tracks, status=status, health=health, site=site, clock=clock)

    def start(self) -> None:
        """Nothing to open: the sockets are made at the first send and never block."""

    # ------------------------------------------------------------------ target reports
    def publish(self, fixes: Sequence[ShipFix], utc_ns: int) -> list[bytes]:
        """This step's reports (and any status due); returns the data blocks handed out."""
        now_s = self._clock()
        latest: dict[int, ShipFix] = {}
        for fix in fixes:
            latest[fix.track_id] = fix
        self.counts["fixes_in"] += len(fixes)
        self.counts["superseded"] += len(fixes) - len(latest)
        records = self._ended([tid for tid in self._live if tid not in latest], now_s)
        for track_id in sorted(latest):
            fix = latest[track_id]
            if fix.status is TrackStatus.ACQUIRING and not self.cfg.send_acquiring:
                self.counts["not_eligible"] += 1
                continue
            number = self.numbers.assign(track_id, now_s)
            if number is None:
                if not self.counts["no_number"]:
                    log.warning("ASTERIX: all %d track numbers busy; new tracks wait (logged once)",
                                MAX_TRACK_NUMBER)
                self.counts["no_number"] += 1
                continue
            try:
                records.append(cat010.target_report(fix, number, self.source))
            except ValueError as exc:
                if not self.counts["refused"]:
                    log.warning("ASTERIX: track %d refused (counted, logged once): %s", track_id, exc)
                self.counts["refused"] += 1
                continue
            self._live[track_id] = (fix, number)
            self.counts["fixes_reported"] += 1
        if self.cfg.start_of_update:
            records.insert(0, cat010.start_of_update(self.source, utc_ns))
        blocks = self._send(self.tracks_sender, cat010.CATEGORY, records)
        return blocks + self.publish_status(utc_ns)

    def _ended(self, track_ids: list[int], now_s: float) -> list[bytes]:
        """The TRE reports of tracks that ended; their numbers go into quarantine."""
        records = []
        for track_id in sorted(track_ids):
            fix, number = self._live.pop(track_id)
            records.append(cat010.target_report(fix, number, self.source, last=True))
            self.numbers.release(track_id)
            self.numbers.retire(number, now_s)
            self.counts["tracks_ended"] += 1
            self.ended.append((track_id, number))
        return records

    def finish(self) -> list[bytes]:
        """End every live track now (TRE); returns the blocks (replay writes them, close sends them)."""
        return self._send(self.tracks_sender, cat010.CATEGORY, self._ended(list(self._live), self._clock()))

    # ------------------------------------------------------------------ status
    def sensor_status(self) -> SensorStatus:
        """I010/550 from the health now (a replay, without health: operational, time valid)."""
        if self.health_source is None:
            return SensorStatus()
        snap = self.health_source()
        processing = next((s for s in snap.stages if s.name == "processing"), None)
        dropped = 0 if processing is None else processing.counters.get("dropped_pairs", 0)
        late = snap.latency_s is not None and snap.latency_s > self.cfg.overload_latency_s
        overloaded = dropped > self._dropped_pairs or late
        self._dropped_pairs = dropped
        synchronised = bool(snap.status_bits & Status.TIME_SYNC)
        return cat010.sensor_status(snap.state, synchronised, overloaded)

    def publish_status(self, utc_ns: int) -> list[bytes]:
        """The status messages due now: an event on a change, the periodic one when its time comes."""
        now_s = self._clock()
        status = self.sensor_status()
        records: list[bytes] = []
        if self._status is not None and status != self._status:
            records.append(cat010.status_report(self.source, utc_ns, status, event=True))
            self.counts["status_event"] += 1
        periodic = now_s >= self._status_due_s
        if periodic:
            records.append(cat010.status_report(self.source, utc_ns, status))
            self.counts["status_periodic"] += 1
            self._status_due_s = now_s + self.cfg.status_period_s
        self._status = status
        blocks = self._send(self.status_sender, cat010.CATEGORY, records)
        if periodic and self.cfg.cat034:
            self.counts["cat034"] += 1
            blocks += self._send(self.status_sender, cat034.CATEGORY,
                                 [cat034.service_message(self.source, utc_ns, status, self.site)])
        return blocks

    # ------------------------------------------------------------------ transport
    def _send(self, sender: BlockSender | None, category: int, records: list[bytes]) -> list[bytes]:
        if not records:
            return []
        blocks = pack_blocks(category, records)
        self.counts["records"] += len(records)
        self.counts["blocks"] += len(blocks)
        self.counts["bytes"] += sum(len(b) for b in blocks)
        if sender is not None:
            for block in blocks:
                sender.send(block)
        return blocks

    def _senders(self) -> list[BlockSender]:
        found: list[BlockSender] = []
        for s in (self.tracks_sender, self.status_sender):
            if s is not None and all(s is not f for f in found):
                found.append(s)
        return found

    def health(self) -> tuple[str | None, dict[str, int]]:
        """(fault text or None, counters) for `HealthMonitor.beat`."""
        stats = [s.stats() for s in self._senders()]
        fault = "ASTERIX UDP output failing" if any(st.fault for st in stats) else None
        c = self.counts
        return fault, {
            "asterix_fixes_in": c["fixes_in"], "asterix_fixes_reported": c["fixes_reported"],
            "asterix_fixes_dropped": c["refused"] + c["no_number"] + c["not_eligible"] + c["superseded"],
            "asterix_tracks_ended": c["tracks_ended"], "asterix_records": c["records"],
            "asterix_blocks_out": c["blocks"],
            "asterix_status_messages": c["status_periodic"] + c["status_event"],
            "asterix_udp_datagrams": sum(st.sent_datagrams for st in stats),
            "asterix_udp_dropped": sum(st.dropped for st in stats),
            "asterix_udp_errors": sum(st.errors for st in stats),
        }

    def close(self) -> None:
        """End every track (TRE), then release the sockets. Safe to call twice."""
        try:
            self.finish()
        except Exception as exc:  # shutting down: report, never raise
            log.warning("ASTERIX: could not end the tracks at close: %s", exc)
        for sender in self._senders():
            sender.close()
