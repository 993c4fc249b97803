"""Frame pairs from two V4L2 cameras and a trigger: capture threads, pairing, reconnection, faults.

    source = V4L2PairSource(left_settings, right_settings, trigger)
    try:
        pair = source.read(timeout_s=1.0)    # FramePair; None only once closed
    except PairTimeout as exc:              # no pair within the timeout: exc.faults says why
        ...
    source.faults["left"].faulted, source.counters["drops_left"], pair.t_utc_ns

One capture thread per camera opens it (`V4L2Camera`), lets the trigger arm
it (`Trigger.configure_camera`, again after every reopen), streams and hands
each frame (pixels already copied, buffer re-queued) to a `Pairer` under one
lock. Completed pairs go to a bounded queue (`queue_pairs`, newest wins: an
overflowing pair is counted in `dropped`). The trigger starts after the
capture threads, so its first pulses meet streaming cameras where possible.

Timestamps: a pair's `t_ns` is the mean of the two exposure stamps on
CLOCK_MONOTONIC (the kernel's buffer timestamps; a camera whose driver does not
stamp on CLOCK_MONOTONIC is stamped at dequeue instead), with each camera's own
stamp in t_left_ns/t_right_ns. `realtime_offset_ns` is CLOCK_REALTIME minus
CLOCK_MONOTONIC sampled as the pair is made, so the daemon stamps UTC as
`pair.t_utc_ns` = realtime at exposure (`realtime_offset` replaces that sampling in tests that
step the wall clock: the machine's own clock is never touched).

Faults and reconnection: a camera that disappears (CameraGone: ENODEV, EIO, a
driver reset) or cannot be opened or configured is closed and reopened with
exponential backoff (`backoff_s` = first and longest wait). Meanwhile
`faults[side]` is a `CameraFault` with faulted=True, the reason and since when
(CLOCK_MONOTONIC ns); `reconnects` counts successful reopens after a fault.
A camera that streams but delivers nothing (no pulses) is not faulted, but its
`last_frame_ns` ages: `stalled(side)` says whether it is older than
`stall_periods` trigger periods. The daemon shows DEGRADED while any camera is
faulted or stalled.

The no-pair signal: `read(timeout_s)` (default `read_timeout_s`, 2 s or five
periods if longer) raises `PairTimeout` carrying the fault snapshot when no pair
arrives in time, so a processing thread never blocks forever on a missing
camera; it returns None only once the source is closed.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, replace

from drivers.camera.base import FramePair, FramePairSource
from drivers.camera.pairing import LEFT, RIGHT, SIDES, Pairer
from drivers.camera.v4l2 import CameraSettings, DeviceError, Frame, V4L2Camera
from drivers.trigger.base import Trigger

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CameraFault:
    """One camera's state for health (all times CLOCK_MONOTONIC ns)."""

    faulted: bool = True  # until the first successful open
    reason: str = "not opened yet"
    since_ns: int = 0
    reconnects: int = 0
    last_frame_ns: int = 0


class PairTimeout(TimeoutError):
    """No pair within the read timeout; `faults` is the per-camera state at that moment."""

    def __init__(self, timeout_s: float, faults: dict[str, CameraFault]) -> None:
        self.timeout_s, self.faults = timeout_s, faults
        bad = [f"{s}: {f.reason}" for s, f in faults.items() if f.faulted]
        super().__init__(f"no frame pair within {timeout_s:g} s" + (f" ({'; '.join(bad)})" if bad else ""))


@dataclass(frozen=True, slots=True)
class _Stamped:
    t_ns: int
    sequence: int
    frame: Frame


def realtime_offset_ns() -> int:
    """CLOCK_REALTIME - CLOCK_MONOTONIC, the realtime read bracketed by two monotonic reads."""
    m0 = time.clock_gettime_ns(time.CLOCK_MONOTONIC)
    real = time.clock_gettime_ns(time.CLOCK_REALTIME)
    m1 = time.clock_gettime_ns(time.CLOCK_MONOTONIC)
    return real - (m0 + m1) // 2


class V4L2PairSource(FramePairSource):
    """A FramePairSource over two V4L2 cameras, a trigger and a Pairer."""

    def __init__(
        self,
        left: CameraSettings,
        right: CameraSettings,
        trigger: Trigger,
        *,
        max_skew_ns: int | None = None,
        max_pending: int = 4,
        queue_pairs: int = 4,
        read_timeout_s: float | None = None,
        backoff_s: tuple[float, float] = (0.5, 30.0),
        poll_s: float = 0.2,
        stall_periods: float = 5.0,
        open_camera: Callable[[CameraSettings], V4L2Camera] = V4L2Camera,
        clock: Callable[[], int] = time.monotonic_ns,
        realtime_offset: Callable[[], int] | None = None,  # tests step the wall clock through this
    ) -> None:
        super().__init__()
        self.settings = (left, right)
        self.trigger = trigger
        self.pairer: Pairer[_Stamped] = Pairer(
            trigger.period_ns,
            tolerance_ns=max_skew_ns,
            max_pending=max_pending,
            track_offset=trigger.synchronised,
        )
        period_s = trigger.period_ns / 1e9
        self.read_timeout_s = read_timeout_s if read_timeout_s is not None else max(2.0, 5 * period_s)
        self.backoff_s, self.poll_s, self.stall_periods = backoff_s, poll_s, stall_periods
        self._open, self._clock = open_camera, clock
        self._realtime_offset = realtime_offset or realtime_offset_ns
        self._cond = threading.Condition()
        self._pairs: deque[FramePair] = deque()
        self._queue_pairs = queue_pairs
        now = clock()
        self._faults = [CameraFault(since_ns=now), CameraFault(since_ns=now)]
        self._camera_totals = [{"stale": 0, "corrupt": 0}, {"stale": 0, "corrupt": 0}]
        self._ever_opened = [False, False]
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    # --- lifecycle ------------------------------------------------------------------------------

    def start(self) -> None:
        """Start both capture threads and the trigger (read() does this on first use)."""
        if self._threads or self.closed:
            return
        for side in (LEFT, RIGHT):
            thread = threading.Thread(
                target=self._capture, args=(side,), name=f"capture-{SIDES[side]}", daemon=True
            )
            self._threads.append(thread)
            thread.start()
        self.trigger.start()

    def close(self) -> None:
        if self.closed:
            return
        self.trigger.stop()
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=5.0)
        with self._cond:
            super().close()
            self.pairer.flush()
            self._cond.notify_all()

    # --- capture threads ------------------------------------------------------------------------

    def _fault(self, side: int, reason: str) -> None:
        with self._cond:
            old = self._faults[side]
            if not old.faulted or old.reason != reason:
                log.warning("camera %s (%s) faulted: %s", SIDES[side], self.settings[side].device, reason)
            since = old.since_ns if old.faulted else self._clock()
            self._faults[side] = replace(old, faulted=True, reason=reason, since_ns=since)

    def _capture(self, side: int) -> None:
        name, settings = SIDES[side], self.settings[side]
        backoff = self.backoff_s[0]
        while not self._stop.is_set():
            try:
                camera = self._open(settings)
            except Exception as exc:  # any failure is this camera's fault state, retried
                if not isinstance(exc, DeviceError):
                    log.exception("camera %s: unexpected error opening %s", name, settings.device)
                self._fault(side, str(exc))
                self._stop.wait(backoff)
                backoff = min(backoff * 2, self.backoff_s[1])
                continue
            try:
                self.trigger.configure_camera(name, camera)
                camera.start()
                self._opened(side)
                backoff = self.backoff_s[0]
                while not self._stop.is_set():
                    frame = camera.read(self.poll_s)
                    if frame is not None:
                        self._on_frame(side, frame)
            except Exception as exc:  # CameraGone and the rest: reopen after the backoff
                if not isinstance(exc, DeviceError):
                    log.exception("camera %s: unexpected error streaming %s", name, settings.device)
                self._fault(side, str(exc))
            finally:
                self._closed_camera(side, camera)
            self._stop.wait(backoff if self._faults[side].faulted else 0)

    def _opened(self, side: int) -> None:
        with self._cond:
            old = self._faults[side]
            reconnects = old.reconnects + self._ever_opened[side]
            self._ever_opened[side] = True
            self._faults[side] = CameraFault(False, "", self._clock(), reconnects, old.last_frame_ns)
            self.pairer.restart(side)
        log.info("camera %s (%s) streaming", SIDES[side], self.settings[side].device)

    def _closed_camera(self, side: int, camera: V4L2Camera) -> None:
        try:
            if not self._faults[side].faulted:
                self.trigger.release_camera(SIDES[side], camera)
        except DeviceError:
            pass
        with self._cond:
            totals = self._camera_totals[side]
            totals["stale"] += camera.stale
            totals["corrupt"] += camera.corrupt
        camera.close()

    def _on_frame(self, side: int, frame: Frame) -> None:
        t_ns = frame.t_ns if frame.monotonic else frame.t_dequeued_ns
        with self._cond:
            self._faults[side] = replace(self._faults[side], last_frame_ns=self._clock())
            for left, right in self.pairer.push(side, _Stamped(t_ns, frame.sequence, frame)):
                pair = FramePair(
                    left.frame.image,
                    right.frame.image,
                    (left.t_ns + right.t_ns) // 2,
                    left.sequence,
                    right.sequence,
                    left.t_ns,
                    right.t_ns,
                    self._realtime_offset(),
                )
                if len(self._pairs) >= self._queue_pairs:
                    self._pairs.popleft()
                    self.dropped += 1  # the consumer is behind: newest wins
                self._pairs.append(pair)
            self._cond.notify_all()

    # --- the consumer side ----------------------------------------------------------------------

    def read(self, timeout_s: float | None = None) -> FramePair | None:
        """The next pair; None once closed; PairTimeout if none arrives within the timeout."""
        self.start()
        timeout = self.read_timeout_s if timeout_s is None else timeout_s
        deadline = time.monotonic() + timeout
        with self._cond:
            while not self._pairs and not self.closed:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise PairTimeout(timeout, self._snapshot())
                self._cond.wait(left)
            return None if self.closed else self._pairs.popleft()

    def _snapshot(self) -> dict[str, CameraFault]:
        return {SIDES[s]: self._faults[s] for s in (LEFT, RIGHT)}

    @property
    def faults(self) -> dict[str, CameraFault]:
        """Per-camera state: {'left': CameraFault, 'right': CameraFault}."""
        with self._cond:
            return self._snapshot()

    def stalled(self, side: str) -> bool:
        """The camera streams but its last frame is older than stall_periods trigger periods."""
        fault = self.faults[side]
        since = max(fault.last_frame_ns, fault.since_ns)
        return not fault.faulted and self._clock() - since > self.stall_periods * self.trigger.period_ns

    def camera_faults(self) -> dict[str, str | None]:
        out: dict[str, str | None] = {}
        for side, fault in self.faults.items():
            if fault.faulted:
                out[side] = fault.reason or "camera not streaming"
            elif self.stalled(side):
                out[side] = f"no frames for {self.stall_periods:g} trigger periods"
            else:
                out[side] = None
        return out

    @property
    def degraded(self) -> bool:
        return any(f.faulted for f in self.faults.values()) or any(self.stalled(s) for s in SIDES)

    @property
    def counters(self) -> dict:
        """Drops (sequence gaps) and unpaired frames per camera, reconnects, pairs, skew statistics."""
        with self._cond:
            p = self.pairer
            out = {"pairs": p.pairs, "dropped_pairs": self.dropped, "skew": p.skew_stats().as_dict()}
            for s, name in enumerate(SIDES):
                out |= {
                    f"drops_{name}": p.drops[s],
                    f"unpaired_{name}": p.unpaired[s],
                    f"reconnects_{name}": self._faults[s].reconnects,
                    f"stale_{name}": self._camera_totals[s]["stale"],
                    f"corrupt_{name}": self._camera_totals[s]["corrupt"],
                }
            return out

    @property
    def info(self) -> dict:
        s = self.settings[LEFT]
        return {
            "fps": self.trigger.rate_hz,
            "width": s.width,
            "height": s.height,
            "pixel_format": s.pixel_format,
            "trigger": self.trigger.describe(),
            "devices": [c.device for c in self.settings],
        }
