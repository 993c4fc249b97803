"""Health: per-stage heartbeats summarised as OK / DEGRADED / STALLED plus a reason.

Every stage of the appliance (each camera, processing, each output) calls
`HealthMonitor.beat()` whenever it makes progress, optionally with a fault
description, a frame count, a latency and free-form counters. `snapshot()`
turns the latest beats into one immutable `HealthSnapshot`: the overall state
and why, the Modbus status bits and fault code, frame rate, latency and
uptime. The daemon feeds it to the Modbus health block, the LEDs and
sd_notify (WATCHDOG=1 only while the state is not STALLED).

Rules (a stage is *fresh* when its last beat is younger than `stall_after_s`):
- STALLED: a critical stage is not fresh (or has never beaten);
- DEGRADED: every critical stage is fresh, but some stage reports a fault, a
  non-critical stage (an output) is not fresh, or the frame rate is below `min_rate_hz`;
- OK: every stage is fresh and fault-free.
The worst problem gives the reason and the fault code `10 * stage.code + kind`
(kind 1 = no heartbeat, 2 = fault reported), so a PLC shows e.g. 32 for
"processing reports a fault". The clock is injectable (monotonic seconds) so
tests step time by hand; beats may come from any thread.
"""

from __future__ import annotations

import enum
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

FAULT_KIND_NO_HEARTBEAT = 1
FAULT_KIND_REPORTED = 2


class HealthState(enum.Enum):
    OK = "OK"
    DEGRADED = "DEGRADED"
    STALLED = "STALLED"


class Status(enum.IntFlag):
    """Bits of the Modbus STATUS register (docs/operations.md, docs/modbus.md)."""

    OK = 1 << 0
    CAMERA_LEFT = 1 << 1
    CAMERA_RIGHT = 1 << 2
    CALIBRATION_VALID = 1 << 3
    TRACKER_RUNNING = 1 << 4
    TIME_SYNC = 1 << 5
    NMEA_ACTIVE = 1 << 6
    SITE_SURVEYED = 1 << 7
    DEGRADED = 1 << 8
    FAULT = 1 << 15


@dataclass(frozen=True, slots=True)
class Stage:
    """A monitored stage: what it vouches for while fresh and fault-free."""

    name: str
    code: int  # 1..6553: fault code = 10 * code + kind
    stall_after_s: float  # no beat for this long -> not fresh
    bits: Status = Status(0)  # status bits set while fresh and fault-free
    critical: bool = True  # not fresh -> STALLED (else DEGRADED)


def standard_stages(outputs: Iterable[tuple[str, Status]] = (), *, stall_after_s: float = 2.0
                    ) -> tuple[Stage, ...]:
    """The appliance's stages: both cameras, processing, then one per output.

    `outputs` gives (name, status bit) per output, e.g. ("nmea", Status.NMEA_ACTIVE);
    outputs are non-critical and get codes 4, 5, ... `stall_after_s` (`health.stale_s`) is how
    long a critical stage may stay silent; outputs get at least 5 s (they beat once per step).
    """
    stages = [
        Stage("camera_left", 1, stall_after_s, Status.CAMERA_LEFT),
        Stage("camera_right", 2, stall_after_s, Status.CAMERA_RIGHT),
        Stage("processing", 3, stall_after_s, Status.TRACKER_RUNNING),
    ]
    for i, (name, bits) in enumerate(outputs):
        stages.append(Stage(name, 4 + i, max(5.0, stall_after_s), bits, critical=False))
    return tuple(stages)


@dataclass(frozen=True, slots=True)
class StageHealth:
    name: str
    fresh: bool
    age_s: float | None  # since the last beat; None if it never beat
    fault: str | None
    counters: Mapping[str, int]


@dataclass(frozen=True, slots=True)
class HealthSnapshot:
    state: HealthState
    reason: str  # "" when OK, else "<stage>: <what>"
    status_bits: int  # Status flags as the u16 register value
    fault_code: int  # 0 = none
    frame_rate_hz: float | None  # of the rate stage, over the rate window
    latency_s: float | None  # largest latency reported by a fresh stage
    uptime_s: float
    stages: tuple[StageHealth, ...] = field(default=())


@dataclass(slots=True)
class _Beat:
    t_s: float | None = None
    fault: str | None = None
    latency_s: float | None = None
    counters: dict[str, int] = field(default_factory=dict)
    frames: deque[tuple[float, int]] = field(default_factory=deque)


class HealthMonitor:
    """Thread-safe collector of stage heartbeats."""

    def __init__(
        self,
        stages: Iterable[Stage],
        *,
        rate_stage: str = "processing",
        rate_window_s: float = 2.0,
        min_rate_hz: float | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._stages = tuple(stages)
        self._min_rate_hz = min_rate_hz  # `health.min_fps`: a slower frame rate is DEGRADED
        names = [s.name for s in self._stages]
        if len(set(names)) != len(names):
            raise ValueError(f"stage names must be unique: {names}")
        codes = [s.code for s in self._stages]
        if len(set(codes)) != len(codes) or not all(1 <= c <= 6553 for c in codes):
            raise ValueError(f"stage codes must be unique and in 1..6553: {codes}")
        if rate_window_s <= 0:
            raise ValueError("rate_window_s must be > 0")
        self._clock = clock
        self._rate_stage = rate_stage
        self._rate_window_s = rate_window_s
        self._start_s = clock()
        self._flags = Status(0)
        self._beats = {s.name: _Beat() for s in self._stages}
        self._lock = threading.Lock()

    def set_flags(self, flags: Status, on: bool = True) -> None:
        """Set or clear static conditions (calibration valid, site surveyed, time sync)."""
        with self._lock:
            self._flags = self._flags | flags if on else self._flags & ~flags

    def beat(
        self,
        stage: str,
        *,
        fault: str | None = None,
        frames: int = 0,
        latency_s: float | None = None,
        counters: Mapping[str, int] | None = None,
    ) -> None:
        """Record progress of `stage` now; `fault` (None = healthy) replaces the last one."""
        now = self._clock()
        with self._lock:
            b = self._beats.get(stage)
            if b is None:
                raise KeyError(f"unknown health stage {stage!r}; known: {list(self._beats)}")
            b.t_s = now
            b.fault = fault
            if latency_s is not None:
                b.latency_s = latency_s
            if counters:
                b.counters.update(counters)
            if frames:
                b.frames.append((now, frames))
            while b.frames and b.frames[0][0] < now - self._rate_window_s:
                b.frames.popleft()

    def snapshot(self) -> HealthSnapshot:
        now = self._clock()
        with self._lock:
            views = [self._view(s, self._beats[s.name], now) for s in self._stages]
            flags = self._flags
            rate = self._frame_rate(now)
            latencies = [
                latency
                for s, v in zip(self._stages, views, strict=True)
                if v.fresh and (latency := self._beats[s.name].latency_s) is not None
            ]
        state, reason, code = HealthState.OK, "", 0
        for stage, view in zip(self._stages, views, strict=True):
            problem = self._problem(stage, view)
            if problem is None:
                flags |= stage.bits
                continue
            kind, text = problem
            severity = HealthState.STALLED if kind == FAULT_KIND_NO_HEARTBEAT and stage.critical \
                else HealthState.DEGRADED
            if _rank(severity) > _rank(state):
                state, reason, code = severity, f"{stage.name}: {text}", 10 * stage.code + kind
        slow = self._slow(rate, now)
        if slow is not None and state is HealthState.OK:
            state, reason, code = HealthState.DEGRADED, slow, 10 * self._rate_code() + FAULT_KIND_REPORTED
        flags |= {HealthState.OK: Status.OK, HealthState.DEGRADED: Status.DEGRADED,
                  HealthState.STALLED: Status.FAULT}[state]
        return HealthSnapshot(
            state=state,
            reason=reason,
            status_bits=int(flags),
            fault_code=code,
            frame_rate_hz=rate,
            latency_s=max(latencies) if latencies else None,
            uptime_s=now - self._start_s,
            stages=tuple(views),
        )

    def _slow(self, rate: float | None, now: float) -> str | None:
        """Why the frame rate is too low, once the rate window has been filled since start."""
        if self._min_rate_hz is None or rate is None or now - self._start_s < self._rate_window_s:
            return None
        return f"{self._rate_stage}: {rate:.1f} fps, below {self._min_rate_hz:g}" \
            if rate < self._min_rate_hz else None

    def _rate_code(self) -> int:
        return next(s.code for s in self._stages if s.name == self._rate_stage)

    def _view(self, stage: Stage, b: _Beat, now: float) -> StageHealth:
        age = None if b.t_s is None else now - b.t_s
        fresh = age is not None and age <= stage.stall_after_s
        return StageHealth(stage.name, fresh, age, b.fault, dict(b.counters))

    @staticmethod
    def _problem(stage: Stage, view: StageHealth) -> tuple[int, str] | None:
        if view.age_s is None:
            return FAULT_KIND_NO_HEARTBEAT, "no heartbeat since start"
        if not view.fresh:
            return FAULT_KIND_NO_HEARTBEAT, f"no heartbeat for {view.age_s:.1f} s"
        if view.fault is not None:
            return FAULT_KIND_REPORTED, view.fault
        return None

    def _frame_rate(self, now: float) -> float | None:
        """Frames/s in the window: frames after its first beat / time since that beat.

        None before the rate stage ever beat (or with one beat at this very
        instant); 0.0 once it beat but reported no frames in the window.
        """
        b = self._beats.get(self._rate_stage)
        if b is None or b.t_s is None:
            return None
        recent = [(t, n) for t, n in b.frames if t >= now - self._rate_window_s]
        if not recent or now <= recent[0][0]:
            return 0.0 if not recent else None
        return sum(n for _, n in recent[1:]) / (now - recent[0][0])


def _rank(state: HealthState) -> int:
    return (HealthState.OK, HealthState.DEGRADED, HealthState.STALLED).index(state)
