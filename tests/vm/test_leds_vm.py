"""SysfsLedPanel on real LED class devices (uleds in the appliance VM): heartbeat while OK, green and
red blinking together while DEGRADED, steady red while STALLED, and a steady green while the driving
process is SIGSTOPped, because the daemon's loop, not a kernel trigger, toggles the LEDs.

One VM boot (~25 s); the scenario is tests/vm/uleds_guest.py, which prints the brightness changes.
"""

from __future__ import annotations

import sys

import pytest
from systemd_harness import ROOT, require_vm, run_vm, tagged_json

pytestmark = pytest.mark.slow
S = 1_000_000_000


@pytest.fixture(scope="module")
def leds() -> dict:
    require_vm()
    run = run_vm(["env", f"PYTHONPATH={ROOT}", sys.executable, "-S", "tests/vm/uleds_guest.py"],
                 timeout_s=180)
    assert run.rc == 0, run.output[-4000:]
    result = tagged_json(run.output, "ULEDS-RESULT")
    result["wall_s"] = run.wall_s
    return result


class Timeline:
    def __init__(self, result: dict) -> None:
        self.t0, self.marks = result["t0_ns"], result["marks"]
        self.events = [(t - self.t0, role, value) for t, role, value in result["events"]]

    def at(self, mark: str) -> int:
        return self.marks[mark] - self.t0

    def changes(self, role: str, a_ns: int, b_ns: int) -> list[tuple[int, int]]:
        return [(t, v) for t, r, v in self.events if r == role and a_ns <= t < b_ns]

    def level(self, role: str, t_ns: int) -> int:
        before = [v for t, r, v in self.events if r == role and t <= t_ns]
        return before[-1] if before else 0

    def on_durations_ms(self, role: str, a_ns: int, b_ns: int) -> list[float]:
        c = self.changes(role, a_ns, b_ns)
        return [(t1 - t0) / 1e6 for (t0, v0), (t1, v1) in zip(c, c[1:], strict=False) if v0 and not v1]


def test_ok_is_a_heartbeat_on_green(leds: dict) -> None:
    tl = Timeline(leds)
    pulses = tl.on_durations_ms("ok", S // 2, 3 * S)
    assert 4 <= len(pulses) <= 6 and all(50 <= p <= 200 for p in pulses), pulses  # 2 x 100 ms per second
    assert tl.changes("fault", S // 2, 3 * S) == [] and tl.level("fault", 2 * S) == 0


def test_degraded_blinks_green_and_red_together(leds: dict) -> None:
    tl = Timeline(leds)
    a, b = 3 * S + S // 4, 6 * S
    for role in ("ok", "fault"):
        on = tl.on_durations_ms(role, a, b)
        assert 4 <= len(on) <= 6 and all(150 <= p <= 350 for p in on), (role, on)  # 250 ms of 500
    rises = {role: [t for t, v in tl.changes(role, a, b) if v] for role in ("ok", "fault")}
    assert all(abs(g - r) < 50_000_000 for g, r in zip(rises["ok"], rises["fault"], strict=True)), rises


def test_stalled_is_steady_red(leds: dict) -> None:
    tl = Timeline(leds)
    a, b = 6 * S + S // 10, 8 * S
    assert tl.changes("ok", a, b) == [] and tl.changes("fault", a, b) == []
    assert (tl.level("ok", a), tl.level("fault", a)) == (0, 255)


def test_a_stopped_daemon_leaves_a_steady_led_and_a_resumed_one_beats_again(leds: dict) -> None:
    tl = Timeline(leds)
    stop, cont, term = tl.at("stop"), tl.at("cont"), tl.at("term")
    assert len(tl.changes("ok", 8 * S + S // 2, stop)) >= 4  # it was beating
    assert tl.changes("ok", stop + S // 5, cont) == []  # 3 s without a change while stopped
    assert tl.changes("fault", stop, cont) == []
    assert len(tl.changes("ok", cont + S // 2, term)) >= 4  # and beats again


def test_close_leaves_red_on(leds: dict) -> None:
    tl = Timeline(leds)
    end = tl.at("term") + 10 * S
    assert leds["child_rc"] == 0
    assert (tl.level("ok", end), tl.level("fault", end)) == (0, 255)
    assert {"mast:green:ok", "mast:red:fault"} <= set(leds["leds"])
