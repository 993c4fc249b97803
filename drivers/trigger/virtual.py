"""A software pulse train for tests and the demo: calls back at each pulse, e.g. to expose fake cameras.

`VirtualTrigger(rate_hz, on_pulse=[cb, ...])` runs a `PulseLoop` thread once
started; each callback gets the pulse's CLOCK_MONOTONIC time in ns (the
deadline, so both fake cameras are stamped with the same instant, as a
hardware trigger would make them). `fire(t_ns)` pulses by hand.
"""

from __future__ import annotations

from collections.abc import Callable

from drivers.trigger.base import CameraSetup, PulseLoop, Trigger


class VirtualTrigger(Trigger):
    kind = "virtual"

    def __init__(
        self,
        rate_hz: float,
        on_pulse: list[Callable[[int], object]] | None = None,
        *,
        camera_setup: CameraSetup | None = None,
    ) -> None:
        super().__init__(rate_hz, camera_setup=camera_setup)
        self.on_pulse = list(on_pulse or [])
        self._loop: PulseLoop | None = None
        self.fired = 0

    def fire(self, t_ns: int) -> None:
        self.fired += 1
        for callback in self.on_pulse:
            callback(t_ns)

    def start(self) -> None:
        if self._loop is None:
            self._loop = PulseLoop(self.period_ns, 0, self.fire, name="virtual-trigger")
            self._loop.start()
        super().start()

    def stop(self) -> None:
        if self._loop is not None:
            self._loop.stop()
            self._loop = None
        super().stop()
