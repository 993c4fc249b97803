"""drivers/camera/virtual.py: pass-through, real-time pacing and re-stamping, catching up, ends."""

from __future__ import annotations

import numpy as np
import pytest

from drivers.camera.base import FramePair
from drivers.camera.virtual import VirtualSource

PERIOD_NS = 100_000_000


def make_pair(k: int) -> FramePair | None:
    if k % 5 == 3:
        return None  # this trigger's pair was lost
    image = np.full((4, 6), k % 256, np.uint8)
    t = 7_000 + k * PERIOD_NS
    return FramePair(image, image.copy(), t, k, k, t - 30, t + 40)


class FakeClock:
    def __init__(self, work_ns: int = 0) -> None:
        self.now, self.work_ns = 50_000, work_ns
        self.slept = 0.0

    def __call__(self) -> int:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.slept += seconds
        self.now += round(seconds * 1e9)


def test_iterable_passes_through_unchanged() -> None:
    pairs = [p for k in range(6) if (p := make_pair(k)) is not None]
    source = VirtualSource(iter(pairs))
    assert list(source) == pairs
    assert source.dropped == 0 and source.read() is None


def test_callable_counts_lost_pairs_and_ends() -> None:
    source = VirtualSource(make_pair, n_triggers=10)
    got = list(source)
    assert [p.seq_left for p in got] == [0, 1, 2, 4, 5, 6, 7, 9]
    assert source.dropped == 2


def test_realtime_paces_and_restamps_onto_the_clock() -> None:
    clock = FakeClock()
    source = VirtualSource(make_pair, fps=10.0, realtime=True, n_triggers=6, clock=clock, sleep=clock.sleep)
    start = clock.now
    got = []
    for pair in source:
        assert pair.t_ns == clock.now  # released exactly when due
        got.append(pair)
        clock.now += 20_000_000  # 20 ms of processing per pair: keeps up
    assert [p.t_ns - start for p in got] == [k * PERIOD_NS for k in (0, 1, 2, 4, 5)]
    assert all(p.t_left_ns - p.t_ns == -30 and p.t_right_ns - p.t_ns == 40 for p in got)  # skew kept
    assert [p.seq_left for p in got] == [0, 1, 2, 4, 5] and source.dropped == 1


def test_realtime_skips_triggers_when_the_consumer_falls_behind() -> None:
    clock = FakeClock()
    source = VirtualSource(make_pair, fps=10.0, realtime=True, n_triggers=40, clock=clock, sleep=clock.sleep)
    seqs = []
    for pair in source:
        seqs.append(pair.seq_left)
        clock.now += 350_000_000  # 350 ms per pair at 10 fps: only every ~4th trigger can be served
    assert seqs[0] == 0 and all(b - a >= 3 for a, b in zip(seqs, seqs[1:], strict=False))
    assert source.dropped >= 40 - len(seqs) - 1
    assert len(seqs) < 15


def test_loop_restarts_the_scene_with_increasing_time() -> None:
    clock = FakeClock()
    source = VirtualSource(
        make_pair, fps=10.0, realtime=True, n_triggers=3, loop=True, clock=clock, sleep=clock.sleep
    )
    got = [source.read() for _ in range(5)]
    assert [int(p.left[0, 0]) for p in got] == [0, 1, 2, 0, 1]  # the scene starts over
    assert np.all(np.diff([p.t_ns for p in got]) == PERIOD_NS) and [p.seq_left for p in got] == [
        0,
        1,
        2,
        3,
        4,
    ]


def test_unpaced_loop_keeps_time_and_sequence_increasing() -> None:
    source = VirtualSource(make_pair, fps=10.0, n_triggers=3, loop=True)
    got = [source.read() for _ in range(6)]
    assert [int(p.left[0, 0]) for p in got] == [0, 1, 2, 0, 1, 2]
    assert np.all(np.diff([p.t_ns for p in got]) == PERIOD_NS)
    assert [p.seq_left for p in got] == list(range(6))


def test_bad_arguments() -> None:
    with pytest.raises(ValueError):
        VirtualSource(make_pair, realtime=True)
    with pytest.raises(ValueError):
        VirtualSource([], loop=True)
