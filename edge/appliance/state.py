"""What must survive a crash: NMEA and ASTERIX track numbers in use or in quarantine, and the next
track id.

A receiver (OpenCPN, a radar display) keys targets by their number; if the daemon is killed
(SIGKILL, power loss, the watchdog) and restarts with empty allocators, it would lend number 01
to a new ship seconds after the old 01 vanished, joining two ships' trails. So the daemon keeps
a small state file, `state.json` in the state directory (`health.state_dir`, else systemd's
$STATE_DIRECTORY from `StateDirectory=mast-stereo`, i.e. /var/lib/mast-stereo; neither: nothing
is kept), and on restart:

- every number that was live or lost at the last save is held in quarantine for `quarantine_s`
  from the restart (its last sentence went out at the latest when the daemon died); a number that
  was in quarantine keeps the rest of it (measured on CLOCK_MONOTONIC within one boot, on the
  wall clock across a reboot, never negative);
- track ids continue above a reserved bound: the file holds `next_track_id` plus
  `ID_RESERVE`, rewritten before the tracker passes it, so ids are never reused and are saved
  rarely, not at every birth.

A missing, unreadable, corrupt or foreign file is a fault, logged once with its MESSAGE_ID
(`state_lost`), never a crash, and track ids then start from the wall clock's seconds (above
any id an earlier run of this unit can plausibly have reached). A file that is there but
unusable means an earlier run lent numbers nobody knows now, so the daemon holds *every* number
for `quarantine_s`; a missing one is most likely the first start (nothing is held: a first
start must report at once; a file deleted by hand is the one case this does not cover).

Writes are atomic (a temporary file in the same directory, fsync, rename, fsync of the
directory) so a kill at any point leaves the old file or the new one, never a mix; they run on a
writer thread of their own (newest state wins), so the processing thread never waits for a disk.
The format is versioned JSON of a few hundred bytes.

ASTERIX I010/161 numbers (1-4,095, `edge.outputs.asterix`) are kept by the same rules under the
key `asterix:SAC/SIC`: a VTS that saw track 12 of this sensor before a crash must not see a new
ship as 12 seconds after the restart.

The daemon's side, `Persistence`, restores the pipeline's and the numbering outputs' state and
saves changes.

`Persistence.open(config)` finds the state directory (none configured: returns None and nothing
is kept). `restore` is called before the first pair (and after a reload that rebuilt the
pipeline or outputs, from the last state in memory); `after_step` after each published step,
offering a new state to the writer thread only when an allocator's `version` changed or the
tracker's next id reached the reserved bound; `close` saves the last state at shutdown.
"""

from __future__ import annotations

import json
import logging
import math
import os
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from edge.encode.target_numbers import TargetNumbers
from edge.outputs.asterix import AsterixOutput
from edge.outputs.fanout import Outputs
from edge.outputs.nmea_serial import NmeaSerialOutput
from edge.outputs.nmea_udp import NmeaUdpOutput
from edge.pipeline import Pipeline

log = logging.getLogger(__name__)

FORMAT = 1
FILE_NAME = "state.json"
ID_RESERVE = 1000  # track ids reserved ahead of the tracker per save


def boot_id() -> str:
    try:
        return Path("/proc/sys/kernel/random/boot_id").read_text(encoding="ascii").strip()
    except OSError:
        return ""


def state_dir(configured: str | None) -> Path | None:
    """The configured directory, else $STATE_DIRECTORY (its first entry), else None (no state kept)."""
    if configured:
        return Path(configured)
    env = os.environ.get("STATE_DIRECTORY", "")
    return Path(env.split(":")[0]) if env else None


@dataclass
class NumbersState:
    """One allocator's numbers: in use (live or lost) and in quarantine (number -> seconds left)."""

    in_use: list[int] = field(default_factory=list)
    quarantine_s: dict[int, float] = field(default_factory=dict)

    @classmethod
    def of(cls, numbers: TargetNumbers, now_s: float) -> NumbersState:
        held = numbers.held(now_s)
        return cls(sorted(n for n, left in held.items() if left is None),
                   {n: left for n, left in sorted(held.items()) if left is not None})


@dataclass
class State:
    next_track_id: int
    numbers: dict[str, NumbersState]  # by output key (e.g. "serial:/dev/ttyS1")

    def to_json(self) -> str:
        return json.dumps({
            "format": FORMAT, "saved_wall_s": time.time(), "saved_mono_s": time.monotonic(),
            "boot_id": boot_id(), "next_track_id": self.next_track_id,
            "numbers": {k: {"in_use": v.in_use, "quarantine_s": {str(n): round(s, 3) for n, s in
                                                              v.quarantine_s.items()}}
                        for k, v in sorted(self.numbers.items())},
        }, separators=(",", ":")) + "\n"


class StateError(ValueError):
    """The state file is missing, unreadable or not a state file of this format."""


def parse_state(text: str, now_wall_s: float, now_mono_s: float) -> State:
    """The saved state with quarantines aged by the time since the save; StateError if malformed."""
    try:
        data: Any = json.loads(text)
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise StateError(f"not format {FORMAT}")
        same_boot = data["boot_id"] == boot_id() and data["boot_id"] != ""
        elapsed_s = (now_mono_s - float(data["saved_mono_s"])) if same_boot \
            else (now_wall_s - float(data["saved_wall_s"]))
        elapsed_s = max(0.0, elapsed_s)
        next_id = int(data["next_track_id"])
        numbers = {}
        for key, v in dict(data["numbers"]).items():
            quarantine = {int(n): max(0.0, float(s) - elapsed_s) for n, s in dict(v["quarantine_s"]).items()}
            numbers[str(key)] = NumbersState([int(n) for n in v["in_use"]], quarantine)
    except StateError:
        raise
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise StateError(f"malformed: {type(exc).__name__}: {exc}") from None
    if next_id < 1 or not all(math.isfinite(s) for v in numbers.values() for s in v.quarantine_s.values()):
        raise StateError("out-of-range values")
    return State(next_id, numbers)


def write_atomic(path: Path, text: str) -> None:
    """Replace `path` with `text`: temp file in the same directory, fsync, rename, fsync the dir."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o640)
    try:
        os.write(fd, text.encode("ascii"))
        os.fsync(fd)
    finally:
        os.close(fd)
    os.replace(tmp, path)
    dfd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dfd)
    finally:
        os.close(dfd)


class StateKeeper:
    """Loads the state once at start and saves each new state on a writer thread."""

    def __init__(self, directory: Path) -> None:
        self.path = directory / FILE_NAME
        self.fault: str | None = None  # why the state at start was lost, if it was
        self.corrupt = False  # a file was there but unusable (not merely missing)
        self.saves = 0
        self.errors = 0
        self._pending: str | None = None
        self._cond = threading.Condition()
        self._stop = False
        for stale in directory.glob(f".{FILE_NAME}.*.tmp") if directory.is_dir() else ():
            stale.unlink(missing_ok=True)  # a write a kill interrupted: the old file stands
        self._thread = threading.Thread(target=self._run, name="state", daemon=True)
        self._thread.start()

    def load(self) -> State | None:
        """The saved state, or None with `fault` set and logged (missing, unreadable, corrupt)."""
        try:
            text = self.path.read_text(encoding="ascii")
            return parse_state(text, time.time(), time.monotonic())
        except FileNotFoundError:
            self.fault = f"no state file {self.path}"
        except (OSError, UnicodeDecodeError, StateError) as exc:
            self.fault, self.corrupt = f"state file {self.path} unusable: {exc}", True
        from edge.appliance.journal import MESSAGE_IDS

        policy = "every NMEA and ASTERIX track number held for the quarantine" if self.corrupt \
            else "first start?"
        log.error("%s: %s; track ids restart from the clock", self.fault, policy,
                  extra={"MESSAGE_ID": MESSAGE_IDS["state_lost"], "FAULT": self.fault})
        return None

    def offer(self, state: State) -> None:
        """Save `state` soon (the writer thread takes the newest); never blocks on the disk."""
        with self._cond:
            self._pending = state.to_json()
            self._cond.notify()

    def _run(self) -> None:
        while True:
            with self._cond:
                self._cond.wait_for(lambda: self._pending is not None or self._stop)
                text, self._pending = self._pending, None
                if text is None:
                    return
            try:
                self.path.parent.mkdir(parents=True, exist_ok=True)
                write_atomic(self.path, text)
                self.saves += 1
            except OSError as exc:
                if not self.errors:
                    log.error("cannot save the state file %s (counted, logged once): %s", self.path, exc)
                self.errors += 1

    def close(self) -> None:
        """Write what is pending, then stop the writer."""
        with self._cond:
            self._stop = True
            self._cond.notify()
        self._thread.join(timeout=2.0)

def allocators(outputs: Outputs) -> Iterator[tuple[str, TargetNumbers]]:
    """(key, allocator) of every output that numbers tracks: an NMEA serial port by its URL, the
    NMEA UDP output by its source, ASTERIX by its SAC/SIC (a VTS keys I010/161 by them)."""
    for out in outputs.outputs:
        if isinstance(out, NmeaSerialOutput):
            yield f"serial:{out.port.name}", out.scheduler.numbers
        elif isinstance(out, NmeaUdpOutput):
            yield f"udp:{out.source}", out.scheduler.numbers
        elif isinstance(out, AsterixOutput):
            yield f"asterix:{out.source.sac}/{out.source.sic}", out.numbers


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
        """Apply the saved state (or, if it was lost, the conservative policy of `edge.appliance.state`)."""
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
        return f"state lost: NMEA and ASTERIX track numbers held {left_s:.0f} s more"

    def close(self, pipeline: Pipeline, outputs: Outputs) -> None:
        self._versions = {}
        self.after_step(pipeline, outputs)
        self.keeper.close()
