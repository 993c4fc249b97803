"""Per-stage latency histograms of the processing thread, for /metrics (edge.appliance.page.metrics).

Each processed pair adds one observation per stage: `queue` (captured to taken by the processing
thread), `chain` (pipeline, AIS and alerts), `outputs` (the fan-out's publish) and `total`
(captured to published, the latency the health block reports). Cumulative bucket counts with fixed
bounds, as Prometheus histograms are, kept in plain lists so the cost on the processing thread is a
bisect and two additions per stage, and no metrics library is loaded while the page is off.
`snapshot` copies them under the lock, so a scrape never sees a count without its sum.
"""

from __future__ import annotations

import bisect
import threading
from dataclasses import dataclass

STAGES = ("queue", "chain", "outputs", "total")
BOUNDS_S = (0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0)  # upper bounds; +Inf last


@dataclass(frozen=True)
class Histogram:
    """One stage's observations: per-bucket counts (not cumulative; the last is above every bound)."""

    buckets: tuple[int, ...]
    sum_s: float

    @property
    def count(self) -> int:
        return sum(self.buckets)

    def cumulative(self) -> list[tuple[str, int]]:
        """(upper bound as Prometheus writes it, cumulative count), +Inf last."""
        out, total = [], 0
        for bound, n in zip((*(repr(b) for b in BOUNDS_S), "+Inf"), self.buckets, strict=True):
            total += n
            out.append((bound, total))
        return out


class StageTimes:
    """Latency histograms of the processing stages; `observe` from one thread, `snapshot` from any."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._counts = {s: [0] * (len(BOUNDS_S) + 1) for s in STAGES}
        self._sums = dict.fromkeys(STAGES, 0.0)

    def observe(self, seconds: dict[str, float]) -> None:
        """One pair's latency per stage (any subset of STAGES), seconds."""
        with self._lock:
            for stage, value in seconds.items():
                self._counts[stage][bisect.bisect_left(BOUNDS_S, value)] += 1
                self._sums[stage] += value

    def snapshot(self) -> dict[str, Histogram]:
        with self._lock:
            return {s: Histogram(tuple(self._counts[s]), self._sums[s]) for s in STAGES}
