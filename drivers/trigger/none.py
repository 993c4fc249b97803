"""No trigger: free-running cameras at their configured frame rate, paired by nearest timestamp only.

Two free-running cameras are not phase-locked (their clocks differ slightly),
so their relative phase drifts through the whole frame period: the pairer
pairs the nearest frames within half a period and must not track an offset
(`synchronised = False`). The worst-case skew is half a frame period, which
matters for moving ships: use a real trigger for ranging at speed.
"""

from __future__ import annotations

from drivers.trigger.base import Trigger


class FreeRunning(Trigger):
    kind = "none"
    synchronised = False

    def describe(self) -> str:
        return f"none (free-running at {self.rate_hz:g} fps, paired by timestamp only)"
