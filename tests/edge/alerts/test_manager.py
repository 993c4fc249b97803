"""The alert manager (edge.alerts.manager): close quarters with confidence and hysteresis, the
event alerts, dark targets, capacity and appliance faults."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from edge.alerts.manager import AlertId, AlertManager, AlertState
from edge.appliance.health import HealthSnapshot, HealthState, StageHealth, Status
from edge.config.alerts import AlertsConfig
from edge.fix import ShipFix, TrackStatus

T0_NS = 1_790_000_000_000_000_000
COV = (25.0, 0, 0, 0, 0, 25.0, 0, 0, 0, 0, 0.01, 0, 0, 0, 0, 0.01)  # 5 m, 0.1 m/s


def fix(
    track_id: int,
    t_s: float,
    state: tuple[float, float, float, float] | None,
    status: TrackStatus = TrackStatus.TRACKING,
    cov: tuple[float, ...] = COV,
    dark: bool = False,
    length_m: float = 80.0,
) -> ShipFix:
    """A fix whose ground state is `state` at t = 0 moved on to `t_s` (constant velocity)."""
    en = None if state is None else (state[0] + state[2] * t_s, state[1] + state[3] * t_s, state[2], state[3])
    return ShipFix(
        T0_NS + round(t_s * 1e9),
        track_id,
        status,
        0.0,
        0.0,
        1000.0,
        1000.0,
        0.0,
        34.6,
        135.0,
        5.0,
        0.0,
        10.0,
        5.0,
        length_m=length_m,
        dark=dark,
        en_state=en,
        en_cov=None if state is None else cov,
    )


def run(
    manager: AlertManager, states: dict[int, tuple[float, float, float, float]], t_s: range, **kw: object
) -> list[tuple[float, AlertState]]:
    """Step once a second; the close-quarters state changes (time, state)."""
    out = []
    for t in t_s:
        before = manager.sequence
        manager.step([fix(i, t, s, **kw) for i, s in states.items()], T0_NS + t * 1_000_000_000)  # type: ignore[arg-type]
        out += [
            (float(t), a.state)
            for _, a in manager.changes_since(before)
            if a.alert_id is AlertId.CLOSE_QUARTERS
        ]
    return out


def test_close_quarters_raises_after_confirmation_and_clears_after_passing() -> None:
    m = AlertManager(AlertsConfig(enabled=True), 32)
    # head-on 100 m apart laterally, closing at 6 m/s from 1800 m: CPA 100 m at t = 300 s
    states = {1: (0.0, 0.0, 0.0, 3.0), 2: (100.0, 1800.0, 0.0, -3.0)}
    changes = run(m, states, range(0, 340))
    # TCPA < 360 s from the start: raised once confirm_s (5 s) and 3 updates have held (t = 5)
    assert changes[0] == (5.0, AlertState.ACTIVE_UNACK)
    # passed: TCPA < -10 s from t = 311, held 5 s -> cleared at 316
    assert changes[1] == (316.0, AlertState.NORMAL)
    assert len(changes) == 2


def test_alert_tied_to_the_pair_and_carries_cpa() -> None:
    m = AlertManager(AlertsConfig(enabled=True), 32)
    run(m, {3: (0.0, 0.0, 0.0, 3.0), 7: (100.0, 1800.0, 0.0, -3.0), 9: (5000.0, 0.0, 0.0, 1.0)}, range(0, 20))
    (alert,) = [a for a in m.active() if a.alert_id is AlertId.CLOSE_QUARTERS]
    assert alert.tracks == (3, 7)
    assert alert.cpa_m is not None and math.isclose(alert.cpa_m, 100.0, abs_tol=1e-6)
    assert alert.tcpa_s is not None and math.isclose(alert.tcpa_s, 300.0 - 19.0, abs_tol=1e-6)


def test_wide_sigma_keeps_the_alert_down() -> None:
    """CPA 100 m but a 300 m sigma on the miss distance: CPA + 2 sigma > 500 m, no alert."""
    wide = (90000.0, 0, 0, 0, 0, 90000.0, 0, 0, 0, 0, 0.01, 0, 0, 0, 0, 0.01)
    m = AlertManager(AlertsConfig(enabled=True), 32)
    assert run(m, {1: (0.0, 0.0, 0.0, 3.0), 2: (100.0, 1800.0, 0.0, -3.0)}, range(0, 60), cov=wide) == []


def test_lost_track_clears_close_quarters_at_once() -> None:
    m = AlertManager(AlertsConfig(enabled=True), 32)
    states = {1: (0.0, 0.0, 0.0, 3.0), 2: (100.0, 1800.0, 0.0, -3.0)}
    run(m, states, range(0, 10))
    m.step([fix(1, 10, states[1])], T0_NS + 10 * 10**9)
    assert not [a for a in m.active() if a.alert_id is AlertId.CLOSE_QUARTERS]
    assert [a.tracks for a in m.active() if a.alert_id is AlertId.TARGET_LOST] == [(2,)]


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 1500.0), st.floats(60.0, 340.0), st.floats(1.0, 8.0), st.floats(0, 2 * math.pi))
def test_raised_exactly_when_inside_the_limits(
    cpa_m: float, tcpa_s: float, speed: float, angle: float
) -> None:
    """Without uncertainty the alert is raised iff CPA < 500 m (TCPA inside 6 min throughout)."""
    v = (speed * math.sin(angle), speed * math.cos(angle))
    n = (-v[1] / speed, v[0] / speed)
    # B relative to A: at t = tcpa it is cpa_m off A across the relative track
    b = (cpa_m * n[0] - v[0] * tcpa_s, cpa_m * n[1] - v[1] * tcpa_s, v[0], v[1])
    zero = (0.0,) * 16
    m = AlertManager(AlertsConfig(enabled=True), 32)
    changes = run(m, {1: (0.0, 0.0, 0.0, 0.0), 2: b}, range(0, 20), cov=zero)
    assert bool(changes) == (cpa_m < 500.0)


def test_event_alerts_new_and_lost_hold_then_end() -> None:
    m = AlertManager(AlertsConfig(enabled=True, event_hold_s=60.0), 32)
    for t in range(0, 70):
        m.step([fix(5, t, None)] if t < 30 else [], T0_NS + t * 10**9)
        if t == 0:
            assert [(a.alert_id, a.tracks) for a in m.active()] == [(AlertId.NEW_TARGET, (5,))]
        if t == 30:  # gone: lost raised, new ended
            assert [(a.alert_id, a.tracks) for a in m.active()] == [(AlertId.TARGET_LOST, (5,))]
    assert [a.alert_id for a in m.active()] == [AlertId.TARGET_LOST]  # held 60 s: until t = 90
    m.step([], T0_NS + 90 * 10**9)
    assert m.active() == []


def test_acknowledged_state_alert_goes_a_and_event_ends() -> None:
    m = AlertManager(AlertsConfig(enabled=True), 32)
    run(m, {1: (0.0, 0.0, 0.0, 3.0), 2: (100.0, 1800.0, 0.0, -3.0)}, range(0, 10))
    cq = next(a for a in m.active() if a.alert_id is AlertId.CLOSE_QUARTERS)
    new = next(a for a in m.active() if a.alert_id is AlertId.NEW_TARGET)
    assert m.acknowledge(cq.key) and m.acknowledge(new.key)
    after = {a.key: a for a in m.active()}
    assert after[cq.key].state is AlertState.ACTIVE_ACK and after[cq.key].revision == 2
    assert new.key not in after


def test_dark_target_follows_the_flag() -> None:
    m = AlertManager(AlertsConfig(enabled=True), 32)
    m.step([fix(4, 0, None, dark=True)], T0_NS)
    assert any(a.alert_id is AlertId.DARK_TARGET and a.tracks == (4,) for a in m.active())
    m.step([fix(4, 1, None, dark=False)], T0_NS + 10**9)
    assert not any(a.alert_id is AlertId.DARK_TARGET for a in m.active())


def test_capacity_caution_at_95_percent_and_full() -> None:
    m = AlertManager(AlertsConfig(enabled=True, confirm_s=2.0), 20)  # 95 % of 20: 19 tracks

    def levels(n: int, t0: int) -> set[int]:
        for t in range(t0, t0 + 4):
            m.step([fix(i, t, None) for i in range(1, n + 1)], T0_NS + t * 10**9)
        return {a.instance for a in m.active() if a.alert_id is AlertId.CAPACITY}

    assert levels(18, 0) == set()
    assert levels(19, 10) == {1}
    assert levels(20, 20) == {2}
    assert levels(17, 30) == set()


def _health(left_fresh: bool, calibration_valid: bool, ais: dict | None = None) -> HealthSnapshot:
    stages = (
        StageHealth("camera_left", left_fresh, 0.1, None, {}),
        StageHealth("camera_right", True, 0.1, None, {}),
        StageHealth("processing", True, 0.1, None, {}),
    ) + (() if ais is None else (StageHealth("ais", True, 0.1, None, ais),))
    bits = Status.CALIBRATION_VALID if calibration_valid else Status(0)
    state = HealthState.OK if left_fresh and calibration_valid else HealthState.DEGRADED
    return HealthSnapshot(state, "", int(bits), 0, 10.0, 0.1, 5.0, stages)


def test_appliance_faults_from_health() -> None:
    m = AlertManager(AlertsConfig(enabled=True, confirm_s=1.0), 32)
    for t in range(4):
        m.step([], T0_NS + t * 10**9, _health(False, False))
    assert {(a.alert_id, a.instance) for a in m.active()} == {
        (AlertId.CAMERA_LOST, 1),
        (AlertId.CALIBRATION, 1),
    }
    assert not m.health_ok
    for t in range(4, 8):
        m.step([], T0_NS + t * 10**9, _health(True, True))
    assert m.active() == [] and m.health_ok


def test_the_ais_calibration_check_raises_the_calibration_alert() -> None:
    m = AlertManager(AlertsConfig(enabled=True, confirm_s=1.0), 32)
    for t in range(4):
        m.step([], T0_NS + t * 10**9, _health(True, True, {"disparity_fault": 0, "bearing_fault": 0}))
    assert m.active() == []
    for t in range(4, 8):
        m.step([], T0_NS + t * 10**9, _health(True, True, {"disparity_fault": 1, "bearing_fault": 0}))
    assert {(a.alert_id, a.instance) for a in m.active()} == {(AlertId.CALIBRATION, 1)}
    for t in range(8, 20):
        m.step([], T0_NS + t * 10**9, _health(True, True, {"disparity_fault": 0, "bearing_fault": 0}))
    assert m.active() == []


def test_stop_clears_every_alert_and_raises_none() -> None:
    """At shutdown the daemon sends every track once more as L: no lost-target alert for that."""
    m = AlertManager(AlertsConfig(enabled=True), 32)
    run(m, {1: (0.0, 0.0, 0.0, 3.0), 2: (100.0, 1800.0, 0.0, -3.0)}, range(0, 10))
    assert len(m.active()) == 3
    before = m.sequence
    m.stop(T0_NS + 10 * 10**9)
    m.step([fix(1, 10, None, status=TrackStatus.LOST)], T0_NS + 10 * 10**9)
    assert m.active() == []
    assert {a.state for _, a in m.changes_since(before)} == {AlertState.NORMAL}


def test_capacity_full_is_a_warning_95_percent_a_caution() -> None:
    m = AlertManager(AlertsConfig(enabled=True, confirm_s=0.0), 20)
    for t in range(3):
        m.step([fix(i, t, None) for i in range(19)], T0_NS + t * 10**9)
    assert [(a.instance, a.priority) for a in m.active() if a.alert_id is AlertId.CAPACITY] == [(1, "C")]
    for t in range(3, 6):
        m.step([fix(i, t, None) for i in range(20)], T0_NS + t * 10**9)
    assert [(a.instance, a.priority) for a in m.active() if a.alert_id is AlertId.CAPACITY] == [(2, "W")]


def test_a_gap_in_the_motion_restarts_the_confirmation() -> None:
    """Danger seen twice, then a step without one ship's motion, then once more: not 3 in a row."""
    m = AlertManager(AlertsConfig(enabled=True, confirm_s=0.0), 32)
    states = {1: (0.0, 0.0, 0.0, 3.0), 2: (100.0, 1800.0, 0.0, -3.0)}
    for t in (0, 1):
        m.step([fix(i, t, s) for i, s in states.items()], T0_NS + t * 10**9)
    m.step([fix(1, 2, states[1]), fix(2, 2, None)], T0_NS + 2 * 10**9)
    m.step([fix(i, 3, s) for i, s in states.items()], T0_NS + 3 * 10**9)
    assert not any(a.alert_id is AlertId.CLOSE_QUARTERS for a in m.active())
    for t in (4, 5):
        m.step([fix(i, t, s) for i, s in states.items()], T0_NS + t * 10**9)
    assert any(a.alert_id is AlertId.CLOSE_QUARTERS for a in m.active())
