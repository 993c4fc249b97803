"""One NMEA port's alert sentences: what is due now, rendered with the port's own target numbers.

The `AlertManager` keeps the alerts; each port (`NmeaScheduler.alerts`) reads the manager's
change log and offers, in this order, the groups its scheduler must send before any track update
(alerts first, then T tracks: edge/outputs/schedule.py):

1. every changed alert (raise, acknowledgement, clear), most urgent first: ALF, or ALR on a
   legacy port (`outputs.nmea[i].alerts: alr`), or both;
2. ALC, the alert list, every `alerts.alc_s` while any alert is active (ALF ports);
3. HBT every `alerts.heartbeat_s`, A while the health is OK, else V;
4. each active alert again once `alerts.repeat_s` (<= 60 s) has passed since it last went out.

Each offer is one sentence (so it always fits the bucket's depth, >= one 82-character sentence)
and the last sentence of an item (an alert's ALF then ALR, the ALC list) comes with a callback the
scheduler calls once it fitted the byte budget, so an item that did not fit stays due and goes
out whole later (nothing is lost, the newest state of an alert wins). An alert
about a track that has no target number on this port (all numbers busy) is withheld and counted.

Received lines (`receive`): an ACN with a valid checksum whose alert is active here is applied
(A acknowledges; Q asks for the alert to be repeated now); every other line is ignored and counted.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Literal

from edge.alerts.manager import Alert, AlertId, AlertManager, AlertState, Key
from edge.config.alerts import AlertsConfig
from edge.encode.alerts import alc, alf, alr, hbt, parse_acn

Offer = tuple[tuple[str, ...], Callable[[], None]]
PRIORITY_ORDER = {"E": 0, "A": 1, "W": 2, "C": 3}
TEXTS = {
    AlertId.CAPACITY: "TRACKS",
    AlertId.NEW_TARGET: "NEW TARGET",
    AlertId.TARGET_LOST: "LOST TARGET",
    AlertId.DARK_TARGET: "DARK TARGET",
    AlertId.CALIBRATION: "CALIBRATION INVALID",
    AlertId.PROCESSING: "PROCESSING FAULT",
}


def _nothing() -> None:
    """The callback of an item's sentences before its last."""


class PortAlerts:
    """Alert sentence timing for one port; `offers` once per scheduler step."""

    def __init__(
        self,
        manager: AlertManager,
        config: AlertsConfig,
        *,
        talker: str = "RA",
        mode: Literal["alf", "alr", "both"] = "alf",
        digits: int = 2,
    ) -> None:
        self.manager, self.cfg, self.talker, self.mode, self.digits = manager, config, talker, mode, digits
        self._seen = 0  # manager change-log sequence read so far
        self._pending: dict[Key, Alert] = {}
        self._last_sent_s: dict[Key, float] = {}
        self._numbers: dict[int, int] = {}  # track id -> this port's target number (kept while referenced)
        self._alc_due_s = -math.inf
        self._alc_left: list[str] = []  # the current ALC list's sentences not yet sent
        self._hbt_due_s = -math.inf
        self._seq = {"ALF": 0, "ALC": 0, "HBT": 0}
        self.counts = dict.fromkeys(
            (
                "alf_sent",
                "alr_sent",
                "alc_sent",
                "hbt_sent",
                "alerts_withheld",
                "acn_applied",
                "acn_unknown",
                "received_ignored",
            ),
            0,
        )

    # ------------------------------------------------------------ instances and text
    def instance(self, alert: Alert) -> int | None:
        if not alert.tracks:
            return alert.instance
        numbers = [self._numbers.get(t) for t in alert.tracks]
        if any(n is None for n in numbers):
            return None
        ordered = sorted(n for n in numbers if n is not None)
        if len(ordered) == 1:
            return ordered[0]
        return ordered[0] * 10**self.digits + ordered[1]

    def text(self, alert: Alert) -> str:
        nums = sorted(self._numbers.get(t, 0) for t in alert.tracks)
        tgt = " ".join(f"{n:0{self.digits}d}" for n in nums)
        if alert.alert_id is AlertId.CLOSE_QUARTERS:
            cpa = "" if alert.cpa_m is None else f" {alert.cpa_m:.0f}M"
            tcpa = (
                ""
                if alert.tcpa_s is None or not math.isfinite(alert.tcpa_s)
                else f" {alert.tcpa_s / 60:.1f}MIN"
            )
            return f"CPA {tgt}{cpa}{tcpa}"
        if alert.alert_id is AlertId.CAPACITY:
            return "TRACKS FULL" if alert.instance == 2 else f"TRACKS {100 * self.cfg.capacity_share:.0f} PCT"
        if alert.alert_id is AlertId.CAMERA_LOST:
            return "CAMERA LEFT LOST" if alert.instance == 1 else "CAMERA RIGHT LOST"
        return f"{TEXTS[alert.alert_id]} {tgt}".strip()

    def _mfr(self, alert: Alert) -> str:
        return self.cfg.manufacturer if alert.alert_id >= 10000 else ""

    def _render(self, alert: Alert, instance: int) -> tuple[str, ...]:
        out: list[str] = []
        if self.mode in ("alf", "both"):
            self._seq["ALF"] = (self._seq["ALF"] + 1) % 10  # at rendering: an offer not sent leaves a gap
            out.append(
                alf(
                    self.talker,
                    self._seq["ALF"],
                    alert.changed_ns,
                    alert.category,
                    alert.priority,
                    alert.state.value,
                    self._mfr(alert),
                    int(alert.alert_id),
                    instance,
                    alert.revision,
                    self.text(alert),
                )
            )
        if self.mode in ("alr", "both"):
            out.append(
                alr(
                    self.talker,
                    alert.changed_ns,
                    int(alert.alert_id),
                    alert.active,
                    alert.state is AlertState.ACTIVE_ACK,
                    self.text(alert),
                )
            )
        return tuple(out)

    # ------------------------------------------------------------ per step
    def offers(self, now_s: float, number_of: Callable[[int], int | None]) -> list[Offer]:
        """The groups due now, in sending order, each with its 'sent' callback."""
        for _, alert in self.manager.changes_since(self._seen):
            self._pending[alert.key] = alert
        self._seen = self.manager.sequence
        active = self.manager.active()
        referenced = {t for a in (*active, *self._pending.values()) for t in a.tracks}
        for tid in referenced:
            n = number_of(tid)
            if n is not None:
                self._numbers[tid] = n
        self._numbers = {t: n for t, n in self._numbers.items() if t in referenced}
        out: list[Offer] = []
        changed = sorted(
            self._pending.values(), key=lambda a: (PRIORITY_ORDER[a.priority], a.changed_ns, a.key)
        )
        for alert in changed:
            self._offer_alert(out, alert, now_s, pending=True)
        with_instance = [(a, self.instance(a)) for a in active]
        if self.mode != "alr" and active and now_s >= self._alc_due_s and not self._alc_left:
            entries = [
                (self._mfr(a), int(a.alert_id), i, a.revision) for a, i in with_instance if i is not None
            ]
            self._alc_left = alc(self.talker, self._seq["ALC"], entries)  # kept until all went out
            self._seq["ALC"] = (self._seq["ALC"] + 1) % 100
        for k, line in enumerate(self._alc_left):  # the list's sentences go out in order, each once
            out.append(((line,), self._sent_alc_line(now_s, k == len(self._alc_left) - 1)))
        if self.cfg.heartbeat_s > 0 and now_s >= self._hbt_due_s:
            out.append(
                (
                    (hbt(self.talker, self.cfg.heartbeat_s, self.manager.health_ok, self._seq["HBT"]),),
                    self._sent_hbt(now_s),
                )
            )
        for alert in active:
            if (
                alert.key not in self._pending
                and now_s - self._last_sent_s.get(alert.key, -math.inf) >= self.cfg.repeat_s
            ):
                self._offer_alert(out, alert, now_s, pending=False)
        return out

    def _offer_alert(self, out: list[Offer], alert: Alert, now_s: float, pending: bool) -> None:
        instance = self.instance(alert)
        if instance is None:
            self.counts["alerts_withheld"] += 1
            if pending and not alert.active:  # a clear for an alert this port never could show
                self._pending.pop(alert.key, None)
            return
        self._item(out, self._render(alert, instance), self._sent_alert(alert, now_s))

    @staticmethod
    def _item(out: list[Offer], lines: Sequence[str], sent: Callable[[], None]) -> None:
        """One offer per sentence; the callback on the last."""
        for k, line in enumerate(lines):
            out.append(((line,), sent if k == len(lines) - 1 else _nothing))

    def _sent_alert(self, alert: Alert, now_s: float) -> Callable[[], None]:
        def sent() -> None:
            if self._pending.get(alert.key) is alert:
                del self._pending[alert.key]
            if alert.active:
                self._last_sent_s[alert.key] = now_s
            else:
                self._last_sent_s.pop(alert.key, None)
            if self.mode in ("alf", "both"):
                self.counts["alf_sent"] += 1
            if self.mode in ("alr", "both"):
                self.counts["alr_sent"] += 1

        return sent

    def _sent_alc_line(self, now_s: float, last: bool) -> Callable[[], None]:
        def sent() -> None:
            self._alc_left.pop(0)
            if last:
                self._alc_due_s = now_s + self.cfg.alc_s
                self.counts["alc_sent"] += 1

        return sent

    def _sent_hbt(self, now_s: float) -> Callable[[], None]:
        def sent() -> None:
            self._hbt_due_s = now_s + self.cfg.heartbeat_s
            self._seq["HBT"] = (self._seq["HBT"] + 1) % 10
            self.counts["hbt_sent"] += 1

        return sent

    # ------------------------------------------------------------ received
    def receive(self, line: str) -> bool:
        """Apply an ACN for an alert shown on this port; True if applied (else counted)."""
        acn = parse_acn(line)
        if acn is None:
            self.counts["received_ignored"] += 1
            return False
        _, alert_id, instance, command = acn
        for alert in self.manager.active():
            if int(alert.alert_id) == alert_id and self.instance(alert) == instance:
                if command == "A":
                    self.manager.acknowledge(alert.key)
                elif command == "Q":
                    self._last_sent_s.pop(alert.key, None)  # repeat it at the next step
                else:
                    self.counts["received_ignored"] += 1
                    return False
                self.counts["acn_applied"] += 1
                return True
        self.counts["acn_unknown"] += 1
        return False
