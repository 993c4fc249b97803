"""Modbus TCP/RTU output: each step's fixes and health as one register image, swapped whole.

The map is `edge.encode.registers`; the servers (`drivers.modbus`) only ever receive complete,
immutable images, so a reader never sees half an update. A server that cannot start (port
taken, serial device missing) is counted, logged once, reported as a fault and retried with
doubling back-off from `publish`; it never stops the appliance.

Accounting: every fix handed in is on a served image, or counted: `modbus_fixes_unslotted` (all
`max_tracks` slots held by other tracks; slots go to tracking before acquiring, nearest first)
or `modbus_fixes_unserved` (no server running). A slotted fix stays readable until the next step.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence

from drivers.modbus import ModbusServer
from edge.appliance.health import HealthSnapshot
from edge.encode.registers import AlertImage, Identity, SlotAssignment, build_snapshot
from edge.fix import ShipFix

log = logging.getLogger(__name__)

RETRY_MIN_S, RETRY_MAX_S = 1.0, 30.0
MODBUS_COUNTERS = ("requests", "exceptions", "writes", "garbage", "clients", "refused_clients",
                   "idle_closed", "unread_closed")  # ModbusStats fields shown as health counters


class _ServerSlot:
    """A Modbus server with start retries: started lazily, re-tried with doubling back-off."""

    def __init__(self, server: ModbusServer, clock: Callable[[], float]) -> None:
        self.server = server
        self.running = False
        self.failures = 0
        self.error: str | None = None
        self._clock = clock
        self._next_try_s = -float("inf")
        self._backoff_s = RETRY_MIN_S

    def ensure_started(self) -> None:
        now_s = self._clock()
        if self.running or now_s < self._next_try_s:
            return
        try:
            self.server.start()
        except OSError as exc:
            self.failures += 1
            if self.error is None:
                log.error("%s could not start: %s (retrying with back-off)", type(self.server).__name__, exc)
            self.error = f"cannot start: {exc}"
            self._next_try_s = now_s + self._backoff_s
            self._backoff_s = min(RETRY_MAX_S, 2 * self._backoff_s)
            return
        if self.error is not None:
            log.info("%s started after %d failed attempts", type(self.server).__name__, self.failures)
        self.running, self.error, self._backoff_s = True, None, RETRY_MIN_S


class ModbusOutput:
    """All configured Modbus servers behind one `Output`: the image is built once per step.

    `snapshot` gives the health to publish (taken after the other outputs have beaten, so the
    status word is this step's); `target_numbers` gives the NMEA number of each track id."""

    stage = "modbus"
    unit = "modbus_images"

    def __init__(self, servers: Sequence[ModbusServer], identity: Identity,
                 snapshot: Callable[[], HealthSnapshot],
                 target_numbers: Callable[[Sequence[ShipFix]], dict[int, int]],
                 clock: Callable[[], float], alerts: Callable[[], AlertImage | None] | None = None) -> None:
        self.identity = identity
        self._alerts = alerts  # issue 18: the alert header and block
        self._slots = [_ServerSlot(s, clock) for s in servers]
        self._snapshot, self._target_numbers = snapshot, target_numbers
        self._assignment = SlotAssignment.empty(identity.max_tracks)
        self.fixes_in = 0  # fixes handed to publish() ...
        self.fixes_unslotted = 0  # ... of which found no free slot (slot overflow: not on Modbus)
        self.fixes_unserved = 0  # ... or were slotted in an image no server was running to serve

    @property
    def servers(self) -> list[ModbusServer]:
        return [s.server for s in self._slots]

    def start(self) -> None:
        for slot in self._slots:
            slot.ensure_started()

    def publish(self, fixes: Sequence[ShipFix], utc_ns: int) -> list[tuple[int, ...]]:
        image = build_snapshot(fixes, self._snapshot(), self.identity, self._assignment,
                               utc_ns=utc_ns, target_numbers=self._target_numbers(fixes),
                               alerts=None if self._alerts is None else self._alerts())
        self._assignment = image.assignment
        self.fixes_in += len(fixes)
        self.fixes_unslotted += len(image.unslotted)
        served = False
        for slot in self._slots:
            slot.ensure_started()
            if slot.running:
                slot.server.update(image.registers)
                served = True
        if not served:
            self.fixes_unserved += len(fixes) - len(image.unslotted)
        return [image.registers] if served else []

    def health(self) -> tuple[str | None, dict[str, int]]:
        """Start faults, and the servers' counters: refused writes and hostile clients show here."""
        errors = [s.error for s in self._slots if s.error]
        counters = {"start_failures": sum(s.failures for s in self._slots), "modbus_fixes_in": self.fixes_in,
                    "modbus_fixes_unslotted": self.fixes_unslotted,
                    "modbus_fixes_unserved": self.fixes_unserved}
        for slot in self._slots:
            stats = slot.server.stats
            for name in MODBUS_COUNTERS:
                counters[f"modbus_{name}"] = counters.get(f"modbus_{name}", 0) + getattr(stats, name)
        return "; ".join(errors) or None, counters

    def close(self) -> None:
        for slot in self._slots:
            if slot.running:
                slot.server.stop()
                slot.running = False
