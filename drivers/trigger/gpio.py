"""A trigger pulse generator on a GPIO line, through the character device's v2 uAPI (linux/gpio.h).

`GpioTrigger(chip="/dev/gpiochip0", line=17, rate_hz=10, pulse_width_s=0.002)`
requests the line as an output (GPIO_V2_GET_LINE_IOCTL on the chip: one line,
OUTPUT, initial value inactive, ACTIVE_LOW if asked) and, from its own thread,
drives it active at start + k / rate_hz and inactive pulse_width_s later with
GPIO_V2_LINE_SET_VALUES_IOCTL on the line fd. Deadlines are absolute
(base.PulseLoop), so the rate holds over hours regardless of wake-up latency;
a pulse that cannot be issued within half a period of its slot is skipped and
counted (`stats["missed"]`). No libgpiod: the structs are a few lines of
ctypes, and all calls go through the `Kernel` chokepoint (tests fake the
chip). Sysfs GPIO (/sys/class/gpio) is deprecated and not supported.

`realtime_priority` (1-99) runs the pulse thread SCHED_FIFO (the unit grants
CAP_SYS_NICE or LimitRTPRIO); without it the edges jitter with the CPU load.
The line is released (driven inactive, fd closed) on stop(). Optionally a
`camera_setup` (controls.TriggerControls) arms the cameras for the pulses.
"""

from __future__ import annotations

import ctypes
import time
from collections.abc import Callable

from drivers.kernel import LINUX, Kernel, iowr
from drivers.trigger.base import CameraSetup, PulseLoop, Trigger

GPIO_V2_LINES_MAX = 64
GPIO_V2_LINE_NUM_ATTRS_MAX = 10
GPIO_MAX_NAME_SIZE = 32
GPIO_V2_LINE_FLAG_ACTIVE_LOW = 1 << 1
GPIO_V2_LINE_FLAG_INPUT = 1 << 2
GPIO_V2_LINE_FLAG_OUTPUT = 1 << 3
GPIO_V2_LINE_FLAG_EDGE_RISING = 1 << 4
GPIO_V2_LINE_FLAG_EDGE_FALLING = 1 << 5
GPIO_V2_LINE_ATTR_ID_OUTPUT_VALUES = 2


class gpio_v2_line_attribute(ctypes.Structure):
    _fields_ = [("id", ctypes.c_uint32), ("padding", ctypes.c_uint32), ("values", ctypes.c_uint64)]


class gpio_v2_line_config_attribute(ctypes.Structure):
    _fields_ = [("attr", gpio_v2_line_attribute), ("mask", ctypes.c_uint64)]


class gpio_v2_line_config(ctypes.Structure):
    _fields_ = [
        ("flags", ctypes.c_uint64),
        ("num_attrs", ctypes.c_uint32),
        ("padding", ctypes.c_uint32 * 5),
        ("attrs", gpio_v2_line_config_attribute * GPIO_V2_LINE_NUM_ATTRS_MAX),
    ]


class gpio_v2_line_request(ctypes.Structure):
    _fields_ = [
        ("offsets", ctypes.c_uint32 * GPIO_V2_LINES_MAX),
        ("consumer", ctypes.c_char * GPIO_MAX_NAME_SIZE),
        ("config", gpio_v2_line_config),
        ("num_lines", ctypes.c_uint32),
        ("event_buffer_size", ctypes.c_uint32),
        ("padding", ctypes.c_uint32 * 5),
        ("fd", ctypes.c_int32),
    ]


class gpio_v2_line_values(ctypes.Structure):
    _fields_ = [("bits", ctypes.c_uint64), ("mask", ctypes.c_uint64)]


class gpio_v2_line_event(ctypes.Structure):
    _fields_ = [
        ("timestamp_ns", ctypes.c_uint64),
        ("id", ctypes.c_uint32),
        ("offset", ctypes.c_uint32),
        ("seqno", ctypes.c_uint32),
        ("line_seqno", ctypes.c_uint32),
        ("padding", ctypes.c_uint32 * 6),
    ]


GPIO_V2_GET_LINE_IOCTL = iowr(0xB4, 0x07, gpio_v2_line_request)
GPIO_V2_LINE_GET_VALUES_IOCTL = iowr(0xB4, 0x0E, gpio_v2_line_values)
GPIO_V2_LINE_SET_VALUES_IOCTL = iowr(0xB4, 0x0F, gpio_v2_line_values)


class GpioError(Exception):
    """The chip or line cannot be used; names the chip and line."""


def request_line(
    kernel: Kernel, chip: str, line: int, flags: int, consumer: str, value: int | None = None
) -> int:
    """Request one line of `chip` with `flags` (and an initial output value); returns the line fd."""
    try:
        chip_fd = kernel.open(chip)
    except OSError as exc:
        raise GpioError(f"{chip}: cannot open ({exc.strerror})") from None
    try:
        req = gpio_v2_line_request(num_lines=1, consumer=consumer.encode()[: GPIO_MAX_NAME_SIZE - 1])
        req.offsets[0] = line
        req.config.flags = flags
        if value is not None:
            req.config.num_attrs = 1
            attr = req.config.attrs[0]
            attr.attr.id, attr.attr.values, attr.mask = GPIO_V2_LINE_ATTR_ID_OUTPUT_VALUES, value & 1, 1
        kernel.ioctl(chip_fd, GPIO_V2_GET_LINE_IOCTL, req)
        return req.fd
    except OSError as exc:
        raise GpioError(f"{chip} line {line}: cannot request it ({exc.strerror or exc})") from None
    finally:
        kernel.close(chip_fd)


class GpioTrigger(Trigger):
    """Generates the trigger pulses on one GPIO line."""

    kind = "gpio"

    def __init__(
        self,
        chip: str,
        line: int,
        rate_hz: float,
        *,
        pulse_width_s: float = 0.001,
        active_low: bool = False,
        realtime_priority: int | None = None,
        consumer: str = "mast-stereo trigger",
        camera_setup: CameraSetup | None = None,
        kernel: Kernel = LINUX,
        clock: Callable[[], int] = time.monotonic_ns,
        wait: Callable[[float], bool] | None = None,
    ) -> None:
        super().__init__(rate_hz, camera_setup=camera_setup)
        if not 0 < pulse_width_s < 1.0 / rate_hz:
            raise ValueError(f"pulse_width_s {pulse_width_s} must be positive and below the period")
        self.chip, self.line, self.pulse_width_s, self.active_low = chip, int(line), pulse_width_s, active_low
        self.consumer, self.kernel = consumer, kernel
        self._fd: int | None = None
        self.loop = PulseLoop(
            self.period_ns,
            round(pulse_width_s * 1e9),
            self._rise,
            self._fall,
            name=f"gpio-trigger {chip}:{line}",
            clock=clock,
            wait=wait,
        )

    def open(self) -> None:
        """Request the line as an output, inactive."""
        if self._fd is None:
            flags = GPIO_V2_LINE_FLAG_OUTPUT | (GPIO_V2_LINE_FLAG_ACTIVE_LOW if self.active_low else 0)
            self._fd = request_line(self.kernel, self.chip, self.line, flags, self.consumer, value=0)

    def _set(self, active: int) -> None:
        values = gpio_v2_line_values(bits=active, mask=1)
        assert self._fd is not None  # start() requested the line
        self.kernel.ioctl(self._fd, GPIO_V2_LINE_SET_VALUES_IOCTL, values)

    def _rise(self, t_ns: int) -> None:
        self._set(1)

    def _fall(self) -> None:
        self._set(0)

    def start(self) -> None:
        self.open()
        self.loop.start()
        super().start()

    def stop(self) -> None:
        self.loop.stop()
        if self._fd is not None:
            try:
                self._set(0)
            finally:
                fd, self._fd = self._fd, None
                self.kernel.close(fd)
        super().stop()

    def describe(self) -> str:
        return (
            f"gpio {self.chip} line {self.line}: {self.rate_hz:g} Hz, {self.pulse_width_s * 1e3:g} ms pulses"
            f"{' (active low)' if self.active_low else ''}"
            + (f", cameras: {self.camera_setup.describe()}" if self.camera_setup else "")
        )

    @property
    def stats(self) -> dict:
        return super().stats | self.loop.stats
