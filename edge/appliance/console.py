"""A live table of the tracks for a person watching the daemon in a terminal (`run --watch`).

The processing thread hands each step's fixes over (`update`, cheap: one reference swap); the
daemon's main loop redraws once per tick (`draw`), in place on a terminal (cursor home, clear),
or as a plain block every few seconds when the output is a pipe or a log file.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import TextIO

from edge.appliance.health import HealthSnapshot
from edge.encode.nmea import fix_name
from edge.fix import ShipFix

PLAIN_EVERY_S = 5.0  # a table every this often when the stream is not a terminal
HEADER = f"{'no':>3} {'id':>4} {'st':>2} {'range m':>8} {'brg deg':>7} {'SOG kn':>6} {'COG deg':>7} " \
         f"{'sigma m':>7} {'age s':>6}"


def _cell(value: float | None, width: int, decimals: int) -> str:
    return f"{'-':>{width}}" if value is None or not math.isfinite(value) else f"{value:>{width}.{decimals}f}"


def rows(fixes: Sequence[ShipFix], numbers: dict[int, int]) -> list[str]:
    """One line per fix, nearest first: NMEA target number (or -), track id, status, ..."""
    out = []
    for f in sorted(fixes, key=lambda f: f.range_m):
        number = f"{numbers[f.track_id]:>3}" if f.track_id in numbers else f"{'-':>3}"
        out.append(f"{number} {f.track_id:>4} {f.status.value:>2} {_cell(f.range_m, 8, 0)} "
                   f"{_cell(f.bearing_deg, 7, 1)} {_cell(f.sog_kn, 6, 1)} {_cell(f.cog_deg, 7, 1)} "
                   f"{_cell(f.sigma_m, 7, 1)} {_cell(f.age_s, 6, 1)}"
                   + (f"  {fix_name(f)}" if f.ais_mmsi is not None or f.dark else ""))  # AIS name / DARK
    return out


class LiveTable:
    def __init__(self, stream: TextIO, numbers: Callable[[Sequence[ShipFix]], dict[int, int]],
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.stream, self.numbers, self.clock = stream, numbers, clock
        self.fixes: Sequence[ShipFix] = ()
        self.utc_ns = 0
        self.tty = bool(getattr(stream, "isatty", lambda: False)())
        self._last_plain_s = -math.inf

    def update(self, utc_ns: int, fixes: Sequence[ShipFix]) -> None:
        self.utc_ns, self.fixes = utc_ns, fixes

    def draw(self, snapshot: HealthSnapshot) -> None:
        now_s = self.clock()
        if not self.tty and now_s - self._last_plain_s < PLAIN_EVERY_S:
            return
        self._last_plain_s = now_s
        fixes = self.fixes
        rate = f"{snapshot.frame_rate_hz:.1f} fps" if snapshot.frame_rate_hz is not None else "no frames yet"
        stamp = time.strftime("%H:%M:%S", time.gmtime(self.utc_ns / 1e9)) if self.utc_ns else "--:--:--"
        head = f"{snapshot.state.value}  {rate}  {len(fixes)} tracks  UTC {stamp}"
        if snapshot.reason:
            head += f"  ({snapshot.reason})"
        text = "\n".join([head, HEADER, *rows(fixes, self.numbers(fixes))]) + "\n"
        try:
            self.stream.write(("\x1b[H\x1b[J" + text) if self.tty else text + "\n")
            self.stream.flush()
        except (OSError, ValueError):  # a closed terminal must not stop the daemon
            pass
