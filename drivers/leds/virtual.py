"""In-memory LED panel for tests and the demo: records every brightness change with its time.

`history[role]` is the list of (now_ns, brightness) writes in order, exactly
what SysfsLedPanel would have written (brightness 0 or `max_brightness`);
`levels()` is the current state, `describe()` a one-line summary for logs.
`missing` roles behave like absent sysfs LEDs (nothing is recorded for them).
"""

from __future__ import annotations

from collections.abc import Iterable

from drivers.leds.base import FAULT_LED, OK_LED, LedPanel


class VirtualLedPanel(LedPanel):
    """Keeps the brightness history of each LED."""

    def __init__(
        self, roles: Iterable[str] = (OK_LED, FAULT_LED), *, max_brightness: int = 1,
        missing: Iterable[str] = (),
    ) -> None:
        super().__init__(roles)
        self.max_brightness = max_brightness
        self.missing = set(missing)
        self.history: dict[str, list[tuple[int, int]]] = {role: [] for role in self.roles}
        self.released = False

    def levels(self) -> dict[str, int]:
        """The last brightness written per LED (0 before any write)."""
        return {role: (h[-1][1] if h else 0) for role, h in self.history.items()}

    def describe(self) -> str:
        return ", ".join(f"{role}={self._patterns[role]}" for role in self.roles)

    def _apply(self, role: str, on: bool, now_ns: int) -> bool:
        if role in self.missing:
            return False
        self.history[role].append((now_ns, self.max_brightness if on else 0))
        return True

    def _release(self) -> None:
        self.released = True
