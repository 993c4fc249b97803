"""NMEA sentences to a text stream (the demo's stdout), with the serial output's scheduling rules.

Same `NmeaScheduler` as a serial port (target numbers, L three times,
refresh once per `min_refresh_s`) but no byte budget: a terminal is not a
4800-baud line. A stream that fails (closed pipe) is counted and reported as
a fault; it never raises into the processing thread.

`clock=None` clocks the schedule by the pairs themselves (the `utc_ns` each publish is given), so
the same pairs give the same sentences whatever the wall clock does: `replay` writes its NMEA this
way, with the sentences' own CR LF endings (`newline="\r\n"`). `stream=None` only counts.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from typing import TextIO

from edge.fix import ShipFix
from edge.outputs.schedule import DEFAULT_SCHEDULE, NmeaSchedule, NmeaScheduler


class NmeaStreamOutput:
    """Writes each scheduled group to `stream` and flushes; an `Output` like the others."""

    stage = "nmea"
    unit = "nmea_stream_groups"

    def __init__(self, stream: TextIO | None, schedule: NmeaSchedule = DEFAULT_SCHEDULE,
                 clock: Callable[[], float] | None = time.monotonic, newline: str = "\n") -> None:
        self.stream, self.newline = stream, newline
        self._pair_s = 0.0  # clock=None: the last published pair's time
        self.scheduler = NmeaScheduler(schedule, None, clock if clock is not None else self._pair_clock)
        self._pair_clocked = clock is None
        self.lines = 0
        self.errors = 0

    def start(self) -> None:
        """Nothing to open: the stream is the caller's."""

    def _pair_clock(self) -> float:
        return self._pair_s

    def publish(self, fixes: Iterable[ShipFix], utc_ns: int = 0) -> list[tuple[str, ...]]:
        if self._pair_clocked:
            self._pair_s = utc_ns / 1e9
        return self._write(self.scheduler.step(fixes))

    def publish_alerts(self) -> list[tuple[str, ...]]:
        """Only the alert sentences due now (the fan-out's call while no pair comes)."""
        return self._write(self.scheduler.step_alerts())

    def _write(self, groups: list[tuple[str, ...]]) -> list[tuple[str, ...]]:
        if not groups:
            return groups
        if self.stream is None:
            self.lines += sum(len(group) for group in groups)
            return groups
        try:
            for group in groups:
                self.stream.write("".join(line.rstrip("\r\n") + self.newline for line in group))
                self.lines += len(group)
            self.stream.flush()
        except (OSError, ValueError):  # closed or broken stream
            self.errors += 1
        return groups

    def health(self) -> tuple[str | None, dict[str, int]]:
        return ("NMEA stream failing" if self.errors else None), {"stream_lines": self.lines}

    def close(self) -> None:
        """The stream is the caller's to close."""
