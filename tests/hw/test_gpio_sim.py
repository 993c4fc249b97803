"""In the VM: drivers/trigger/gpio drives a gpio-sim line; rate and pulse width read back from the sim side.

gpio-sim is set up through configfs (a chip with one bank of two lines); the
simulator's `sim_gpio0/value` shows what the consumer drives. A separate
process samples it (so its busy loop cannot delay the trigger thread through
the GIL) and reports the transitions; from those: rate within 1 %, median pulse
width within 10 %. 5 Hz with 50 ms pulses, the thread at SCHED_FIFO: under TCG on a
loaded host a wake-up can be several ms late, which a 2 ms pulse could not absorb.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from drivers.trigger.gpio import GpioTrigger

CONFIGFS = Path("/sys/kernel/config/gpio-sim")
SAMPLER = r"""
import os, sys, time
os.nice(5)  # the trigger thread comes first
fd = os.open(sys.argv[1], os.O_RDONLY)
end = time.monotonic_ns() + int(float(sys.argv[2]) * 1e9)
print("ready", flush=True)
last, out = None, []
while (now := time.monotonic_ns()) < end:
    value = os.pread(fd, 2, 0)[:1]
    if value != last:
        out.append(f"{now} {value.decode()}")
        last = value
print("\n".join(out), flush=True)
"""


@pytest.fixture
def sim_chip():
    dev = CONFIGFS / f"mast-test-{os.getpid()}"
    bank = dev / "gpio-bank0"
    bank.mkdir(parents=True)
    (bank / "num_lines").write_text("2")
    (dev / "live").write_text("1")
    chip = (bank / "chip_name").read_text().strip()
    value = (
        Path("/sys/devices/platform") / (dev / "dev_name").read_text().strip() / chip / "sim_gpio0" / "value"
    )
    yield f"/dev/{chip}", value
    (dev / "live").write_text("0")
    bank.rmdir()
    dev.rmdir()


def test_gpio_trigger_rate_and_pulse_width_on_the_sim(sim_chip) -> None:
    chip, value_path = sim_chip
    rate_hz, width_s, seconds = 5.0, 0.050, 4.0
    sampler = subprocess.Popen(
        [sys.executable, "-S", "-c", SAMPLER, str(value_path), str(seconds)],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert sampler.stdout.readline().strip() == "ready"
    trigger = GpioTrigger(chip, 0, rate_hz, pulse_width_s=width_s, realtime_priority=50)
    trigger.start()
    try:
        out, _ = sampler.communicate(timeout=seconds + 30)
    finally:
        trigger.stop()
    events = [(int(t), v) for t, v in (line.split() for line in out.split("\n") if line)]
    rises = [t for (t, v), (_, prev) in zip(events[1:], events, strict=False) if v == "1" and prev == "0"]
    falls = {t for (t, v), (_, prev) in zip(events[1:], events, strict=False) if v == "0" and prev == "1"}
    widths = [min(f for f in falls if f > r) - r for r in rises if any(f > r for f in falls)]
    stats = trigger.stats
    assert len(rises) >= 0.6 * rate_hz * seconds and len(widths) >= len(rises) - 1, stats
    # the pulse clock's rate from each edge's slot number: a pulse skipped because the emulated
    # machine stalled (counted in stats["missed"]) is a health event, not a rate error
    period_ns = 1e9 / rate_hz
    slots = [round((r - rises[0]) / period_ns) for r in rises]
    # Theil-Sen slope of edge time over slot number: an edge the emulator delayed cannot tilt it
    slopes = sorted(
        (tj - ti) / (kj - ki)
        for i, (ki, ti) in enumerate(zip(slots, rises, strict=True))
        for kj, tj in zip(slots[i + 1 :], rises[i + 1 :], strict=True)
        if kj != ki  # two edges in one slot: an emulator stall delayed one; it says nothing of the rate
    )
    slope_ns = slopes[len(slopes) // 2]
    measured_rate = 1e9 / slope_ns
    widths.sort()
    median_width = widths[len(widths) // 2] / 1e9  # robust to the odd emulator stall mid-pulse
    print(
        f"gpio-sim: {len(rises)} pulses over {slots[-1] + 1} slots, rate {measured_rate:.4f} Hz, "
        f"median width {median_width * 1e3:.2f} ms "
        f"(range {widths[0] / 1e6:.2f}..{widths[-1] / 1e6:.2f}), {stats}"
    )
    assert abs(measured_rate - rate_hz) < 0.01 * rate_hz, stats
    assert abs(median_width - width_s) < 0.1 * width_s, stats
    assert len(rises) + stats["missed"] >= slots[-1] + 1  # every slot was pulsed or counted as missed
