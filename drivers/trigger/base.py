"""The Trigger contract, and the absolute-deadline pulse loop shared by the GPIO and virtual generators.

A `Trigger` tells the pair source three things: how to set each camera up
(`configure_camera`, called after every open, so a reconnected camera is armed
again; `release_camera` at close), whether it drives pulses itself
(`start()`/`stop()`), and what to expect: `period_ns` (the pairer's tolerance
is half of it) and `synchronised` (False for free-running cameras, whose
relative phase drifts, so the pairer must not track an offset).

`PulseLoop` schedules pulse k at start + k x period on CLOCK_MONOTONIC and
sleeps to absolute deadlines, so wake-up latency never accumulates into the
rate; it wakes early by the median latency of its last wake-ups, so a steady
latency (a loaded CPU, a slow timer) does not show as late edges or long pulses;
a pulse whose rising edge would be more than `late_limit` of a period late is
skipped (counted in `missed`) rather than bunched up behind the previous one. The
falling edge comes `width_ns` after the rising edge was actually issued, so a
late pulse is still a full-width pulse the camera registers. `priority` runs the
loop's thread SCHED_FIFO at that priority (needs CAP_SYS_NICE; warned and
ignored without), which keeps other work on a busy mast computer from delaying edges.
"""

from __future__ import annotations

import logging
import os
import statistics
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import ClassVar, Protocol

log = logging.getLogger(__name__)


class ControlTarget(Protocol):
    """What a trigger adapter needs from a camera (V4L2Camera has these)."""

    path: str

    def set_control(self, name: str, value: object) -> int: ...

    def has_control(self, name: str) -> bool: ...


class CameraSetup(Protocol):
    def apply(self, camera: ControlTarget) -> None: ...

    def release(self, camera: ControlTarget) -> None: ...

    def describe(self) -> str: ...


class Trigger:
    """Base class: a nominal rate, an optional per-camera setup, no pulses of its own."""

    kind: ClassVar[str] = "abstract"
    synchronised: ClassVar[bool] = True

    def __init__(self, rate_hz: float, *, camera_setup: CameraSetup | None = None) -> None:
        if not rate_hz > 0:
            raise ValueError(f"{self.kind} trigger needs a positive rate_hz, not {rate_hz!r}")
        self.rate_hz = float(rate_hz)
        self.camera_setup = camera_setup
        self.running = False

    @property
    def period_ns(self) -> int:
        """The expected interval between pulses (between frames, for free-running cameras)."""
        return round(1e9 / self.rate_hz)

    def configure_camera(self, side: str, camera: ControlTarget) -> None:
        """Put a freshly opened camera into this trigger's mode (before STREAMON)."""
        if self.camera_setup is not None:
            self.camera_setup.apply(camera)

    def release_camera(self, side: str, camera: ControlTarget) -> None:
        if self.camera_setup is not None:
            self.camera_setup.release(camera)

    def start(self) -> None:
        self.running = True

    def stop(self) -> None:
        self.running = False

    def describe(self) -> str:
        setup = f", cameras: {self.camera_setup.describe()}" if self.camera_setup else ""
        return f"{self.kind} at {self.rate_hz:g} Hz{setup}"

    @property
    def stats(self) -> dict:
        return {"kind": self.kind, "rate_hz": self.rate_hz}


class PulseLoop:
    """Calls `rise(t_ns)` and, `width_ns` later, `fall()` at start + k x period, from its own thread."""

    def __init__(
        self,
        period_ns: int,
        width_ns: int,
        rise: Callable[[int], None],
        fall: Callable[[], None] | None = None,
        *,
        name: str = "pulses",
        late_limit: float = 0.5,
        priority: int | None = None,
        clock: Callable[[], int] = time.monotonic_ns,
        wait: Callable[[float], bool] | None = None,
    ) -> None:
        if not 0 <= width_ns < period_ns:
            raise ValueError("the pulse width must be shorter than the period")
        self.period_ns, self.width_ns, self.late_limit = period_ns, width_ns, late_limit
        self._rise, self._fall, self._clock = rise, fall, clock
        self._stop = threading.Event()
        self._wait = wait or self._stop.wait
        self._thread: threading.Thread | None = None
        self._name, self.priority = name, priority
        self.pulses = self.missed = 0
        self.lateness_ns: deque[int] = deque(maxlen=1024)  # rising edge issued minus its deadline
        self._wakeups: deque[int] = deque(maxlen=15)  # how late the recent wake-ups came, ns
        self.t0_ns = 0

    def _sleep_until(self, deadline_ns: int) -> bool:
        """Sleep to an absolute deadline, waking early by the recent wake-up latency; False if stopped."""
        lead = min(int(statistics.median(self._wakeups)) if self._wakeups else 0, self.period_ns // 10)
        wake_at = deadline_ns - lead
        while (left := wake_at - self._clock()) > 0:
            if self._wait(left / 1e9):
                return False
        self._wakeups.append(max(0, self._clock() - wake_at))
        return not self._stop.is_set()

    def run(self, max_pulses: int | None = None, lead_ns: int = 5_000_000) -> None:
        """The loop (the thread's body; tests call it directly with a fake clock)."""
        self.t0_ns = self._clock() + lead_ns
        k = 0
        while max_pulses is None or self.pulses + self.missed < max_pulses:
            rise_at = self.t0_ns + k * self.period_ns
            if not self._sleep_until(rise_at):
                return
            late = self._clock() - rise_at
            if late > self.late_limit * self.period_ns:
                behind = late // self.period_ns + 1  # skip to the next pulse still ahead
                self.missed += behind
                k += behind
                continue
            self._rise(rise_at)
            risen = self._clock()
            self.pulses += 1
            self.lateness_ns.append(late)
            if self._fall is not None:  # the full width from the actual edge: a late pulse is never a runt
                self._sleep_until(risen + self.width_ns)
                self._fall()
            k += 1

    def _thread_main(self) -> None:
        if self.priority is not None:
            try:  # SCHED_FIFO for this thread only: edges on time even when the CPU is busy
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(self.priority))
            except (OSError, AttributeError) as exc:
                log.warning(
                    "%s: no real-time priority %d (%s); running at normal priority",
                    self._name,
                    self.priority,
                    exc,
                )
        self.run()

    def start(self) -> None:
        if self._thread is not None:
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._thread_main, name=self._name, daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None

    @property
    def stats(self) -> dict:
        late = sorted(self.lateness_ns)
        return {
            "pulses": self.pulses,
            "missed": self.missed,
            "late_p99_us": late[int(0.99 * (len(late) - 1))] / 1e3 if late else 0.0,
            "wakeup_lead_us": statistics.median(self._wakeups) / 1e3 if self._wakeups else 0.0,
        }
