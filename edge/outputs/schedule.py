"""NMEA output scheduling: which track updates go out now, inside the byte budget of the line.

Every processing step hands the live fixes to `NmeaScheduler.step()`, which
returns the track updates (groups of TTM/TLL/TXY sentences, one group per
target) to send now. Rules (docs/nmea.md, "Line budget"):

- Byte budget: a token bucket filled at `bytes_per_s` (for a serial line the
  baud rate divided by the bits per character, e.g. 10 for 8N1, times a
  `utilisation` margin) and capped at ``max(0.25 s of budget, one largest
  group)``. Over any interval T the bytes handed out are at most
  ``bytes_per_s * T + capacity``, so nothing piles up behind a slow line.
- Fair refresh: live tracks go oldest-refreshed first (never-sent first, ties
  by track id), each at most once per `min_refresh_s`. A group that does not
  fit waits; nothing smaller jumps ahead of it.
- Priority: a dropped track (status L, or absent from the step's fixes) gets
  its last fix re-sent with status L `lost_repeats` times `lost_interval_s`
  apart, before any live update. After the last one its number goes into
  quarantine (`edge.encode.target_numbers`), so the number stays off the wire >= 60 s.
- A track enters NMEA once it is T (Q too only if `send_acquiring`); target
  numbers come from `TargetNumbers`. With all numbers busy a new track waits
  (counted, logged once) and is served in track-id order when one frees.
- Alerts first (issue 18): with `alerts` set (an `edge.alerts.port.PortAlerts`), its due
  sentences (ALF/ALR on change, ALC, HBT, repeats) are spent from the same bucket before any lost
  or live track update; one that does not fit holds everything behind it until the bucket refills.
- A fix that cannot be framed (e.g. a field too long for 82 characters) is
  refused and counted, never sent half-right.

Accounting (the soak checks it): every fix handed to `step` ends in exactly one counter of
`SchedulerStats`: ``fixes_in = fixes_sent + fixes_superseded + fixes_no_number +
fixes_not_eligible + fixes_refused + fixes_pending``. Sent: a group carrying it went out (a live
update, or the first L repeat of a dropped track's last fix). Superseded: a newer fix of the
same track replaced it before its refresh slot (`min_refresh_s`) or the byte budget let it out
(newest wins per track: a receiver wants the latest position, not a backlog). No number: it
was replaced while its track waited for a free target number. Not eligible: status Q without
`send_acquiring`, or an L fix of a track NMEA never carried. Pending: still held (the current
fix of a live or lost track), sent or superseded later.

The clock (monotonic seconds) is injectable; the scheduler itself does no
I/O, so its results are deterministic for a given clock. `edge.outputs.nmea_serial`
joins it to a serial port; the IEC 61162-450 UDP output is `edge.outputs.nmea_udp`, and
`replay` clocks it with the pairs' own timestamps on an unlimited line.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from edge.encode.nmea import (
    KINDS,
    MAX_SENTENCE_CHARS,
    NmeaError,
    check_manufacturer,
    check_talker,
    track_sentences,
)
from edge.encode.target_numbers import TargetNumbers
from edge.fix import ShipFix, TrackStatus

if TYPE_CHECKING:
    from edge.alerts.port import PortAlerts
    from edge.config.app import NmeaPort, UdpConfig

log = logging.getLogger(__name__)

BURST_S = 0.25  # token-bucket depth in seconds of budget (at least one whole group)


@dataclass(frozen=True, kw_only=True)
class NmeaSchedule:
    """What an NMEA output sends and how often (shared by the serial and UDP outputs)."""

    sentences: tuple[str, ...] = ("TTM", "TLL")  # any of KINDS; TXY = proprietary x/y, off by default
    talker: str = "RA"  # RA radar, II, U0..U9
    manufacturer: str = "XXX"  # TXY's NMEA manufacturer code: XXX is a placeholder, get a real one
    send_acquiring: bool = False  # also send tentative tracks, with status Q
    max_target_number: int = 99  # numbers 1..N; above 99 they have 3 digits
    min_refresh_s: float = 1.0  # never resend one track sooner than this
    lost_repeats: int = 3  # times a dropped track is sent with status L
    lost_interval_s: float = 1.0  # time between those L sentences
    quarantine_s: float = 60.0  # a number stays unused this long after its last L
    dark_prefix: str = "DARK"  # name prefix of a dark track (ais.dark_prefix, issue 17)

    def __post_init__(self) -> None:
        if not self.sentences or set(self.sentences) - set(KINDS):
            raise ValueError(f"sentences must be a non-empty subset of {KINDS}, got {self.sentences}")
        check_talker(self.talker)
        check_manufacturer(self.manufacturer)
        if self.lost_repeats < 1 or min(self.min_refresh_s, self.lost_interval_s, self.quarantine_s) < 0:
            raise ValueError(f"need lost_repeats >= 1 and non-negative times: {self}")


DEFAULT_SCHEDULE = NmeaSchedule()


@dataclass(frozen=True, slots=True)
class SchedulerStats:
    groups_sent: int  # track updates handed out (live and lost)
    lost_groups_sent: int  # of which status-L repeats
    bytes_sent: int
    refused: int  # fixes that could not be framed (NmeaError)
    tracks_waited: int  # tracks that found all target numbers busy
    fixes_in: int  # fixes handed to step(); the identity of the module docstring holds
    fixes_sent: int
    fixes_superseded: int
    fixes_no_number: int
    fixes_not_eligible: int
    fixes_refused: int
    live: int  # live tracks known to the scheduler
    waiting: int  # live tracks without a number right now
    lost_pending: int  # dropped tracks whose L repeats are not all sent yet
    fixes_pending: int  # fixes held now (a live or lost track's current fix), not yet sent

    @property
    def fixes_dropped(self) -> int:
        """Fixes that will never go out, each for a documented reason."""
        return self.fixes_superseded + self.fixes_no_number + self.fixes_not_eligible + self.fixes_refused


@dataclass(slots=True)
class _Live:
    fix: ShipFix
    number: int | None
    last_sent_s: float = -math.inf
    waited: bool = False  # found all numbers busy at least once
    unsent: bool = True  # `fix` has not gone out yet (the accounting's pending)


@dataclass(slots=True)
class _Lost:
    fix: ShipFix  # the last fix, with status L
    number: int
    remaining: int
    due_s: float
    unsent: bool = True


class NmeaScheduler:
    """Round-robin track updates inside a byte budget; see the module docstring for the rules."""

    def __init__(
        self,
        schedule: NmeaSchedule,
        bytes_per_s: float | None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if bytes_per_s is not None and not bytes_per_s > 0:
            raise ValueError(f"bytes_per_s must be > 0 or None (unlimited), got {bytes_per_s}")
        self.schedule = schedule
        self.bytes_per_s = bytes_per_s
        self.capacity = (
            math.inf
            if bytes_per_s is None
            else max(bytes_per_s * BURST_S, MAX_SENTENCE_CHARS * len(schedule.sentences))
        )
        self.numbers = TargetNumbers(schedule.max_target_number, schedule.quarantine_s)
        self._clock = clock
        self._tokens = self.capacity
        self._last_s: float | None = None
        self._live: dict[int, _Live] = {}
        self._lost: dict[int, _Lost] = {}  # by track id
        keys = ("groups_sent", "lost_groups_sent", "bytes_sent", "refused", "tracks_waited", "fixes_in",
                "fixes_sent", "fixes_superseded", "fixes_no_number", "fixes_not_eligible", "fixes_refused")
        self._counts = dict.fromkeys(keys, 0)
        self.alerts: PortAlerts | None = None  # alert sentences, sent first (issue 18)
        self.alert_groups_sent = 0
        self.alert_bytes_sent = 0
        self.alert_errors = 0

    def step(self, fixes: Iterable[ShipFix]) -> list[tuple[str, ...]]:
        """Take this step's live fixes; return the groups of sentences to send now, in order."""
        now_s = self._clock()
        self._refill(now_s)
        self._update(fixes, now_s)
        out: list[tuple[str, ...]] = []
        if self.alerts is not None and not self._alerts_first(now_s, out):  # no track while one waits
            return out
        for lost in sorted(self._lost.values(), key=lambda e: (e.due_s, e.number)):
            if lost.due_s > now_s:
                break
            group = self._render(lost.fix, lost.number)
            if group and not self._spend(group, out):
                return out
            self._counts["lost_groups_sent"] += bool(group)
            if lost.unsent:
                self._counts["fixes_sent" if group else "fixes_refused"] += 1
                lost.unsent = False
            lost.remaining -= 1
            lost.due_s = now_s + self.schedule.lost_interval_s
            if lost.remaining <= 0 or not group:
                del self._lost[lost.fix.track_id]
                self.numbers.retire(lost.number, now_s)
        due = [t for t in self._live.values() if t.number is not None
               and now_s - t.last_sent_s >= self.schedule.min_refresh_s]  # fmt: skip
        for track in sorted(due, key=lambda t: (t.last_sent_s, t.fix.track_id)):
            assert track.number is not None  # due holds numbered tracks only
            group = self._render(track.fix, track.number)
            if group and not self._spend(group, out):
                break
            track.last_sent_s = now_s
            if track.unsent:
                self._counts["fixes_sent" if group else "fixes_refused"] += 1
                track.unsent = False
        return out

    def step_alerts(self) -> list[tuple[str, ...]]:
        """Only the alert sentences due now, inside the budget (no pair came: no track update)."""
        now_s = self._clock()
        self._refill(now_s)
        out: list[tuple[str, ...]] = []
        self._alerts_first(now_s, out)
        return out

    def _alerts_first(self, now_s: float, out: list[tuple[str, ...]]) -> bool:
        """Spend the due alert sentences; False when one did not fit (it waits, and so do tracks).
        An error in them is counted and logged once: the track updates go on."""
        if self.alerts is None:
            return True
        try:
            offers = self.alerts.offers(now_s, self.numbers.reserved_for)
        except Exception as exc:
            if not self.alert_errors:
                log.warning("NMEA: alert sentences failed (counted, logged once): %r", exc)
            self.alert_errors += 1
            return True
        for group, sent in offers:
            if not self._spend(group, out, alert=True):
                return False
            sent()
        return True

    def stats(self) -> SchedulerStats:
        return SchedulerStats(
            **self._counts,
            live=len(self._live),
            waiting=sum(t.number is None for t in self._live.values()),
            lost_pending=len(self._lost),
            fixes_pending=sum(t.unsent for t in self._live.values())
            + sum(e.unsent for e in self._lost.values()),
        )

    def _refill(self, now_s: float) -> None:
        if self._last_s is not None and self.bytes_per_s is not None:
            elapsed_s = max(0.0, now_s - self._last_s)
            self._tokens = min(self.capacity, self._tokens + elapsed_s * self.bytes_per_s)
        self._last_s = now_s

    def _spend(self, group: tuple[str, ...], out: list[tuple[str, ...]], alert: bool = False) -> bool:
        cost = sum(len(line) for line in group)
        if cost > self._tokens:
            return False
        self._tokens -= cost
        out.append(group)
        if alert:  # not a track update: kept out of the track accounting
            self.alert_groups_sent += 1
            self.alert_bytes_sent += cost
            return True
        self._counts["groups_sent"] += 1
        self._counts["bytes_sent"] += cost
        return True

    def _render(self, fix: ShipFix, number: int) -> tuple[str, ...]:
        cfg = self.schedule
        try:
            return tuple(track_sentences(fix, number, cfg.sentences, talker=cfg.talker,
                                         manufacturer=cfg.manufacturer, digits=self.numbers.digits,
                                         dark_prefix=cfg.dark_prefix))
        except NmeaError as exc:
            if not self._counts["refused"]:
                log.warning("NMEA: track %d refused (counted, logged once): %s", fix.track_id, exc)
            self._counts["refused"] += 1
            return ()

    def _update(self, fixes: Iterable[ShipFix], now_s: float) -> None:
        given = list(fixes)
        latest = {fix.track_id: fix for fix in given}
        self._counts["fixes_in"] += len(given)
        self._counts["fixes_superseded"] += len(given) - len(latest)  # two fixes of one track in a step
        used: set[int] = set()  # L fixes that became a dropped track's last word
        for track_id in list(self._live):
            fix = latest.get(track_id)
            if fix is None or fix.status is TrackStatus.LOST:
                self._drop(track_id, fix, now_s)
                if fix is not None:
                    used.add(track_id)
        wanted = {TrackStatus.TRACKING, TrackStatus.ACQUIRING} if self.schedule.send_acquiring else {
            TrackStatus.TRACKING}  # fmt: skip
        for track_id in sorted(latest):
            fix = latest[track_id]
            track = self._live.get(track_id)
            if track is not None:
                if track.unsent:
                    self._counts["fixes_superseded" if track.number is not None else "fixes_no_number"] += 1
                track.fix, track.unsent = fix, True
            elif fix.status in wanted:
                back = self._lost.pop(track_id, None)  # a dropped track that came back keeps its number
                if back is not None and back.unsent:
                    self._counts["fixes_superseded"] += 1
                track = self._live[track_id] = _Live(fix, None)
            else:
                if track_id not in used:
                    self._counts["fixes_not_eligible"] += 1
                continue
            if track.number is None:
                track.number = self.numbers.assign(track_id, now_s)
                if track.number is None and not track.waited:
                    if not self._counts["tracks_waited"]:
                        log.warning("NMEA: all %d target numbers busy; new tracks wait (logged once)",
                                    self.numbers.max_number)
                    self._counts["tracks_waited"] += 1
                    track.waited = True

    def _drop(self, track_id: int, fix: ShipFix | None, now_s: float) -> None:
        track = self._live.pop(track_id)
        number = self.numbers.release(track_id)
        if number is None:  # it never had a number: its held fix and an L fix go nowhere
            self._counts["fixes_no_number"] += track.unsent + (fix is not None)
            return
        if fix is not None and track.unsent:
            self._counts["fixes_superseded"] += 1  # the L fix replaces the unsent one
        last = fix if fix is not None else dataclasses.replace(track.fix, status=TrackStatus.LOST)
        unsent = fix is not None or track.unsent
        self._lost[track_id] = _Lost(last, number, self.schedule.lost_repeats, now_s, unsent)


def fix_counters(stats: SchedulerStats) -> dict[str, int]:
    """The fix accounting as health counters: in = sent + dropped + pending."""
    return {"nmea_fixes_in": stats.fixes_in, "nmea_fixes_sent": stats.fixes_sent,
            "nmea_fixes_dropped": stats.fixes_dropped, "nmea_fixes_pending": stats.fixes_pending}


def schedule_from_config(cfg: NmeaPort | UdpConfig, dark_prefix: str = "DARK") -> NmeaSchedule:
    """The `NmeaSchedule` of an `outputs.nmea[i]` or `outputs.udp` configuration entry."""
    sentences: tuple[str, ...]  # the configured kinds, and TXY if proprietary
    sentences, manufacturer = tuple(cfg.sentences), "XXX"
    proprietary = getattr(cfg, "proprietary", None)
    if proprietary is not None and proprietary.enabled:
        sentences, manufacturer = (*sentences, "TXY"), proprietary.manufacturer
    talker = cfg.talker if hasattr(cfg, "talker") else cfg.source[:2]  # UDP: the talker of its s: source
    return NmeaSchedule(sentences=sentences, talker=talker, manufacturer=manufacturer,
                        send_acquiring=getattr(cfg, "send_acquiring", False), dark_prefix=dark_prefix)
