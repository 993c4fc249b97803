"""The capture thread's hand-over to the processing thread: a one-slot queue where the newest pair wins.

A slow processing step must never back up the cameras, so an unread pair is replaced (and counted
as dropped); a source without pacing (a recording, the simulator at full speed) waits for the slot
instead and loses nothing. Used by edge.appliance.daemon.
"""

from __future__ import annotations

import threading
import time

from drivers.camera.base import FramePair

WAIT_S = 0.2  # how often a waiting put looks at its stop event


class LatestPair:
    """One-slot queue: put() replaces an unread pair (counted as dropped); remembers when it came."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._pair: FramePair | None = None
        self.put_ns = 0  # CLOCK_MONOTONIC when the pair now held was put
        self.dropped = 0
        self.ended = False

    def put(self, pair: FramePair, wait_until: threading.Event | None = None) -> None:
        """With `wait_until`, wait for the slot to be read first (a source without pacing: a recording
        or the simulator at full speed loses nothing) unless that event is set (stop, reload)."""
        with self._cond:
            while wait_until is not None and self._pair is not None and not wait_until.is_set():
                self._cond.wait(WAIT_S)
            if wait_until is not None and wait_until.is_set():
                return  # stopping: the pair is not taken, and none was dropped
            self.dropped += self._pair is not None
            self._pair, self.put_ns = pair, time.monotonic_ns()
            self._cond.notify()

    def end(self) -> None:
        with self._cond:
            self.ended = True
            self._cond.notify()

    def get(self, timeout_s: float) -> tuple[FramePair, int] | None:
        """(pair, CLOCK_MONOTONIC ns when it was captured), or None on time-out or end."""
        with self._cond:
            self._cond.wait_for(lambda: self._pair is not None or self.ended, timeout_s)
            pair, self._pair = self._pair, None
            self._cond.notify()  # a waiting put
            return None if pair is None else (pair, self.put_ns)
