"""drivers/trigger/gpio.py against a fake GPIO chardev and a fake clock: the uAPI calls, the pulse timing."""

from __future__ import annotations

import ctypes
import errno
import time

import pytest

from drivers.kernel import Kernel
from drivers.trigger import gpio
from drivers.trigger.base import PulseLoop
from drivers.trigger.virtual import VirtualTrigger

MS = 1_000_000


class FakeClock:
    """Monotonic ns; every wait oversleeps by `late_ns` (a busy machine), plus extra on chosen waits."""

    def __init__(self, late_ns: int = 0, extra: dict[int, int] | None = None) -> None:
        self.now, self.late_ns, self.extra, self.waits = 1_000 * MS, late_ns, extra or {}, 0

    def __call__(self) -> int:
        return self.now

    def wait(self, seconds: float) -> bool:
        self.waits += 1
        self.now += round(seconds * 1e9) + self.late_ns + self.extra.get(self.waits, 0)
        return False


class FakeChip(Kernel):
    def __init__(self, clock: FakeClock) -> None:
        self.clock, self.events, self.request, self.open_fds = clock, [], None, set()

    def open(self, path: str, flags: int = 0) -> int:
        if path != "/dev/gpiochip3":
            raise OSError(errno.ENOENT, "No such file or directory")
        self.open_fds.add(3)
        return 3

    def close(self, fd: int) -> None:
        self.open_fds.discard(fd)

    def ioctl(self, fd: int, request: int, arg) -> None:
        if request == gpio.GPIO_V2_GET_LINE_IOCTL:
            if arg.offsets[0] >= 8:
                raise OSError(errno.EINVAL, "Invalid argument")
            self.request = gpio.gpio_v2_line_request.from_buffer_copy(arg)
            arg.fd = 9
            self.open_fds.add(9)
        elif request == gpio.GPIO_V2_LINE_SET_VALUES_IOCTL:
            assert fd == 9 and arg.mask == 1
            self.events.append((self.clock(), arg.bits))
        else:
            raise OSError(errno.ENOTTY, "Inappropriate ioctl for device")


def make(clock: FakeClock, **kw) -> tuple[gpio.GpioTrigger, FakeChip]:
    chip = FakeChip(clock)
    args = {"rate_hz": 10.0, "pulse_width_s": 0.002, "kernel": chip, "clock": clock, "wait": clock.wait} | kw
    return gpio.GpioTrigger("/dev/gpiochip3", 5, **args), chip


def test_struct_sizes_match_the_uapi() -> None:
    assert ctypes.sizeof(gpio.gpio_v2_line_request) == 592
    assert gpio.GPIO_V2_GET_LINE_IOCTL == 0xC250B407 and gpio.GPIO_V2_LINE_SET_VALUES_IOCTL == 0xC010B40F


def test_line_request_and_release() -> None:
    clock = FakeClock()
    trigger, chip = make(clock, active_low=True)
    trigger.open()
    req = chip.request
    assert req.num_lines == 1 and req.offsets[0] == 5 and req.consumer == b"mast-stereo trigger"
    assert req.config.flags == gpio.GPIO_V2_LINE_FLAG_OUTPUT | gpio.GPIO_V2_LINE_FLAG_ACTIVE_LOW
    assert req.config.num_attrs == 1 and req.config.attrs[0].attr.values == 0  # starts inactive
    assert chip.open_fds == {9}  # the chip fd is closed, the line fd kept
    trigger.stop()
    assert chip.events[-1][1] == 0 and chip.open_fds == set()
    with pytest.raises(gpio.GpioError, match="/dev/gpiochip3 line 8: cannot request"):
        make(clock)[0].__class__("/dev/gpiochip3", 8, 10.0, kernel=chip).open()
    with pytest.raises(gpio.GpioError, match="/dev/gpiochip9: cannot open"):
        gpio.GpioTrigger("/dev/gpiochip9", 1, 10.0, kernel=chip).open()


def test_absolute_deadlines_hold_the_rate_and_width_despite_late_wakeups() -> None:
    clock = FakeClock(late_ns=300_000)  # every wake-up 0.3 ms late
    trigger, chip = make(clock)
    trigger.open()
    trigger.loop.run(max_pulses=50)
    rises = [t for t, v in chip.events if v == 1]
    falls = [t for t, v in chip.events if v == 0]
    errors = [r - (trigger.loop.t0_ns + k * 100 * MS) for k, r in enumerate(rises)]
    # the first edge is late by the latency; from then on the loop wakes that much early
    assert len(rises) == 50 and errors[0] == 300_000 and set(errors[1:]) == {0}
    assert all(f - r == 2 * MS for r, f in zip(rises, falls, strict=True))
    assert trigger.stats["pulses"] == 50 and trigger.stats["missed"] == 0
    assert trigger.stats["wakeup_lead_us"] == 300.0


def test_a_long_stall_skips_pulses_instead_of_bunching() -> None:
    clock = FakeClock(extra={5: 260 * MS})  # the 5th wait oversleeps 2.6 periods
    trigger, chip = make(clock)
    trigger.open()
    trigger.loop.run(max_pulses=10)
    rises = [t for t, v in chip.events if v == 1]
    slots = [(r - trigger.loop.t0_ns) / (100 * MS) for r in rises]
    assert trigger.loop.missed == 3 and len(rises) == 7
    assert (
        all(abs(s - round(s)) < 0.01 for s in slots)
        and min(b - a for a, b in zip(rises, rises[1:], strict=False)) >= 99 * MS
    )


def test_pulse_loop_and_virtual_trigger_in_real_time() -> None:
    with pytest.raises(ValueError):
        PulseLoop(10, 10, lambda t: None)
    seen: list[int] = []
    trigger = VirtualTrigger(200.0, [seen.append])
    trigger.start()
    time.sleep(0.2)
    trigger.stop()
    steps = [b - a for a, b in zip(seen, seen[1:], strict=False)]
    assert len(seen) >= 10 and all(s % (5 * MS) == 0 for s in steps)  # on the slots exactly
