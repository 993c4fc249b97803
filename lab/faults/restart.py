"""Fault cases: SIGKILL in the middle of a run, a corrupt state file, kills during state writes.

- `restart-sigkill`: `mast-stereo run` (a looped recording at full speed, NMEA on a pty read
  by `PtyReader`, the tracks CSV, a real NOTIFY_SOCKET) is killed with SIGKILL once its NMEA
  carries target numbers, and started again on the same state directory: READY=1 again, no
  number of the killed run lent to a track of the new one (all within 60 s of their last use),
  track ids above the killed run's, and the state file parses after the kill and after SIGTERM.
- `restart-corrupt-state`: garbage in state.json: the daemon logs the fault, still sends
  READY=1 with the fault in STATUS=, holds every number (no TTM) and rewrites a good file.
- `state-kill-loop`: a writer saving states as fast as it can, SIGKILLed at random points:
  the file parses after every kill (write temp + fsync + rename).

A recording to replay can be given in $MAST_FAULTS_RECORDING (the tests pass one the session
already rendered); otherwise the soak's small lap is rendered into the work directory.
"""

from __future__ import annotations

import csv
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import yaml

from edge.appliance.state import FILE_NAME, StateError, parse_state
from lab.faults._rig import NotifyListener
from lab.faults.matrix import Case, Row
from lab.faults.soak import ROOT, PtyReader
from lab.faults.soak_scene import TEST_LAP, lap_recording


def recording(workdir: Path) -> Path:
    given = os.environ.get("MAST_FAULTS_RECORDING")
    return Path(given) if given else lap_recording(workdir / "cache", TEST_LAP)


def write_config(workdir: Path, name: str, rec: Path, pty_path: str, state: Path) -> Path:
    cfg = {"cameras": {"kind": "replay", "path": str(rec), "pace": False, "loop": True},
           "outputs": {"nmea": [{"url": pty_path, "baud": 115200}],
                       "tracks_csv": str(workdir / f"{name}.csv"),
                       "modbus": {"tcp": {"enabled": False}}},
           "health": {"stale_s": 30.0, "min_fps": 0.0, "leds": {"kind": "none"}, "state_dir": str(state)},
           "logging": {"level": "INFO"}}
    path = workdir / f"{name}.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def start(config: Path, notify: NotifyListener, log: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "edge.cli", "run", "--config", str(config)], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=open(log, "w"),  # noqa: SIM115 - the child owns it
                            env={**os.environ, "NOTIFY_SOCKET": notify.path})


def track_ids(path: Path) -> list[int]:
    """Track ids in a tracks CSV (a row cut by the kill is skipped)."""
    if not path.is_file():
        return []
    with open(path, newline="", encoding="ascii", errors="replace") as f:
        return [int(r[1]) for r in csv.reader(f) if len(r) > 1 and r[1].isdigit()]


def state_parses(path: Path) -> str | None:
    """None if the state file parses, else why not."""
    try:
        parse_state(path.read_text(encoding="ascii"), time.time(), time.monotonic())
    except (OSError, UnicodeDecodeError, StateError) as exc:
        return str(exc)
    return None


def numbers_after(reader: PtyReader, t_s: float, status: str = "T") -> set[int]:
    return {n for t, n, s in list(reader.ttm) if t >= t_s and s == status}


def wait_numbers(reader: PtyReader, after_s: float, count: int, timeout_s: float) -> set[int]:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end and len(numbers_after(reader, after_s)) < count:
        time.sleep(0.1)
    return numbers_after(reader, after_s)


def _sigkill(workdir: Path) -> list[Row]:
    rec, state = recording(workdir), workdir / "state"
    reader, notify = PtyReader(keep_ttm=True), NotifyListener(workdir / "notify.sock")
    rows: list[Row] = []
    procs: list[subprocess.Popen] = []
    try:
        t0 = time.monotonic()
        config = write_config(workdir, "run1", rec, reader.path, state)
        procs.append(start(config, notify, workdir / "run1.log"))
        if notify.wait_for("READY=1", t0) is None:
            return [Row("SIGKILL mid-run", "READY=1 from the first run", "no READY=1", False)]
        first = wait_numbers(reader, t0, 2, 15.0)
        procs[0].send_signal(signal.SIGKILL)
        procs[0].wait(5)
        killed_s = time.monotonic()
        ids_1 = track_ids(workdir / "run1.csv")
        why = state_parses(state / FILE_NAME)
        rows.append(Row("SIGKILL after NMEA numbers " + ",".join(f"{n:02d}" for n in sorted(first)),
                        "state file parses after the kill", why or "parses", why is None and bool(first)))
        config = write_config(workdir, "run2", rec, reader.path, state)
        procs.append(start(config, notify, workdir / "run2.log"))
        ready_s = notify.wait_for("READY=1", killed_s)
        rows.append(Row("restart after SIGKILL", "READY=1 again (NOTIFY_SOCKET)",
                        "READY=1" if ready_s else "no READY=1", ready_s is not None,
                        None if ready_s is None else ready_s - killed_s))
        second = wait_numbers(reader, ready_s or killed_s, 1, 15.0)
        reused = second & first
        rows.append(Row("NMEA numbers after the restart", "none of the killed run's within 60 s",
                        f"before {sorted(first)}, after {sorted(second)}, "
                        f"{time.monotonic() - t0:.0f} s apart at most",
                        bool(second) and not reused and time.monotonic() - t0 < 60.0))
        ids_2 = track_ids(workdir / "run2.csv")
        rows.append(Row("track ids after the restart", "all above the killed run's",
                        f"run 1 up to {max(ids_1, default=0)}, run 2 from {min(ids_2, default=0)}",
                        bool(ids_1) and bool(ids_2) and min(ids_2) > max(ids_1)))
        procs[1].send_signal(signal.SIGTERM)
        code = procs[1].wait(10)
        why = state_parses(state / FILE_NAME)
        rows.append(Row("SIGTERM after the restart", "exit 0, state file parses",
                        f"exit {code}, " + (why or "parses"), code == 0 and why is None))
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
        reader.close(settle_s=0.0)
        notify.close()
    return rows


def _corrupt(workdir: Path) -> list[Row]:
    rec, state = recording(workdir), workdir / "state"
    state.mkdir()
    (state / FILE_NAME).write_bytes(b'{"format": 1, "next_track_id": \x00garbage')
    reader, notify = PtyReader(keep_ttm=True), NotifyListener(workdir / "notify.sock")
    log = workdir / "run.log"
    t0 = time.monotonic()
    proc = start(write_config(workdir, "run", rec, reader.path, state), notify, log)
    try:
        ready_s = notify.wait_for("READY=1", t0)
        statuses = [s for s in notify.texts("STATUS=", t0) if "state lost" in s]
        if ready_s is not None:
            end = time.monotonic() + 15.0
            while not statuses and time.monotonic() < end:
                time.sleep(0.2)
                statuses = [s for s in notify.texts("STATUS=", t0) if "state lost" in s]
            time.sleep(2.0)  # tracks form; their numbers must be held
        numbers = numbers_after(reader, t0)
        proc.send_signal(signal.SIGTERM)
        code = proc.wait(10)
        text = log.read_text(errors="replace")
        logged = next((line for line in text.splitlines() if "unusable" in line), "")
        why = state_parses(state / FILE_NAME)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        reader.close(settle_s=0.0)
        notify.close()
    return [
        Row("corrupt state file at start", "fault logged once, no traceback",
            (logged.split(": ", 1)[-1][:60] or "not logged") + ("; TRACEBACK" if "Traceback" in text else ""),
            bool(logged) and text.count("unusable") == 1 and "Traceback" not in text),
        Row("corrupt state file at start", "READY=1; STATUS= names it",
            f"{'READY=1' if ready_s else 'no READY'}; {statuses[0][7:70] if statuses else 'not in STATUS='}",
            ready_s is not None and bool(statuses), None if ready_s is None else ready_s - t0),
        Row("corrupt state file at start", "every target number held (no TTM)",
            f"numbers on the wire: {sorted(numbers) or 'none'}", not numbers),
        Row("corrupt state file at start", "exit 0 on SIGTERM, a good file written",
            f"exit {code}, " + (why or "parses"), code == 0 and why is None),
    ]


WRITER = """
import sys
from edge.appliance.state import NumbersState, State, write_atomic
from pathlib import Path
path, k = Path(sys.argv[1]), 0
while True:
    k += 1
    state = State(k * 1000, {f"serial:/dev/tty{j}": NumbersState(list(range(1, k % 99 + 1)),
                                                                {99: 59.5}) for j in range(3)})
    write_atomic(path, state.to_json())
"""


def _kill_loop(workdir: Path, kills: int = 12) -> list[Row]:
    path = workdir / FILE_NAME
    rng = random.Random(15)
    failures: list[str] = []
    writes = 0
    for _ in range(kills):
        proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], cwd=ROOT)
        deadline = time.monotonic() + 10.0
        while not path.exists() and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(rng.uniform(0.0, 0.15))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        why = state_parses(path)
        writes += 1
        if why:
            failures.append(why)
    leftovers = [p.name for p in workdir.iterdir() if p.name.endswith(".tmp")]
    return [Row(f"SIGKILL while saving state x{kills}", "the file parses after every kill",
                f"{kills - len(failures)}/{kills} parsed; {len(leftovers)} temp files left"
                + (f"; {failures[0]}" if failures else ""), not failures and writes == kills)]


CASES = [Case("restart-sigkill", "restart", _sigkill),
         Case("restart-corrupt-state", "restart", _corrupt),
         Case("state-kill-loop", "restart", _kill_loop)]
