"""The daemon's side of `edge.state`: restore the pipeline's and NMEA outputs' state, save changes.

`Persistence.open(config)` finds the state directory (none configured: returns None and nothing
is kept). `restore` is called before the first pair (and after a reload that rebuilt the
pipeline or outputs, from the last state in memory); `after_step` after each published step,
offering a new state to the writer thread only when an allocator's `version` changed or the
tracker's next id reached the reserved bound; `close` saves the last state at shutdown.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator

from edge.encode.targets import TargetNumbers
from edge.outputs.fanout import Outputs
from edge.outputs.nmea_serial import NmeaSerialOutput
from edge.outputs.nmea_udp import NmeaUdpOutput
from edge.pipeline import Pipeline
from edge.state import ID_RESERVE, NumbersState, State, StateKeeper, state_dir

log = logging.getLogger(__name__)


def allocators(outputs: Outputs) -> Iterator[tuple[str, TargetNumbers]]:
    """(key, allocator) of every NMEA output: the serial port's URL or the UDP group and port."""
    for out in outputs.outputs:
        if isinstance(out, NmeaSerialOutput):
            yield f"serial:{out.port.name}", out.scheduler.numbers
        elif isinstance(out, NmeaUdpOutput):
            yield f"udp:{out.source}", out.scheduler.numbers


class Persistence:
    """Restores and saves the state of one running appliance; see the module docstring."""

    def __init__(self, keeper: StateKeeper) -> None:
        self.keeper = keeper
        self.state: State | None = None  # the last state offered (what a reload restores)
        self._versions: dict[str, int] = {}
        self._reserved_id = 0
        self.hold_until_s: float | None = None  # monotonic: every number held (state was lost)

    @classmethod
    def open(cls, configured_dir: str | None) -> Persistence | None:
        directory = state_dir(configured_dir)
        return None if directory is None else cls(StateKeeper(directory))

    def restore(self, pipeline: Pipeline, outputs: Outputs, *, from_memory: bool = False) -> None:
        """Apply the saved state (or, if it was lost, the conservative policy of `edge.state`)."""
        state = self.state if from_memory else self.keeper.load()
        now_s = time.monotonic()
        if state is None:
            pipeline.table.next_id = max(pipeline.table.next_id, int(time.time()))
            if self.keeper.corrupt:
                for _, numbers in allocators(outputs):
                    for n in range(1, numbers.max_number + 1):
                        numbers.hold(n, numbers.quarantine_s, now_s)
                quarantine_s = max((n.quarantine_s for _, n in allocators(outputs)), default=0.0)
                self.hold_until_s = now_s + quarantine_s
        else:
            pipeline.table.next_id = max(pipeline.table.next_id, state.next_track_id)
            for key, numbers in allocators(outputs):
                saved = state.numbers.get(key, NumbersState())
                for n in saved.in_use:
                    if 1 <= n <= numbers.max_number:
                        numbers.hold(n, numbers.quarantine_s, now_s)
                for n, left_s in saved.quarantine_s.items():
                    if 1 <= n <= numbers.max_number:
                        numbers.hold(n, left_s, now_s)
            if not from_memory:
                held = sum(len(v.in_use) + len(v.quarantine_s) for v in state.numbers.values())
                log.info("state restored from %s: next track id %d, %d numbers held", self.keeper.path,
                         state.next_track_id, held)
        self._versions = {}
        self._reserved_id = 0
        self.after_step(pipeline, outputs)  # the restored state is saved at once

    def after_step(self, pipeline: Pipeline, outputs: Outputs) -> None:
        versions = {key: numbers.version for key, numbers in allocators(outputs)}
        next_id = pipeline.table.next_id
        if versions == self._versions and next_id < self._reserved_id:
            return
        now_s = time.monotonic()
        if next_id >= self._reserved_id:
            self._reserved_id = next_id + ID_RESERVE
        self.state = State(self._reserved_id, {key: NumbersState.of(numbers, now_s)
                                               for key, numbers in allocators(outputs)})
        self._versions = {key: numbers.version for key, numbers in allocators(outputs)}  # after expiry
        self.keeper.offer(self.state)

    def status(self) -> str | None:
        """The STATUS= addition while every number is held after a lost state, else None."""
        if self.hold_until_s is None or time.monotonic() >= self.hold_until_s:
            return None
        left_s = self.hold_until_s - time.monotonic()
        return f"state lost: NMEA target numbers held {left_s:.0f} s more"

    def close(self, pipeline: Pipeline, outputs: Outputs) -> None:
        self._versions = {}
        self.after_step(pipeline, outputs)
        self.keeper.close()
