"""LED panel on Linux LED class devices: /sys/class/leds/NAME/{brightness,trigger,max_brightness}.

Each role ("ok", "fault", optional "amber") names one LED class device, e.g.
gpio-leds from the board's device tree ("mast:green:ok"). When an LED is
first found its kernel trigger is set to "none" (a default "heartbeat" or
"timer" trigger would keep blinking over a hung daemon) and its
max_brightness read; after that only brightness is written, 0 or
max_brightness, by the caller's tick() (see base.py).

A missing LED is never a failure: the appliance works without its lamps. It
is logged once as a warning and looked for again every `retry_s` (LEDs on a
USB or I2C expander may appear late); a write error (the LED vanished, no
permission) is logged once per outage the same way. `root` replaces
/sys/class/leds so tests run against a fake tree of plain files.

Permissions: sysfs files are root:root 0644. The service user writes them
because systemd/60-mast-stereo.rules gives the group mast-stereo write access
to brightness and trigger of the LEDs it names.
"""

from __future__ import annotations

import errno
import logging
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from drivers.leds.base import LedPanel

log = logging.getLogger(__name__)

SYSFS_LEDS = Path("/sys/class/leds")


@dataclass(slots=True)
class _Led:
    name: str
    max_brightness: int = 0  # 0 = not acquired (missing or failed)
    next_try_ns: int = 0
    warned: bool = False
    trigger_warned: bool = False
    writes: int = 0
    errors: int = 0


class SysfsLedPanel(LedPanel):
    """LEDs by LED class device name; missing or unwritable ones are skipped with one warning each."""

    def __init__(
        self, names: Mapping[str, str], *, root: str | Path = SYSFS_LEDS, retry_s: float = 5.0
    ) -> None:
        roles = [role for role, name in names.items() if name]
        super().__init__(roles)
        if retry_s <= 0:
            raise ValueError(f"retry_s must be > 0, got {retry_s}")
        self.root = Path(root)
        self.retry_ns = round(retry_s * 1e9)
        self._leds = {role: _Led(names[role]) for role in self.roles}

    def present(self) -> dict[str, bool]:
        """Per role: whether its LED was found and the last write to it succeeded."""
        return {role: led.max_brightness > 0 for role, led in self._leds.items()}

    def counters(self) -> dict[str, int]:
        return {"led_writes": sum(x.writes for x in self._leds.values()),
                "led_errors": sum(x.errors for x in self._leds.values())}

    def _retry_ns(self) -> int:
        return self.retry_ns

    def _apply(self, role: str, on: bool, now_ns: int) -> bool:
        led = self._leds[role]
        if not led.max_brightness and not self._acquire(led, now_ns):
            return False
        try:
            _write(self.root / led.name / "brightness", str(led.max_brightness if on else 0))
        except OSError as exc:
            self._lost(led, now_ns, f"cannot write its brightness: {_reason(exc)}")
            return False
        led.writes += 1
        return True

    def _acquire(self, led: _Led, now_ns: int) -> bool:
        """Find the LED, read max_brightness, detach its kernel trigger; False (logged once) if absent."""
        if now_ns < led.next_try_ns:
            return False
        path = self.root / led.name
        try:
            max_brightness = int((path / "max_brightness").read_text().strip() or 0)
        except (OSError, ValueError) as exc:
            what = "not found" if isinstance(exc, FileNotFoundError) else f"unreadable: {_reason(exc)}"
            self._lost(led, now_ns, f"{what} under {self.root}")
            return False
        try:
            _write(path / "trigger", "none")
        except OSError as exc:  # not fatal: writing brightness 0 detaches a trigger too
            if not led.trigger_warned:
                log.warning("LED %s: cannot set its trigger to none (%s)", led.name, _reason(exc))
            led.trigger_warned = True
        led.max_brightness = max(max_brightness, 1)
        if led.warned:
            log.info("LED %s is back", led.name)
        led.warned = False
        return True

    def _lost(self, led: _Led, now_ns: int, what: str) -> None:
        led.max_brightness = 0
        led.errors += 1
        led.next_try_ns = now_ns + self.retry_ns
        if not led.warned:
            log.warning("LED %s %s; its pattern is not shown (looking again every %g s)",
                        led.name, what, self.retry_ns / 1e9)
            led.warned = True


def _write(path: Path, text: str) -> None:
    """One write(2) of `text`, truncating (a no-op on sysfs; makes the fake tree of tests hold one value)."""
    fd = os.open(path, os.O_WRONLY | os.O_TRUNC)
    try:
        os.write(fd, text.encode())
    finally:
        os.close(fd)


def _reason(exc: OSError | ValueError) -> str:
    if not isinstance(exc, OSError):  # a max_brightness that is not a number
        return str(exc)
    if exc.errno in (errno.EACCES, errno.EPERM):
        return f"{exc.strerror} (is the udev rule for LEDs installed and the user in group mast-stereo?)"
    return exc.strerror or str(exc)
