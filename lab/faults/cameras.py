"""Camera faults against the running daemon: unplug/replug, trigger loss and bursts, drops, skew.

Each case runs the daemon on two fake V4L2 cameras (lab/faults/_rig.py: the real V4L2PairSource
and pairer over the kernel-ABI fake) and reads the unit as a technician's tools would: the Modbus
STATUS word and FAULT_CODE over TCP, the LED panel, the NMEA port. Every processed pair is checked
against the ground-truth pulse ids the fake cameras stamp, so "no mispaired pair" is a count.

- camera-unplug: left, right, then both unplugged for UNPLUG_S and replugged, in one run. DEGRADED
  within 1 s on Modbus (DEGRADED bit, the camera's bit cleared) and on the LEDs; OK again within
  5 s of the replug; no pair made of frames from either side of the gap.
- camera-pairing: trigger loss (no pulses for 1 s), a trigger burst (5 extra pulses 10 ms apart),
  the right camera losing every 3rd frame, a constant skew of twice `cameras.max_skew_ms`: no
  mispaired pair processed, every injected drop counted on the camera's health counters.
"""

from __future__ import annotations

import time
from pathlib import Path

from edge.appliance.health import Status
from lab.faults._rig import Bench, degraded, ok
from lab.faults.matrix import Case, Row

UNPLUG_S = 0.8
DEGRADED_WITHIN_S, OK_WITHIN_S = 1.0, 5.0
CAMERA_BIT = {"left": Status.CAMERA_LEFT, "right": Status.CAMERA_RIGHT}


def _unplug_row(bench: Bench, sides: tuple[str, ...]) -> Row:
    name = " and ".join(sides)
    bits = 0
    for side in sides:
        bits |= CAMERA_BIT[side]
    k_out = bench.pulse
    t_out = time.monotonic()
    for side in sides:
        bench.unplug(side)
    t_modbus = bench.modbus.first(t_out, lambda s, f: degraded(s, f) and not s & bits) \
        if bench.wait(lambda: bench.modbus.first(t_out, lambda s, f: degraded(s, f) and not s & bits),
                      3.0) else None
    t_led = bench.wait(lambda: bench.led_state() == "DEGRADED", 3.0)
    fault_codes = sorted({f for t, s, f in bench.modbus.samples if t >= t_out and degraded(s, f)})
    left = UNPLUG_S - (time.monotonic() - t_out)
    if left > 0:
        time.sleep(left)
    k_in = bench.pulse
    t_in = time.monotonic()
    for side in sides:
        bench.replug(side)
    t_back = bench.wait(lambda: bench.modbus.first(t_in, ok) is not None and bench.led_state() == "OK", 8.0)
    t_ok = bench.modbus.first(t_in, ok)
    bad = bench.mispaired()
    across = [p for p in bench.processed if p.t_s >= t_out and p.pulse_left is not None
              and k_out + 1 < p.pulse_left < k_in]  # a pair from inside the gap
    d_mb = None if t_modbus is None else t_modbus - t_out
    d_led = None if t_led is None else t_led - t_out
    d_ok = None if t_back is None or t_ok is None else max(t_back, t_ok) - t_in
    passed = (d_mb is not None and d_mb <= DEGRADED_WITHIN_S and d_led is not None
              and d_led <= DEGRADED_WITHIN_S and d_ok is not None and d_ok <= OK_WITHIN_S
              and not bad and not across)
    fmt = lambda d: "never" if d is None else f"{d:.2f} s"  # noqa: E731
    return Row(f"{name} camera unplugged {UNPLUG_S:g} s, replugged",
               f"DEGRADED <= {DEGRADED_WITHIN_S:g} s, OK <= {OK_WITHIN_S:g} s after, no cross-gap pair",
               f"DEGRADED modbus {fmt(d_mb)} led {fmt(d_led)} (code {fault_codes}); OK {fmt(d_ok)}; "
               f"{len(bad)} mispaired, {len(across)} in gap", passed, d_ok)


def camera_unplug(workdir: Path) -> list[Row]:
    with Bench(workdir) as bench:
        if not bench.ready():
            return [Row("daemon on fake cameras", "READY=1 and OK", "never ready", False)]
        rows = []
        for sides in (("left",), ("right",), ("left", "right")):
            rows.append(_unplug_row(bench, sides))
            time.sleep(0.3)
        return rows


def _counter(bench: Bench, side: str, name: str) -> int:
    return bench.stage_counters(f"camera_{side}").get(name, 0)


def camera_pairing(workdir: Path) -> list[Row]:
    max_skew_ms = 2.0
    with Bench(workdir, max_skew_ms=max_skew_ms) as bench:
        if not bench.ready():
            return [Row("daemon on fake cameras", "READY=1 and OK", "never ready", False)]
        rows = []
        # trigger loss: no pulse reaches either camera for 1 s
        t0 = time.monotonic()
        bench.trigger_on = False
        t_deg = bench.wait(lambda: bench.modbus.first(t0, degraded) is not None, 3.0)
        time.sleep(max(0.0, 1.0 - (time.monotonic() - t0)))
        bench.trigger_on = True
        t_on = time.monotonic()
        t_ok = bench.wait(lambda: bench.modbus.first(t_on, ok) is not None, 5.0)
        drops = _counter(bench, "left", "drops") + _counter(bench, "right", "drops")
        bad = bench.mispaired(t0)
        rows.append(Row("trigger lost 1 s", "DEGRADED, no mispaired pair, OK after",
                        f"DEGRADED after {_s(t_deg, t0)}, OK {_s(t_ok, t_on)} after; {len(bad)} mispaired; "
                        f"drops {drops} (no pulse is no frame lost)",
                        t_deg is not None and t_ok is not None and not bad,
                        None if t_ok is None else t_ok - t_on))
        # a burst of 5 extra pulses 10 ms apart (the camera has 4 buffers: some frames are lost)
        t0 = time.monotonic()
        n0 = len(bench.processed)
        before = {s: (_counter(bench, s, "drops"), _counter(bench, s, "unpaired")) for s in ("left", "right")}
        bench.burst = 5
        time.sleep(1.0)
        bad = bench.mispaired(t0)
        after = {s: (_counter(bench, s, "drops"), _counter(bench, s, "unpaired")) for s in ("left", "right")}
        pulses = [p.pulse_left for p in bench.processed[n0:]]
        rows.append(Row("trigger burst: 5 extra pulses 10 ms apart", "no mispaired pair; losses counted",
                        f"{len(pulses)} pairs processed, {len(bad)} mispaired; drops/unpaired L "
                        f"{_delta(before['left'], after['left'])} "
                        f"R {_delta(before['right'], after['right'])}",
                        not bad and len(pulses) > 0))
        # the right camera loses every 3rd frame for 1.5 s
        t0 = time.monotonic()
        drops0, unpaired0 = _counter(bench, "right", "drops"), _counter(bench, "left", "unpaired")
        injected0 = bench.dropped_by_us["right"]
        bench.drop_every = ("right", 3)
        time.sleep(1.5)
        bench.drop_every = None
        time.sleep(0.6)  # the next frame shows the last gap
        injected = bench.dropped_by_us["right"] - injected0
        counted = _counter(bench, "right", "drops") - drops0
        unpaired = _counter(bench, "left", "unpaired") - unpaired0
        bad = bench.mispaired(t0)
        rows.append(Row("right camera drops every 3rd frame 1.5 s", "no mispaired pair; every drop counted",
                        f"{injected} dropped, {counted} counted (drops_right), "
                        f"{unpaired} left frames unpaired; "
                        f"{len(bad)} mispaired", not bad and injected > 0 and counted == injected
                        and unpaired == injected))
        # a constant skew of twice the tolerance: no pair may be made at all
        t0 = time.monotonic()
        n0 = len(bench.processed)
        bench.skew_us = round(2 * max_skew_ms * 1000)
        t_deg = bench.wait(lambda: bench.modbus.first(t0, degraded) is not None, 3.0)
        time.sleep(max(0.0, 1.0 - (time.monotonic() - t0)))
        during = [p for p in bench.processed[n0:] if p.t_s > t0 + 0.2]  # pairs in flight at the change
        unpaired0 = _counter(bench, "left", "unpaired") + _counter(bench, "right", "unpaired")
        bench.skew_us = 0
        t_on = time.monotonic()
        t_ok = bench.wait(lambda: bench.modbus.first(t_on, ok) is not None, 5.0)
        bad = bench.mispaired(t0)
        rows.append(Row(f"constant skew {2 * max_skew_ms:g} ms > max_skew_ms {max_skew_ms:g}",
                        "no pair, DEGRADED, frames counted unpaired",
                        f"{len(during)} pairs, {len(bad)} mispaired, DEGRADED after {_s(t_deg, t0)}, "
                        f"{unpaired0} unpaired in all; OK {_s(t_ok, t_on)} after",
                        not during and not bad and t_deg is not None and t_ok is not None,
                        None if t_ok is None else t_ok - t_on))
        return rows


def _s(t: float | None, t0: float) -> str:
    return "never" if t is None else f"{t - t0:.2f} s"


def _delta(before: tuple[int, int], after: tuple[int, int]) -> str:
    return f"+{after[0] - before[0]}/+{after[1] - before[1]}"


CASES = [
    Case("camera-unplug", "cameras", camera_unplug),
    Case("camera-pairing", "cameras", camera_pairing),
]
