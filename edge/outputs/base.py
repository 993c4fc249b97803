"""The one contract every output implements, so the fan-out treats them all alike.

An output is started once, handed each processing step's complete list of live fixes
(`publish`), asked for its health after every step and closed at shutdown. `publish` returns
what it sent this step, one item per `unit` (an NMEA group, a UDP datagram, a CSV row, a Modbus
register image), so the fan-out can count sends per unit without knowing the output's kind.
It must never block the processing thread: queues, writer threads and retries live inside.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol, runtime_checkable

from edge.fix import ShipFix


@runtime_checkable
class Output(Protocol):
    """start / publish / health / close, plus the health stage it reports under and its unit."""

    stage: str  # the health stage it beats: "nmea", "modbus" or "tracks_csv"
    unit: str  # what one item of publish()'s result is, as a counter name: "serial_groups", ...

    def start(self) -> None:
        """Open what it needs; a failure here is a health fault to retry, never an exception."""

    def publish(self, fixes: Sequence[ShipFix], utc_ns: int) -> Sequence[object]:
        """Hand over this step's live fixes (measured at UTC `utc_ns`); returns what was sent."""
        ...

    def health(self) -> tuple[str | None, dict[str, int]]:
        """(fault text or None, cumulative counters) for `HealthMonitor.beat`."""
        ...

    def close(self) -> None:
        """Flush what is queued (within its timeout) and release the transport. Safe to call twice."""
