"""LED panel base: one pattern per LED (off, on, blink, heartbeat), toggled by the caller's own loop.

The appliance shows its health on two or three enclosure LEDs: green "ok",
red "fault" and optionally a dedicated amber one. The patterns are not handed
to kernel LED triggers: the daemon's main loop calls `LedPanel.tick(now_ns)`,
and the panel computes every LED's level from the clock and writes only the
changes. A hung daemon therefore shows a *steady* LED where a live one blinks
or beats; a kernel trigger would keep blinking over a dead process.

`health_patterns(state, amber=...)` is the pure mapping from the health state
(OK / DEGRADED / STALLED, the values of `edge.appliance.health.HealthState`) to the
patterns: OK = green heartbeat, DEGRADED = amber blinking (the amber LED, or
green and red blinking together when there is none), STALLED = steady red.

Levels are computed from the absolute monotonic clock (phase = now mod
period), so LEDs with the same pattern blink in phase and a test can predict
every edge. Subclasses implement `_apply()` (write one LED) and `_release()`.
"""

from __future__ import annotations

import abc
import enum
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

OK_LED = "ok"  # green
FAULT_LED = "fault"  # red
AMBER_LED = "amber"  # optional dedicated amber LED
ROLES = (OK_LED, FAULT_LED, AMBER_LED)

HEARTBEAT_PERIOD_S = 1.0
BLINK_PERIOD_S = 0.5
IDLE_TICK_NS = 1_000_000_000  # tick() deadline when every LED is steady


class Kind(enum.Enum):
    OFF = "off"
    ON = "on"
    BLINK = "blink"  # on for the first half of the period
    HEARTBEAT = "heartbeat"  # two short pulses, then dark for the rest of the period


# toggle points in permille of the period: the LED is on between edges 0-1, 2-3, ...
_EDGES_PERMILLE = {Kind.BLINK: (0, 500), Kind.HEARTBEAT: (0, 100, 250, 350)}


@dataclass(frozen=True, slots=True)
class Pattern:
    """What one LED shows; build with OFF, ON, blink() or heartbeat()."""

    kind: Kind
    period_ns: int = 0

    def __post_init__(self) -> None:
        periodic = self.kind in _EDGES_PERMILLE
        if periodic and self.period_ns < 2_000_000:
            raise ValueError(f"{self.kind.value} needs a period of at least 2 ms, got {self.period_ns} ns")
        if not periodic and self.period_ns:
            raise ValueError(f"{self.kind.value} takes no period")

    def _edges_ns(self) -> tuple[int, ...]:
        return tuple(e * self.period_ns // 1000 for e in _EDGES_PERMILLE[self.kind])

    def level(self, now_ns: int) -> bool:
        """Whether the LED is lit at `now_ns` (CLOCK_MONOTONIC)."""
        if self.kind is Kind.OFF or self.kind is Kind.ON:
            return self.kind is Kind.ON
        phase = now_ns % self.period_ns
        return sum(edge <= phase for edge in self._edges_ns()) % 2 == 1

    def next_change_ns(self, now_ns: int) -> int | None:
        """The first instant after `now_ns` at which the level changes; None if it never does."""
        if self.kind is Kind.OFF or self.kind is Kind.ON:
            return None
        phase = now_ns % self.period_ns
        later = [edge for edge in self._edges_ns() if edge > phase]
        return now_ns - phase + (later[0] if later else self.period_ns)

    def __str__(self) -> str:
        return self.kind.value if not self.period_ns else f"{self.kind.value}({self.period_ns / 1e9:g} s)"


OFF = Pattern(Kind.OFF)
ON = Pattern(Kind.ON)


def blink(period_s: float = BLINK_PERIOD_S) -> Pattern:
    """On for half of `period_s`, off for the other half."""
    return Pattern(Kind.BLINK, round(period_s * 1e9))


def heartbeat(period_s: float = HEARTBEAT_PERIOD_S) -> Pattern:
    """Two 10 % pulses at the start of each `period_s` (like the kernel's heartbeat trigger)."""
    return Pattern(Kind.HEARTBEAT, round(period_s * 1e9))


def health_patterns(
    state: str | enum.Enum,
    *,
    amber: bool,
    heartbeat_period_s: float = HEARTBEAT_PERIOD_S,
    blink_period_s: float = BLINK_PERIOD_S,
) -> dict[str, Pattern]:
    """LED patterns for a health state ("OK", "DEGRADED", "STALLED", or a HealthState).

    `amber`: the panel has a dedicated amber LED (else DEGRADED blinks green and
    red together, which reads as amber on a bicolour LED). The amber role is in
    the result only when `amber` is true.
    """
    name = state.value if isinstance(state, enum.Enum) else state
    if name == "OK":
        result = {OK_LED: heartbeat(heartbeat_period_s), FAULT_LED: OFF, AMBER_LED: OFF}
    elif name == "DEGRADED" and amber:
        result = {OK_LED: OFF, FAULT_LED: OFF, AMBER_LED: blink(blink_period_s)}
    elif name == "DEGRADED":
        result = {OK_LED: blink(blink_period_s), FAULT_LED: blink(blink_period_s)}
    elif name == "STALLED":
        result = {OK_LED: OFF, FAULT_LED: ON, AMBER_LED: OFF}
    else:
        raise ValueError(f"unknown health state {name!r}; expected OK, DEGRADED or STALLED")
    if not amber:
        result.pop(AMBER_LED, None)
    return result


class LedPanel(abc.ABC):
    """A few named LEDs ("ok", "fault", optional "amber"), each showing a Pattern.

    Not thread-safe: one thread (the daemon's main loop) calls show(), tick()
    and close(). show() only records; tick() writes the levels due now.
    """

    def __init__(self, roles: Iterable[str]) -> None:
        self.roles = tuple(roles)
        unknown = set(self.roles) - set(ROLES)
        if unknown or len(set(self.roles)) != len(self.roles) or not self.roles:
            raise ValueError(f"LED roles must be distinct and among {ROLES}, got {self.roles}")
        self._patterns = dict.fromkeys(self.roles, OFF)
        self._applied: dict[str, bool | None] = dict.fromkeys(self.roles)
        self._closed = False

    @property
    def has_amber(self) -> bool:
        """Whether DEGRADED has a dedicated amber LED (pass it to health_patterns)."""
        return AMBER_LED in self.roles

    @property
    def patterns(self) -> dict[str, Pattern]:
        return dict(self._patterns)

    def show(self, patterns: Mapping[str, Pattern]) -> None:
        """Set the patterns of some LEDs (the others keep theirs); takes effect at the next tick()."""
        unknown = set(patterns) - set(self.roles)
        if unknown:
            raise KeyError(f"no LED for {sorted(unknown)} on this panel (roles {self.roles})")
        self._patterns.update(patterns)

    def show_health(self, state: str | enum.Enum) -> None:
        """show(health_patterns(state)) with this panel's amber setting."""
        self.show(health_patterns(state, amber=self.has_amber))

    def tick(self, now_ns: int | None = None) -> int:
        """Write the levels due at `now_ns`; returns when tick() should run next (monotonic ns).

        The caller may tick more often (it costs a comparison per LED) but
        not much later than asked, or pulses are lost.
        """
        now_ns = time.monotonic_ns() if now_ns is None else now_ns
        if self._closed:
            return now_ns + IDLE_TICK_NS
        deadline = now_ns + IDLE_TICK_NS
        for role in self.roles:
            pattern = self._patterns[role]
            on = pattern.level(now_ns)
            if self._applied[role] is not on:
                self._applied[role] = on if self._apply(role, on, now_ns) else None
            if self._applied[role] is None:  # not written (LED missing): try again soon
                deadline = min(deadline, now_ns + self._retry_ns())
            change = pattern.next_change_ns(now_ns)
            if change is not None:
                deadline = min(deadline, change)
        return deadline

    def close(self, final: Mapping[str, Pattern] | None = None, now_ns: int | None = None) -> None:
        """Show `final` (default: steady red, "not running") once, then let the LEDs go."""
        if self._closed:
            return
        self._patterns = dict.fromkeys(self.roles, OFF)
        self.show({FAULT_LED: ON} if final is None and FAULT_LED in self.roles else (final or {}))
        self.tick(now_ns)
        self._closed = True
        self._release()

    def _retry_ns(self) -> int:
        return IDLE_TICK_NS

    @abc.abstractmethod
    def _apply(self, role: str, on: bool, now_ns: int) -> bool:
        """Light or darken one LED; False if it could not be written (retried at a later tick)."""

    def _release(self) -> None:  # noqa: B027 (optional hook)
        """Free what the implementation holds (after close() showed its final patterns)."""
