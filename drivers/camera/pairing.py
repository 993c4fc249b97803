"""Pair the left and right frames of the same trigger pulse by timestamp (pure: no I/O, no threads).

Why timestamps and not sequence numbers: each camera's sequence counter starts
at STREAMON and counts only what that camera saw, so one missed pulse on one
side desyncs the counters forever (docs in /work/shared/research/v4l2.md).
Sequence numbers serve only to count each camera's drops (`SequenceTracker`:
a gap of n is n-1 drops, modulo 2^32 so the u32 wrap is no gap; a step
backwards is a restart of the stream, not a drop).

The rule (`Pairer`), for frames that arrive in timestamp order per camera but
interleaved arbitrarily between the two (a late dequeue on one side):

- corrected skew d = t_right - t_left - offset, where `offset` is the constant
  difference between the cameras' stamps (EOF vs SOE stamping, exposure
  differences, a trigger wired with a delay), estimated online as the median of
  the last `offset_window` accepted skews once `offset_min_samples` are in
  (before that: the configured `offset_ns`, default 0). The median ignores the
  odd outlier, and the estimate moves only with accepted pairs, so it cannot
  be dragged to a neighbouring pulse. Free-running cameras (no trigger) drift
  through the whole period: pair them with `track_offset=False`, nearest frames.
- the oldest waiting frames of both sides are compared: |d| < tolerance
  (default half the trigger period) pairs them; otherwise the older one can
  never pair (its partner would have come before the other's oldest frame, and
  each camera delivers in order) and is dropped as unpaired;
- up to `max_pending` frames wait per side for the other camera; beyond that
  the oldest is dropped as unpaired, so a dead camera never holds memory.

Guarantee: frames of different pulses are never paired as long as, for every
pulse, |relative jitter| + |offset error| < tolerance < pulse spacing -
(|relative jitter| + |offset error|). With periodic pulses and tolerance P/2
that is |jitter + offset error| < P/2 (the test drives this to its edges).
A frame pairs whenever its partner arrives fewer than about `max_pending`
frames late. Counters: `drops[side]` (sequence gaps), `unpaired[side]`,
`restarts[side]`, `pairs`; `skew_stats()` summarises the recent raw skews.
"""

from __future__ import annotations

import statistics
from collections import deque
from dataclasses import dataclass
from typing import Generic, Protocol, TypeVar

import numpy as np

LEFT, RIGHT = 0, 1
SIDES = ("left", "right")
U32 = 1 << 32


class Stamped(Protocol):
    @property
    def t_ns(self) -> int: ...

    @property
    def sequence(self) -> int: ...


F = TypeVar("F", bound=Stamped)


class SequenceTracker:
    """One camera's drop counter from its u32 sequence numbers."""

    def __init__(self) -> None:
        self.last: int | None = None
        self.frames = self.drops = self.restarts = self.repeats = 0

    def update(self, sequence: int) -> int:
        """Account one delivered frame; returns the frames dropped just before it."""
        self.frames += 1
        last, self.last = self.last, sequence
        if last is None:
            return 0
        step = (sequence - last) % U32
        if step == 0:
            self.repeats += 1
            return 0
        if step < U32 // 2:
            self.drops += step - 1
            return step - 1
        self.restarts += 1  # went backwards: the stream restarted (reopen, driver reset)
        return 0

    def restart(self) -> None:
        """The stream was restarted on purpose (reconnect): its next sequence number starts afresh."""
        if self.last is not None:
            self.restarts += 1
        self.last = None


@dataclass(frozen=True)
class SkewStats:
    """Raw skews (t_right - t_left) of the recent pairs, for health; ns."""

    pairs: int  # in the window
    mean_ns: float
    p99_abs_ns: float
    max_abs_ns: int
    offset_ns: int  # the offset the pairer corrects for

    def as_dict(self) -> dict:
        return {
            "pairs": self.pairs,
            "mean_ms": self.mean_ns / 1e6,
            "p99_abs_ms": self.p99_abs_ns / 1e6,
            "max_abs_ms": self.max_abs_ns / 1e6,
            "offset_ms": self.offset_ns / 1e6,
        }


class Pairer(Generic[F]):
    """Pairs stamped frames of two cameras; `push` returns the pairs it completes, oldest first."""

    def __init__(
        self,
        period_ns: int,
        *,
        tolerance_ns: int | None = None,
        max_pending: int = 4,
        offset_ns: int = 0,
        track_offset: bool = True,
        offset_window: int = 31,
        offset_min_samples: int = 8,
        stats_window: int = 1024,
    ) -> None:
        if period_ns <= 0:
            raise ValueError("period_ns must be positive")
        self.period_ns = int(period_ns)
        self.tolerance_ns = int(tolerance_ns if tolerance_ns is not None else period_ns // 2)
        if not 0 < self.tolerance_ns <= self.period_ns // 2:
            raise ValueError("tolerance_ns must be positive and at most half the period")
        if max_pending < 1:
            raise ValueError("max_pending must be at least 1")
        self.max_pending = max_pending
        self.offset_ns = int(offset_ns)
        self.track_offset = track_offset
        self._offset_samples: deque[int] = deque(maxlen=offset_window)
        self._offset_min = offset_min_samples
        self._skews: deque[int] = deque(maxlen=stats_window)
        self.pending: tuple[deque[F], deque[F]] = (deque(), deque())
        self.trackers = (SequenceTracker(), SequenceTracker())
        self.unpaired = [0, 0]
        self.pairs = 0

    @property
    def drops(self) -> tuple[int, int]:
        return self.trackers[LEFT].drops, self.trackers[RIGHT].drops

    @property
    def restarts(self) -> tuple[int, int]:
        return self.trackers[LEFT].restarts, self.trackers[RIGHT].restarts

    def push(self, side: int, frame: F) -> list[tuple[F, F]]:
        """Add one frame of `side` (LEFT/RIGHT); returns the (left, right) pairs now complete."""
        self.trackers[side].update(frame.sequence)
        queue = self.pending[side]
        if queue and frame.t_ns <= queue[-1].t_ns:
            self._discard(side, len(queue))  # stamps went backwards (a new clock base): start over
        queue.append(frame)
        pairs = self._match()
        if len(queue) > self.max_pending:
            self._discard(side, len(queue) - self.max_pending)
        return pairs

    def restart(self, side: int) -> None:
        """The camera of `side` was reopened: don't count its next sequence step as drops."""
        self.trackers[side].restart()

    def flush(self) -> int:
        """Give up on every waiting frame (at close); returns how many were dropped."""
        n = len(self.pending[LEFT]) + len(self.pending[RIGHT])
        for side in (LEFT, RIGHT):
            self._discard(side, len(self.pending[side]))
        return n

    def _discard(self, side: int, count: int) -> None:
        for _ in range(count):
            self.pending[side].popleft()
            self.unpaired[side] += 1

    def _match(self) -> list[tuple[F, F]]:
        left, right = self.pending
        out: list[tuple[F, F]] = []
        while left and right:
            skew = right[0].t_ns - left[0].t_ns
            d = skew - self.offset_ns
            if abs(d) < self.tolerance_ns:
                out.append((left.popleft(), right.popleft()))
                self._accepted(skew)
            elif d < 0:
                self._discard(RIGHT, 1)
            else:
                self._discard(LEFT, 1)
        return out

    def _accepted(self, skew_ns: int) -> None:
        self.pairs += 1
        self._skews.append(skew_ns)
        if self.track_offset:
            self._offset_samples.append(skew_ns)
            if len(self._offset_samples) >= self._offset_min:
                self.offset_ns = int(statistics.median(self._offset_samples))

    def skew_stats(self) -> SkewStats:
        if not self._skews:
            return SkewStats(0, 0.0, 0.0, 0, self.offset_ns)
        skews = np.fromiter(self._skews, dtype=np.int64, count=len(self._skews))
        magnitude = np.abs(skews)
        return SkewStats(
            len(skews),
            float(skews.mean()),
            float(np.percentile(magnitude, 99)),
            int(magnitude.max()),
            self.offset_ns,
        )
