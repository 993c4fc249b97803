"""The alert manager: each step's fixes and health in, the state of every alert out, with a change log.

Alerts are keyed by internal track ids (never reused), so an alert stays tied to its ships; each
NMEA port renders the instance from its own target numbers (`edge.alerts.port`), Modbus from the
first port's. Identifiers (ALF field 9; the standard ones are the radar TT alerts seen in the field,
Furuno FAR-15x3's list: research/vts-ais-alerts.md):

| id    | alert                        | instance                       | priority | kind  |
|-------|------------------------------|--------------------------------|----------|-------|
| 190   | track capacity               | 1: 95 %, 2: full               | C / W    | state |
| 191   | close quarters (CPA/TCPA)    | 100 x lower + higher number    | alarm    | state |
| 192   | new target (T)               | target number                  | W        | event |
| 193   | target lost                  | target number                  | W        | event |
| 10001 | dark target (no AIS)         | target number                  | W        | state |
| 10002 | camera lost                  | 1 left, 2 right                | W        | state |
| 10003 | calibration invalid or drift | 1                              | W        | state |
| 10004 | processing stalled or fault  | 1                              | A        | state |

(3-digit target numbers: 1000 x lower + higher.) Ids >= 10000 are proprietary: ALF field 8
carries the manufacturer mnemonic (`alerts.manufacturer`).

States (ALF field 7): V active-unacknowledged, A active-acknowledged, N normal. A state alert
goes V on raise, A on acknowledgement (ACN), N once its condition is rectified (MSC.302 7.3.7:
a CPA alarm's signal may cease when rectified, so no rectified-unacknowledged U is held for a
remote sensor that may have no acknowledge path). An event alert (new, lost) goes V on raise and
N on acknowledgement or after `event_hold_s`. Every state change is a revision (1..99, wraps
to 1) and an entry in the change log that the ports read (`changes_since`).

Close quarters, for every pair of T tracks whose ground-plane motion is known (`ShipFix.en_state`):
CPA, TCPA and their 1-sigma from `edge.core.cpa` (eq. 18.2-18.5). Raise when CPA + k sigma is
below the limit and 0 < TCPA < the TCPA limit for `confirm_s` and at least MIN_UPDATES updates
in a row; clear when CPA - k sigma is above `clear_factor` x the limit, or TCPA is below
-`passed_s` (the ships have passed), or TCPA above `clear_factor` x its limit, for as long; or at
once when either ship's track is lost. Appliance faults and capacity raise and clear after
`confirm_s` likewise.
"""

from __future__ import annotations

import enum
import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from edge.appliance.health import HealthSnapshot, HealthState, Status
from edge.config.alerts import AlertsConfig
from edge.core.cpa import pair_cpa
from edge.fix import ShipFix, TrackStatus

MIN_UPDATES = 3  # a condition needs this many updates in a row besides confirm_s
MAX_LENGTH_M = 400.0  # a longer apparent length (merged boxes) does not widen the CPA limit
LOG_SIZE = 4096  # change-log entries kept for the ports


class AlertId(enum.IntEnum):
    CAPACITY = 190
    CLOSE_QUARTERS = 191
    NEW_TARGET = 192
    TARGET_LOST = 193
    DARK_TARGET = 10001
    CAMERA_LOST = 10002
    CALIBRATION = 10003
    PROCESSING = 10004


EVENT_IDS = frozenset({AlertId.NEW_TARGET, AlertId.TARGET_LOST})
PRIORITY = {AlertId.CAPACITY: "C", AlertId.CLOSE_QUARTERS: "A", AlertId.NEW_TARGET: "W",
            AlertId.TARGET_LOST: "W", AlertId.DARK_TARGET: "W", AlertId.CAMERA_LOST: "W",
            AlertId.CALIBRATION: "W", AlertId.PROCESSING: "A"}
CATEGORY = {AlertId.CLOSE_QUARTERS: "A", AlertId.NEW_TARGET: "A", AlertId.TARGET_LOST: "A"}  # else B


class AlertState(enum.StrEnum):
    ACTIVE_UNACK = "V"
    ACTIVE_ACK = "A"
    NORMAL = "N"


@dataclass(frozen=True, slots=True)
class Alert:
    """One alert's state; `tracks` are the track ids it is about (none for capacity and faults),
    `instance` the fixed instance of alerts without tracks."""

    alert_id: AlertId
    tracks: tuple[int, ...]
    instance: int
    state: AlertState
    revision: int
    changed_ns: int  # UTC of the last state change
    raised_ns: int
    cpa_m: float | None = None  # close quarters: the latest CPA and TCPA
    tcpa_s: float | None = None
    level: int = 0  # capacity: 1 = 95 %, 2 = full (the instance)

    @property
    def key(self) -> tuple[int, tuple[int, ...], int]:
        return int(self.alert_id), self.tracks, self.instance

    @property
    def active(self) -> bool:
        return self.state is not AlertState.NORMAL

    @property
    def priority(self) -> str:
        if self.alert_id is AlertId.CAPACITY and self.instance == 2:
            return "W"  # full: a warning; 95 %: a caution
        return PRIORITY[self.alert_id]

    @property
    def category(self) -> str:
        return CATEGORY.get(self.alert_id, "B")


@dataclass(slots=True)
class _Condition:
    """A condition's run of updates: since when it has held and how many updates."""

    since_ns: int | None = None
    updates: int = 0

    def feed(self, holds: bool, now_ns: int, confirm_s: float) -> bool:
        """True once it has held for confirm_s and MIN_UPDATES updates."""
        if not holds:
            self.since_ns, self.updates = None, 0
            return False
        if self.since_ns is None:
            self.since_ns = now_ns
        self.updates += 1
        return self.updates >= MIN_UPDATES and now_ns - self.since_ns >= confirm_s * 1e9


@dataclass(slots=True)
class _Pair:
    raise_run: _Condition
    clear_run: _Condition


Key = tuple[int, tuple[int, ...], int]


class AlertManager:
    """All alerts of the appliance; `step` once per processing step (see the module docstring)."""

    def __init__(self, config: AlertsConfig, max_tracks: int) -> None:
        self.cfg, self.max_tracks = config, max_tracks
        self.alerts: dict[Key, Alert] = {}  # active ones
        self.log: deque[tuple[int, Alert]] = deque(maxlen=LOG_SIZE)  # (sequence, alert after change)
        self.sequence = 0
        self.raised = 0  # alerts raised since start
        self.health_ok = True  # HBT status: the last health snapshot was OK
        self._pairs: dict[tuple[int, int], _Pair] = {}
        self._tracking: set[int] = set()  # track ids seen T and still live
        self._runs: dict[Key, tuple[_Condition, _Condition]] = {}  # fixed alerts: (raise, clear)
        self.last_utc_ns = 0
        self.stopped = False  # `stop`: every alert cleared, no new ones (the daemon is shutting down)

    # ------------------------------------------------------------ state changes
    def _emit(self, alert: Alert) -> None:
        self.sequence += 1
        self.log.append((self.sequence, alert))
        if alert.active:
            self.alerts[alert.key] = alert
        else:
            self.alerts.pop(alert.key, None)

    def _raise(self, alert_id: AlertId, tracks: tuple[int, ...], instance: int, now_ns: int,
               **values: float | None) -> None:
        key = (int(alert_id), tracks, instance)
        if key in self.alerts:
            return
        self.raised += 1
        self._emit(Alert(alert_id, tracks, instance, AlertState.ACTIVE_UNACK, 1, now_ns, now_ns,
                         **values))  # type: ignore[arg-type]

    def _change(self, key: Key, state: AlertState, now_ns: int) -> None:
        old = self.alerts.get(key)
        if old is None or old.state is state:
            return
        self._emit(replace(old, state=state, revision=old.revision % 99 + 1, changed_ns=now_ns))

    def acknowledge(self, key: Key, now_ns: int | None = None) -> bool:
        """ACN 'A' for an active alert: state alerts go A, event alerts end (N). False if unknown."""
        old = self.alerts.get(key)
        if old is None:
            return False
        t = self.last_utc_ns if now_ns is None else now_ns
        self._change(key, AlertState.NORMAL if old.alert_id in EVENT_IDS else AlertState.ACTIVE_ACK, t)
        return True

    def changes_since(self, sequence: int) -> list[tuple[int, Alert]]:
        """Change-log entries after `sequence` (oldest first)."""
        if not self.log or self.log[-1][0] <= sequence:
            return []
        return [e for e in self.log if e[0] > sequence]

    def active(self) -> list[Alert]:
        """Active alerts, most urgent first (alarm, warning, caution), then oldest first."""
        order = {"E": 0, "A": 1, "W": 2, "C": 3}
        return sorted(self.alerts.values(), key=lambda a: (order[a.priority], a.raised_ns, a.key))

    def stop(self, utc_ns: int) -> None:
        """The appliance stops: every active alert goes N (sent by the ports' next step) and no
        alert is raised any more (the shutdown's L fixes are not lost targets)."""
        for key in list(self.alerts):
            self._change(key, AlertState.NORMAL, utc_ns)
        self.stopped = True

    # ------------------------------------------------------------ per step
    def step(self, fixes: Sequence[ShipFix], utc_ns: int, health: HealthSnapshot | None = None) -> None:
        if self.stopped:
            return
        self.last_utc_ns = utc_ns
        live = [f for f in fixes if f.status is not TrackStatus.LOST]
        tracking = {f.track_id for f in live if f.status is TrackStatus.TRACKING}
        present = {f.track_id for f in live}
        self._events(tracking, present, utc_ns)
        self._close_quarters([f for f in live if f.status is TrackStatus.TRACKING], present, utc_ns)
        self._dark({f.track_id for f in live if f.dark and f.status is TrackStatus.TRACKING}, utc_ns)
        self._capacity(len(live), utc_ns)
        if health is not None:
            self._health(health, utc_ns)

    def health_step(self, utc_ns: int, health: HealthSnapshot) -> None:
        """No pair came (a camera gone): only the appliance-fault alerts and the HBT status move."""
        if not self.stopped:
            self.last_utc_ns = max(self.last_utc_ns, utc_ns)
            self._health(health, self.last_utc_ns)

    def _events(self, tracking: set[int], present: set[int], now_ns: int) -> None:
        for tid in sorted(tracking - self._tracking):
            self._raise(AlertId.NEW_TARGET, (tid,), 0, now_ns)
            lost = (int(AlertId.TARGET_LOST), (tid,), 0)
            if lost in self.alerts:  # it came back: not lost any more
                self._change(lost, AlertState.NORMAL, now_ns)
        for tid in sorted(self._tracking - present):
            self._raise(AlertId.TARGET_LOST, (tid,), 0, now_ns)
            new = (int(AlertId.NEW_TARGET), (tid,), 0)
            if new in self.alerts:
                self._change(new, AlertState.NORMAL, now_ns)
        self._tracking = (self._tracking & present) | tracking
        hold_ns = self.cfg.event_hold_s * 1e9
        for key, alert in list(self.alerts.items()):
            if alert.alert_id in EVENT_IDS and now_ns - alert.raised_ns >= hold_ns:
                self._change(key, AlertState.NORMAL, now_ns)

    def _limit_m(self, a: ShipFix, b: ShipFix) -> float:
        lengths = [min(x.length_m, MAX_LENGTH_M) for x in (a, b) if x.length_m is not None
                   and math.isfinite(x.length_m)]
        return max(self.cfg.cpa_m, self.cfg.length_factor * max(lengths, default=0.0))

    def _close_quarters(self, tracked: list[ShipFix], present: set[int], now_ns: int) -> None:
        cfg = self.cfg
        for key in [k for k in self.alerts if k[0] == AlertId.CLOSE_QUARTERS]:
            if not set(key[1]) <= present:  # a ship's track is gone: the lost alert takes over
                self._change(key, AlertState.NORMAL, now_ns)
        self._pairs = {p: s for p, s in self._pairs.items() if set(p) <= present}
        known = sorted((f for f in tracked if f.en_state is not None and f.en_cov is not None),
                       key=lambda f: f.track_id)
        ids = {f.track_id for f in known}
        for pair, state in self._pairs.items():  # not evaluated this step: a run must be in a row
            if not set(pair) <= ids:
                state.raise_run, state.clear_run = _Condition(), _Condition()
        if len(known) < 2:
            return
        states = np.array([f.en_state for f in known], float)
        covs = np.array([f.en_cov for f in known], float).reshape(-1, 4, 4)
        res = pair_cpa(states, covs)
        rows = zip(res.i.tolist(), res.j.tolist(), res.cpa_m.tolist(), res.tcpa_s.tolist(),
                   res.miss_sigma_m.tolist(), strict=True)
        for i, j, cpa, tcpa, sigma in rows:
            a, b = known[i], known[j]
            pair = (a.track_id, b.track_id)
            limit = self._limit_m(a, b)
            upper, lower = cpa + cfg.sigmas * sigma, cpa - cfg.sigmas * sigma
            state = self._pairs.setdefault(pair, _Pair(_Condition(), _Condition()))
            key = (int(AlertId.CLOSE_QUARTERS), pair, 0)
            if key in self.alerts:
                self.alerts[key] = replace(self.alerts[key], cpa_m=cpa, tcpa_s=tcpa)
                opened = lower > cfg.clear_factor * limit
                gone = tcpa < -cfg.passed_s or tcpa > cfg.clear_factor * cfg.tcpa_s
                if state.clear_run.feed(opened or gone, now_ns, cfg.confirm_s):
                    self._change(key, AlertState.NORMAL, now_ns)
                    state.raise_run = _Condition()
                continue
            danger = upper < limit and 0.0 < tcpa < cfg.tcpa_s  # eq. 18.2-18.5 against the limits
            if state.raise_run.feed(danger, now_ns, cfg.confirm_s):
                self._raise(AlertId.CLOSE_QUARTERS, pair, 0, now_ns, cpa_m=cpa, tcpa_s=tcpa)
                state.clear_run = _Condition()

    def _dark(self, dark: set[int], now_ns: int) -> None:
        for tid in sorted(dark):
            self._raise(AlertId.DARK_TARGET, (tid,), 0, now_ns)
        for key in [k for k in self.alerts if k[0] == AlertId.DARK_TARGET and k[1][0] not in dark]:
            self._change(key, AlertState.NORMAL, now_ns)

    def _fixed(self, alert_id: AlertId, instance: int, holds: bool, now_ns: int, **values: int) -> None:
        """An alert without tracks: raise / clear after confirm_s and MIN_UPDATES updates."""
        key = (int(alert_id), (), instance)
        raise_run, clear_run = self._runs.setdefault(key, (_Condition(), _Condition()))
        if key in self.alerts:
            if clear_run.feed(not holds, now_ns, self.cfg.confirm_s):
                self._change(key, AlertState.NORMAL, now_ns)
            raise_run.feed(False, now_ns, 0.0)
        else:
            if raise_run.feed(holds, now_ns, self.cfg.confirm_s):
                self._raise(alert_id, (), instance, now_ns, **values)
            clear_run.feed(False, now_ns, 0.0)

    def _capacity(self, live: int, now_ns: int) -> None:
        caution_at = math.ceil(self.cfg.capacity_share * self.max_tracks - 1e-9)
        full = live >= self.max_tracks
        self._fixed(AlertId.CAPACITY, 2, full, now_ns, level=2)
        self._fixed(AlertId.CAPACITY, 1, caution_at <= live and not full, now_ns, level=1)

    def _health(self, snap: HealthSnapshot, now_ns: int) -> None:
        self.health_ok = snap.state is HealthState.OK
        stages = {s.name: s for s in snap.stages}

        def bad(name: str) -> bool:
            s = stages.get(name)
            return s is not None and (not s.fresh or s.fault is not None)

        self._fixed(AlertId.CAMERA_LOST, 1, bad("camera_left"), now_ns)
        self._fixed(AlertId.CAMERA_LOST, 2, bad("camera_right"), now_ns)
        ais = stages.get("ais")  # issue 17's online check: a disparity or bearing offset beyond its bound
        drift = ais is not None and bool(ais.counters.get("disparity_fault")
                                         or ais.counters.get("bearing_fault"))
        calibration = drift or not snap.status_bits & Status.CALIBRATION_VALID or any(
            bad(n) for n in stages if n.startswith("calibration"))
        self._fixed(AlertId.CALIBRATION, 1, calibration, now_ns)
        self._fixed(AlertId.PROCESSING, 1, bad("processing"), now_ns)
