"""LED patterns, the health -> pattern mapping, and the tick() contract (on the virtual panel)."""

from __future__ import annotations

import enum

import pytest

from drivers.leds.base import (
    AMBER_LED,
    FAULT_LED,
    OFF,
    OK_LED,
    ON,
    Kind,
    Pattern,
    blink,
    health_patterns,
    heartbeat,
)
from drivers.leds.virtual import VirtualLedPanel

MS = 1_000_000
S = 1000 * MS


class FakeHealthState(enum.Enum):  # like edge.appliance.health.HealthState (drivers never import edge)
    OK = "OK"
    DEGRADED = "DEGRADED"
    STALLED = "STALLED"


def test_blink_is_on_for_the_first_half_of_its_period() -> None:
    p = blink(0.5)
    assert [p.level(t * MS) for t in (0, 249, 250, 499, 500, 749, 750)] == [1, 1, 0, 0, 1, 1, 0]
    assert p.next_change_ns(0) == 250 * MS
    assert p.next_change_ns(250 * MS) == 500 * MS
    assert p.next_change_ns(10 * S + 300 * MS) == 10 * S + 500 * MS


def test_heartbeat_is_two_short_pulses_per_period() -> None:
    p = heartbeat(1.0)
    lit = [t for t in range(0, 1000, 10) if p.level(t * MS)]
    assert lit == list(range(0, 100, 10)) + list(range(250, 350, 10))
    edges, t = [], 3 * S + 500 * MS
    for _ in range(5):
        t = p.next_change_ns(t)
        edges.append(t - 4 * S)
    assert edges == [0, 100 * MS, 250 * MS, 350 * MS, 1 * S]


def test_steady_patterns_never_change() -> None:
    assert ON.level(123) and not OFF.level(123)
    assert ON.next_change_ns(5) is None and OFF.next_change_ns(5) is None


@pytest.mark.parametrize("bad", [lambda: Pattern(Kind.BLINK, 0), lambda: Pattern(Kind.ON, 5 * MS)])
def test_pattern_rejects_nonsense_periods(bad) -> None:
    with pytest.raises(ValueError):
        bad()


def test_health_mapping_without_amber_led() -> None:
    assert health_patterns("OK", amber=False) == {OK_LED: heartbeat(), FAULT_LED: OFF}
    assert health_patterns("DEGRADED", amber=False) == {OK_LED: blink(), FAULT_LED: blink()}
    assert health_patterns("STALLED", amber=False) == {OK_LED: OFF, FAULT_LED: ON}


def test_health_mapping_with_amber_led_and_an_enum_state() -> None:
    assert health_patterns(FakeHealthState.OK, amber=True) == {OK_LED: heartbeat(), FAULT_LED: OFF,
                                                                AMBER_LED: OFF}
    assert health_patterns(FakeHealthState.DEGRADED, amber=True) == {OK_LED: OFF, FAULT_LED: OFF,
                                                                      AMBER_LED: blink()}
    assert health_patterns(FakeHealthState.STALLED, amber=True)[FAULT_LED] == ON
    assert health_patterns("DEGRADED", amber=True, blink_period_s=2.0)[AMBER_LED] == blink(2.0)


def test_health_mapping_rejects_unknown_states() -> None:
    with pytest.raises(ValueError, match="STARTING"):
        health_patterns("STARTING", amber=False)


def _run(panel: VirtualLedPanel, start_ns: int, end_ns: int) -> int:
    """The daemon's loop: tick, sleep until the deadline tick() returned, repeat."""
    t, ticks = start_ns, 0
    while t <= end_ns:
        t = panel.tick(t)
        ticks += 1
    return ticks


def test_ticking_at_the_returned_deadlines_writes_every_edge_once() -> None:
    panel = VirtualLedPanel()
    panel.show_health("OK")
    ticks = _run(panel, 10 * S, 12 * S)
    ok = panel.history[OK_LED]
    assert [v for _, v in ok] == [1, 0, 1, 0] * 2 + [1]
    assert [t - 10 * S for t, _ in ok] == [0, 100 * MS, 250 * MS, 350 * MS,
                                           1 * S, 1100 * MS, 1250 * MS, 1350 * MS, 2 * S]
    assert panel.history[FAULT_LED] == [(10 * S, 0)]
    assert ticks == 9


def test_degraded_blinks_green_and_red_in_phase_then_stalled_is_steady_red() -> None:
    panel = VirtualLedPanel()
    panel.show_health("DEGRADED")
    _run(panel, 20 * S, 21 * S)
    assert panel.history[OK_LED] == panel.history[FAULT_LED]
    assert [v for _, v in panel.history[FAULT_LED]] == [1, 0, 1, 0, 1]
    panel.show_health("STALLED")
    panel.tick(21 * S)
    deadline = panel.tick(21 * S + 1)
    assert deadline == 22 * S + 1  # nothing blinks: the idle deadline
    assert panel.levels() == {OK_LED: 0, FAULT_LED: 1}


def test_a_panel_not_ticked_keeps_its_level() -> None:
    panel = VirtualLedPanel()
    panel.show_health("OK")
    panel.tick(0)
    panel.tick(50 * MS)  # mid-pulse: stays lit however long nobody ticks
    assert panel.levels()[OK_LED] == 1 and len(panel.history[OK_LED]) == 1


def test_a_missing_led_is_retried_and_the_rest_still_shows() -> None:
    panel = VirtualLedPanel(missing={FAULT_LED})
    panel.show_health("STALLED")
    deadline = panel.tick(0)
    assert panel.history[FAULT_LED] == [] and panel.history[OK_LED] == [(0, 0)]
    assert deadline == 1 * S
    panel.missing.clear()
    panel.tick(deadline)
    assert panel.history[FAULT_LED] == [(1 * S, 1)]


def test_show_rejects_leds_the_panel_does_not_have() -> None:
    with pytest.raises(KeyError, match="amber"):
        VirtualLedPanel().show({AMBER_LED: ON})


def test_close_leaves_steady_red_and_releases() -> None:
    panel = VirtualLedPanel((OK_LED, FAULT_LED, AMBER_LED), max_brightness=255)
    panel.show_health("OK")
    panel.tick(0)
    panel.close(now_ns=5 * MS)
    assert panel.levels() == {OK_LED: 0, FAULT_LED: 255, AMBER_LED: 0} and panel.released
    panel.tick(10 * S)
    assert panel.levels()[FAULT_LED] == 255
    assert "ok=off" in panel.describe()
