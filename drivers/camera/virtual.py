"""A live frame-pair source fed by software (the simulator), paced like real cameras.

`VirtualSource` wraps either

- a callable `make_pair(k) -> FramePair | None` giving the pair of trigger k
  (None: that trigger produced no pair, counted as dropped), for k = 0, 1, ...
  up to `n_triggers` (or forever), optionally starting over (`loop`); or
- any iterable of `FramePair` (a generator), consumed in order.

With `realtime=True` trigger k is due at start + k / fps on `clock`
(CLOCK_MONOTONIC by default): the source sleeps until then and re-stamps the
pair onto that clock (t_ns = due time; each camera's timestamp keeps its
offset from the pair time, so skew and jitter survive) with sequence numbers
counting triggers, as real cameras on a shared trigger would report. If the
consumer or the generator falls behind by more than a frame, triggers are
skipped to catch up (counted in `dropped`), the way a camera overwrites
frames nobody collected. With `realtime=False` pairs pass through as fast as
they are asked for, unchanged except when looping: each lap's timestamps are
shifted by the scene's length (n_triggers / fps) and sequence numbers count
triggers, so time and sequence keep increasing.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import replace

from drivers.camera.base import FramePair, FramePairSource


class VirtualSource(FramePairSource):
    """Frame pairs from a callable or an iterable, optionally in real time."""

    def __init__(
        self,
        pairs: Callable[[int], FramePair | None] | Iterable[FramePair],
        *,
        fps: float | None = None,
        realtime: bool = False,
        n_triggers: int | None = None,
        loop: bool = False,
        clock: Callable[[], int] = time.monotonic_ns,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        super().__init__()
        if realtime and not (fps and fps > 0.0):
            raise ValueError("a real-time virtual source needs a positive fps")
        if loop and not (callable(pairs) and n_triggers and fps and fps > 0.0):
            raise ValueError("loop needs a make_pair callable, n_triggers and fps")
        self._make = pairs if callable(pairs) else None
        self._iter: Iterator[FramePair] | None = None if callable(pairs) else iter(pairs)
        self.fps, self.realtime, self.n_triggers, self.loop = fps, realtime, n_triggers, loop
        self._clock, self._sleep = clock, sleep
        self._k = 0  # next trigger number (realtime stamps count these, across loops)
        self._start_ns: int | None = None

    @property
    def info(self) -> dict:
        return {"fps": self.fps, "realtime": self.realtime}

    def _due_ns(self, k: int) -> int:
        assert self._start_ns is not None and self.fps
        return self._start_ns + round(k * 1e9 / self.fps)

    def read(self) -> FramePair | None:
        while not self.closed:
            if self.realtime:
                assert self.fps is not None  # __init__: real time needs a positive fps
                now = self._clock()
                if self._start_ns is None:
                    self._start_ns = now
                behind = int((now - self._due_ns(self._k)) * self.fps // 1_000_000_000)
                if behind >= 1:  # more than a frame late: skip to the current trigger
                    self._skip(behind)
                    if self.closed:
                        return None
            k = self._k
            pair = self._produce(k)
            if pair is _END:
                return None
            self._k += 1
            if pair is None:
                self.dropped += 1
                continue
            if not self.realtime:
                if not self.loop:
                    return pair
                assert self.n_triggers is not None and self.fps is not None  # __init__: loop needs both
                if k < self.n_triggers:
                    return pair
                shift = (k // self.n_triggers) * round(self.n_triggers * 1e9 / self.fps)
                return replace(
                    pair,
                    t_ns=pair.t_ns + shift,
                    seq_left=k,
                    seq_right=k,
                    t_left_ns=pair.t_left_ns + shift,
                    t_right_ns=pair.t_right_ns + shift,
                )
            due = self._due_ns(k)
            now = self._clock()
            if due > now:
                self._sleep((due - now) / 1e9)
            return replace(
                pair,
                t_ns=due,
                seq_left=k,
                seq_right=k,
                t_left_ns=due + pair.t_left_ns - pair.t_ns,
                t_right_ns=due + pair.t_right_ns - pair.t_ns,
            )
        return None

    def _produce(self, k: int):
        if self._make is None:
            assert self._iter is not None
            return next(self._iter, _END)
        if self.n_triggers is not None and k >= self.n_triggers:
            if not self.loop:
                return _END
            k %= self.n_triggers
        return self._make(k)

    def _skip(self, count: int) -> None:
        for _ in range(count):
            if self._make is None and self._produce(self._k) is _END:  # iterables must be consumed
                self.close()
                return
            if (
                self._make is not None
                and self.n_triggers is not None
                and not self.loop
                and self._k >= self.n_triggers
            ):
                self.close()
                return
            self._k += 1
            self.dropped += 1


_END = object()  # sentinel: the underlying source is exhausted
