"""drivers/camera/pairing.py: property tests on synthetic (sequence, timestamp) traces with ground truth.

Each synthetic camera sees a train of trigger pulses and delivers, per pulse, a
frame stamped pulse time + its offset + its own jitter, or drops it (its
sequence still advances), or misses the pulse (no frame, no sequence step);
it may start near the u32 wrap and restart (sequence back to 0) mid-trace.
Frames reach the pairer late by up to a few periods, interleaved by arrival.
Ground-truth pulse ids check that no pair ever mixes two pulses, that every
pulse seen by both cameras is paired, and that drops and unpaired frames are
counted exactly.
"""

from __future__ import annotations

import random
from dataclasses import dataclass

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.camera.pairing import LEFT, RIGHT, U32, Pairer, SequenceTracker

P = 100_000_000  # 10 Hz


@dataclass(frozen=True)
class Synth:
    t_ns: int
    sequence: int
    pulse: int
    arrival_ns: int = 0


@dataclass
class Trace:
    frames: list[tuple[int, Synth]]  # (side, frame) in arrival order
    delivered: tuple[set[int], set[int]]  # pulse ids delivered per side
    drops: tuple[int, int]  # exact sequence gaps the pairer can see
    offset_ns: int


@st.composite
def traces(draw) -> tuple[Trace, dict]:
    n = draw(st.integers(20, 250))
    jitter = [draw(st.floats(0.0, 0.15)) for _ in range(2)]  # each camera's stamp jitter, fraction of P
    common = draw(st.floats(0.0, 0.02))  # trigger jitter, seen by both
    room = 0.48 - jitter[0] - jitter[1] - 2 * common
    offset = draw(st.floats(-room, room))  # right stamps minus left, constant
    drop = [draw(st.floats(0.0, 0.5)) for _ in range(2)]
    miss = [draw(st.floats(0.0, 0.15)) for _ in range(2)]
    late = [draw(st.floats(0.0, 2.0)) for _ in range(2)]  # periods; max_pending=4 takes up to 2
    start = [draw(st.sampled_from([0, 7, U32 - 1, U32 - 30])) for _ in range(2)]
    restarts = [set(draw(st.lists(st.integers(5, n - 1), max_size=2))) for _ in range(2)]
    explicit = draw(st.booleans())
    rng = random.Random(draw(st.integers(0, 2**32)))

    base = 10**15  # CLOCK_MONOTONIC after ~12 days of uptime
    pulses = [base + k * P + round(rng.uniform(-common, common) * P) for k in range(n)]
    per_side: list[list[tuple[int, Synth, bool]]] = [[], []]  # (arrival, frame, restart-before)
    delivered: tuple[set[int], set[int]] = (set(), set())
    drops = [0, 0]
    for side in (LEFT, RIGHT):
        seq, arrival, pending_drops, seen_any, restart_flag = start[side], 0, 0, False, False
        for k, t in enumerate(pulses):
            if k in restarts[side] and seen_any and 0 < (seq - 1) % U32 < U32 // 2:
                seq, pending_drops, seen_any, restart_flag = 0, 0, False, True
                forced = True  # the first frame after a restart is delivered (it shows the step back)
            else:
                forced = False
            if not forced and rng.random() < miss[side]:
                continue  # this camera never saw the pulse: no frame, no sequence step
            if not forced and rng.random() < drop[side]:
                seq = (seq + 1) % U32
                pending_drops += seen_any  # visible only once a later frame of this stream arrives
                continue
            stamp = t + round((offset if side == RIGHT else 0.0) * P + rng.uniform(-1, 1) * jitter[side] * P)
            arrival = max(arrival + 1, stamp + round(rng.uniform(0, late[side]) * P))  # in order per camera
            drops[side] += pending_drops
            pending_drops, seen_any = 0, True
            per_side[side].append((arrival, Synth(stamp, seq, k, arrival), restart_flag))
            restart_flag = False
            delivered[side].add(k)
            seq = (seq + 1) % U32
    merged = sorted([(a, rng.random(), side, f, r) for side in (LEFT, RIGHT) for a, f, r in per_side[side]])
    frames = []
    for _, _, side, f, restart_flag in merged:
        if restart_flag and explicit:
            frames.append((side, None))  # the source knows it reopened the camera
        frames.append((side, f))
    return Trace(frames, delivered, (drops[0], drops[1]), round(offset * P)), {"jitter": jitter}


@settings(max_examples=300, deadline=None)
@given(traces())
def test_never_mispairs_and_counts_exactly(case) -> None:
    trace, _ = case
    pairer: Pairer[Synth] = Pairer(P, max_pending=4)
    pairs = []
    for side, frame in trace.frames:
        if frame is None:
            pairer.restart(side)
        else:
            pairs += pairer.push(side, frame)
    pairer.flush()
    for left, right in pairs:
        assert left.pulse == right.pulse, f"paired pulse {left.pulse} with {right.pulse}"
    both = trace.delivered[LEFT] & trace.delivered[RIGHT]
    assert {left.pulse for left, _ in pairs} == both  # every pulse both cameras delivered is paired
    assert pairer.pairs == len(both)
    assert pairer.unpaired == [len(trace.delivered[s] - both) for s in (LEFT, RIGHT)]
    assert pairer.drops == trace.drops


@settings(max_examples=50, deadline=None)
@given(traces())
def test_offset_estimate_converges(case) -> None:
    trace, params = case
    pairer: Pairer[Synth] = Pairer(P)
    for side, frame in trace.frames:
        if frame is not None:
            pairer.push(side, frame)
    if pairer.pairs >= 31:
        worst = (params["jitter"][0] + params["jitter"][1]) * P
        assert abs(pairer.offset_ns - trace.offset_ns) <= worst + 0.05 * P


def test_sequence_tracker_wrap_restart_and_repeat() -> None:
    t = SequenceTracker()
    for seq in (U32 - 2, U32 - 1, 1, 2, 5):  # 0 dropped across the wrap, then 3 and 4
        t.update(seq)
    assert (t.drops, t.restarts) == (3, 0)
    t.update(0)  # back to 0: a restart, no drops
    t.update(0)
    assert (t.drops, t.restarts, t.repeats) == (3, 1, 1)
    t.restart()
    t.update(100)  # after an announced restart anything goes
    assert (t.drops, t.restarts) == (3, 2)


def test_late_camera_keeps_pairs_and_dead_camera_bounds_memory() -> None:
    pairer: Pairer[Synth] = Pairer(P, max_pending=3)
    lefts = [Synth(k * P, k, k) for k in range(10)]
    rights = [Synth(k * P + 1_000_000, k, k) for k in range(10)]
    out = []
    for k in range(10):  # right arrives two frames late
        out += pairer.push(LEFT, lefts[k])
        if k >= 2:
            out += pairer.push(RIGHT, rights[k - 2])
    for r in rights[8:]:
        out += pairer.push(RIGHT, r)
    assert [(a.pulse, b.pulse) for a, b in out] == [(k, k) for k in range(10)]
    for k in range(10, 20):  # right camera dead: left keeps at most max_pending waiting
        pairer.push(LEFT, Synth(k * P, k, k))
    assert len(pairer.pending[LEFT]) == 3 and pairer.unpaired == [7, 0]
    stats = pairer.skew_stats()
    assert stats.pairs == 10 and stats.max_abs_ns == 1_000_000 and stats.offset_ns == 1_000_000


def test_rejects_bad_tolerance() -> None:
    with pytest.raises(ValueError):
        Pairer(P, tolerance_ns=P)
    with pytest.raises(ValueError):
        Pairer(0)
