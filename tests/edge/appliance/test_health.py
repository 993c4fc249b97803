"""HealthMonitor: heartbeats -> OK / DEGRADED / STALLED, status bits, fault code, rates."""

from __future__ import annotations

import threading

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.appliance.health import HealthMonitor, HealthState, Stage, Status, standard_stages


class Clock:
    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


def monitor(clock: Clock, **kw) -> HealthMonitor:
    return HealthMonitor(standard_stages([("nmea", Status.NMEA_ACTIVE), ("modbus", Status(0))]),
                         clock=clock, **kw)


def beat_all(h: HealthMonitor, names=("camera_left", "camera_right", "processing", "nmea", "modbus")):
    for name in names:
        h.beat(name)


def test_nothing_beaten_yet_is_stalled_on_the_first_critical_stage() -> None:
    snap = monitor(Clock()).snapshot()
    assert snap.state is HealthState.STALLED
    assert snap.reason == "camera_left: no heartbeat since start"
    assert snap.fault_code == 11
    assert snap.status_bits == Status.FAULT
    assert snap.frame_rate_hz is None and snap.latency_s is None


def test_all_fresh_is_ok_with_every_stage_bit_and_the_static_flags() -> None:
    clock = Clock()
    h = monitor(clock)
    h.set_flags(Status.CALIBRATION_VALID | Status.SITE_SURVEYED | Status.TIME_SYNC)
    h.set_flags(Status.TIME_SYNC, on=False)
    beat_all(h)
    snap = h.snapshot()
    assert snap.state is HealthState.OK and snap.reason == "" and snap.fault_code == 0
    expected = (Status.OK | Status.CAMERA_LEFT | Status.CAMERA_RIGHT | Status.TRACKER_RUNNING
                | Status.NMEA_ACTIVE | Status.CALIBRATION_VALID | Status.SITE_SURVEYED)
    assert snap.status_bits == int(expected)


def test_freshness_boundary_is_inclusive() -> None:
    clock = Clock()
    h = monitor(clock)
    beat_all(h)
    clock.t += 2.0  # cameras/processing stall after 2 s
    assert h.snapshot().state is HealthState.OK
    clock.t += 0.01
    snap = h.snapshot()
    assert snap.state is HealthState.STALLED
    assert snap.reason == "camera_left: no heartbeat for 2.0 s"


def test_stale_output_degrades_and_clears_its_bit() -> None:
    clock = Clock()
    h = monitor(clock)
    beat_all(h)
    clock.t += 4.0
    beat_all(h, ("camera_left", "camera_right", "processing", "modbus"))
    clock.t += 1.5  # nmea last beat 5.5 s ago (outputs stall after 5 s)
    snap = h.snapshot()
    assert snap.state is HealthState.DEGRADED
    assert snap.reason == "nmea: no heartbeat for 5.5 s"
    assert snap.fault_code == 41
    assert snap.status_bits & Status.DEGRADED and not snap.status_bits & Status.NMEA_ACTIVE
    assert not snap.status_bits & (Status.OK | Status.FAULT)


def test_reported_fault_degrades_with_its_text_and_code() -> None:
    clock = Clock()
    h = monitor(clock)
    beat_all(h)
    h.beat("camera_right", fault="frame timeout")
    snap = h.snapshot()
    assert (snap.state, snap.reason, snap.fault_code) == (
        HealthState.DEGRADED, "camera_right: frame timeout", 22)
    assert not snap.status_bits & Status.CAMERA_RIGHT and snap.status_bits & Status.CAMERA_LEFT
    h.beat("camera_right")  # the next healthy beat clears it
    assert h.snapshot().state is HealthState.OK


def test_worst_problem_wins_over_an_earlier_lesser_one() -> None:
    clock = Clock()
    h = monitor(clock)
    beat_all(h)
    h.beat("camera_left", fault="exposure clipped")
    clock.t += 3.0
    beat_all(h, ("camera_left", "camera_right", "nmea", "modbus"))  # processing stalls
    snap = h.snapshot()
    assert (snap.state, snap.fault_code) == (HealthState.STALLED, 31)
    assert snap.reason.startswith("processing: no heartbeat")
    assert snap.status_bits & Status.FAULT and not snap.status_bits & Status.TRACKER_RUNNING


@settings(max_examples=40, deadline=None)
@given(rate_hz=st.floats(1.0, 120.0), n=st.integers(3, 200), window_s=st.floats(0.5, 5.0))
def test_frame_rate_of_periodic_beats_is_the_beat_rate(rate_hz: float, n: int, window_s: float) -> None:
    clock = Clock()
    h = monitor(clock, rate_window_s=window_s)
    period = 1.0 / rate_hz
    times = [1000.0 + i * period for i in range(n)]
    for t in times:
        clock.t = t
        h.beat("processing", frames=1)
    in_window = sum(1 for t in times if t >= times[-1] - window_s)
    snap = h.snapshot()
    if in_window < 2:
        assert snap.frame_rate_hz is None
    else:
        assert snap.frame_rate_hz == pytest.approx(rate_hz, rel=1e-9)


def test_frame_rate_falls_to_zero_when_frames_stop() -> None:
    clock = Clock()
    h = monitor(clock, rate_window_s=2.0)
    for _ in range(10):
        h.beat("processing", frames=2)
        clock.t += 0.1
    assert h.snapshot().frame_rate_hz == pytest.approx(18 / 1.0)  # 9 beats of 2 after the first, 1.0 s
    clock.t += 5.0
    assert h.snapshot().frame_rate_hz == 0.0


def test_latency_is_the_largest_of_fresh_stages_and_uptime_counts_from_start() -> None:
    clock = Clock()
    h = monitor(clock)
    beat_all(h)
    h.beat("nmea", latency_s=0.30)
    h.beat("processing", latency_s=0.12)
    h.beat("processing", counters={"dropped": 3})
    snap = h.snapshot()
    assert snap.latency_s == pytest.approx(0.30)
    assert {s.name: dict(s.counters) for s in snap.stages}["processing"] == {"dropped": 3}
    clock.t += 5.5
    h.beat("processing")
    snap = h.snapshot()
    assert snap.latency_s == pytest.approx(0.12)  # nmea is stale now
    assert snap.uptime_s == pytest.approx(5.5)


def test_bad_configuration_and_unknown_stage_are_refused() -> None:
    with pytest.raises(ValueError, match="unique"):
        HealthMonitor([Stage("a", 1, 1.0), Stage("a", 2, 1.0)])
    with pytest.raises(ValueError, match="codes"):
        HealthMonitor([Stage("a", 1, 1.0), Stage("b", 1, 1.0)])
    with pytest.raises(KeyError, match="unknown health stage"):
        monitor(Clock()).beat("gps")


def test_beats_from_many_threads_are_all_recorded() -> None:
    h = HealthMonitor([Stage("processing", 1, 10.0)])

    def worker(name: str) -> None:
        for k in range(1, 2001):
            h.beat("processing", counters={name: k})

    threads = [threading.Thread(target=worker, args=(f"w{i}",)) for i in range(4)]
    for t in threads:
        t.start()
    for _ in range(200):
        h.snapshot()  # concurrently with the beats
    for t in threads:
        t.join()
    assert dict(h.snapshot().stages[0].counters) == {f"w{i}": 2000 for i in range(4)}
