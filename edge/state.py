"""What must survive a crash: NMEA target numbers in use or in quarantine, and the next track id.

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
"""

from __future__ import annotations

import json
import logging
import math
import os
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from edge.encode.targets import TargetNumbers

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
        from edge.journal import MESSAGE_IDS

        policy = "every NMEA target number held for the quarantine" if self.corrupt else "first start?"
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
