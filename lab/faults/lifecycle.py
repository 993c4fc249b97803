"""Lifecycle faults against the running daemon: wall-clock steps, a full disk, a hung stage.

The daemon runs on the fake-V4L2 bench of lab/faults/_rig.py (real sockets: sd_notify, Modbus
TCP, NMEA on a pty).

- wall-clock-step: CLOCK_REALTIME stepped +1 h, then to -1 h, while running (through the pair
  source's `realtime_offset` seam; the machine's clock is never touched). Pairing and the track
  filter run on CLOCK_MONOTONIC, so the same track keeps its id and range and no pair is
  mispaired or lost; the NMEA TTM time follows the wall clock within 2 s.
- disk-full-recording: `run --record` onto a 3 MB tmpfs (root only; skipped otherwise). The
  recording stops with a fault (Modbus FAULT_CODE 72, DEGRADED, logged once), the daemon keeps
  processing and sending TTM, and the recording replays up to its last complete pair.
- hung-stage: with WatchdogSec = 1.2 s and health.stale_s = 0.6 s, the NMEA output's publish,
  then the pair source's read, made to block: WATCHDOG=1 stops within one WatchdogSec of the
  hang and resumes once released.
- watchdog-restart (slow, appliance VM only): systemd restarts the unit on the watchdog time-out;
  that is tests/vm/test_systemd_vm.py::test_a_stopped_daemon_is_restarted_by_the_watchdog (the
  daemon SIGSTOPped inside the systemd VM), run here only where the VM exists.
"""

from __future__ import annotations

import datetime
import logging
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

from edge.outputs.nmea_serial import NmeaSerialOutput
from edge.recording.live import STAGE as RECORDING_STAGE
from lab.faults._rig import Bench, degraded, tmpfs
from lab.faults.matrix import Case, Row

STEP_S = 3600.0
WATCHDOG_USEC = 1_200_000  # pings every 0.6 s; a stage is stale after 0.6 s (health.stale_s)
ROOT = Path(__file__).resolve().parents[2]


def _tod_error_s(hhmmss: str, expected_unix_s: float) -> float:
    """|TTM time of day - expected UTC time of day|, modulo a day."""
    tod = int(hhmmss[:2]) * 3600 + int(hhmmss[2:4]) * 60 + float(hhmmss[4:])
    want = expected_unix_s % 86400
    d = abs(tod - want) % 86400
    return min(d, 86400 - d)


def wall_clock_step(workdir: Path) -> list[Row]:
    with Bench(workdir) as bench:
        if not bench.ready():
            return [Row("daemon on fake cameras", "READY=1 and OK", "never ready", False)]
        time.sleep(1.0)  # the track is confirmed and on NMEA
        phases: list[tuple[float, float, float]] = []  # (start, end, step) on CLOCK_MONOTONIC
        for step in (0.0, STEP_S, -STEP_S):
            bench.utc_step_s = step
            t0 = time.monotonic()
            time.sleep(1.5)
            phases.append((t0, time.monotonic(), step))
        bench.utc_step_s = 0.0
        offset = time.time() - time.monotonic()  # to turn arrival times into true UTC
        worst: dict[float, float] = {}
        for t, fields in bench.pty.sentences("TTM"):
            for t0, t1, step in phases:
                if t0 + 0.5 <= t < t1:  # sentences of pairs made before the step may be in flight
                    err = _tod_error_s(fields[14], t + offset + step)
                    worst[step] = max(worst.get(step, 0.0), err)
        run = [p for p in bench.processed if p.t_s >= phases[0][0]]
        ids = {f.track_id for p in run for f in p.fixes}
        ranges = [f.range_m for p in run for f in p.fixes if f.track_id == min(ids, default=-1)]
        pulses = sorted(p.pulse_left for p in run if p.pulse_left is not None)
        lost = sum(b - a - 1 for a, b in zip(pulses, pulses[1:], strict=False))
        bad = bench.mispaired(phases[0][0])
    spread = max(ranges) - min(ranges) if ranges else float("nan")
    utc_ok = len(worst) == 3 and max(worst.values()) < 2.0  # the steps 0, +1 h, -1 h all seen
    rows = [
        Row("wall clock stepped +1 h, then -1 h", "pairing and filter unaffected",
            f"{len(run)} pairs, {len(bad)} mispaired, {lost} pulses skipped; track ids {sorted(ids)}, "
            f"range spread {spread:.1f} m", not bad and len(ids) == 1 and spread < 15.0 and lost <= 2),
        Row("wall clock stepped +1 h, then -1 h", "NMEA TTM UTC follows the wall clock (< 2 s)",
            "worst |TTM - wall clock| " + ", ".join(f"{k / 3600:+g} h: {v:.2f} s" for k, v in worst.items()),
            utc_ok),
    ]
    return rows


class _Records(logging.Handler):
    def __init__(self) -> None:
        super().__init__()
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


def disk_full_recording(workdir: Path) -> list[Row]:
    expected = "recording stops with fault 72, tracking and TTM go on"
    fault = "disk full while recording (3 MB tmpfs)"
    mount = workdir / "small-disk"
    with tmpfs(mount, 3072) as mounted:
        if not mounted:
            why = "needs root to mount a tmpfs" if os.geteuid() != 0 else "mount -t tmpfs failed here"
            return [Row(fault, expected, "", False, skipped=why)]
        records = _Records()
        logging.getLogger().addHandler(records)
        try:
            with Bench(workdir, record=mount / "rec") as bench:
                if not bench.ready():
                    return [Row(fault, expected, "daemon never ready", False)]
                t_full = bench.wait(lambda: bench.modbus.first(0, lambda s, f: f == 72) is not None, 20.0)
                if t_full is None:
                    return [Row(fault, expected, "no fault 72 on Modbus within 20 s", False)]
                n0, ttm0 = len(bench.processed), len(bench.pty.sentences("TTM"))
                time.sleep(1.5)
                after = len(bench.processed) - n0
                ttm_after = len(bench.pty.sentences("TTM")) - ttm0
                snap = bench.app.health.snapshot()
                counters = bench.stage_counters(RECORDING_STAGE)
                reason = snap.reason
                status = bench.modbus.samples[-1][1] if bench.modbus.samples else 0
        finally:
            logging.getLogger().removeHandler(records)
        logged = [r for r in records.records if getattr(r, "STAGE", None) == RECORDING_STAGE
                  and r.levelno >= logging.ERROR]
        replayed, replay_error = _replay_count(mount / "rec")
    written = counters.get("written", -1)
    passed = (after >= 5 and ttm_after >= 1 and degraded(status, 72) and len(logged) == 1
              and counters.get("write_failures") == 1 and replay_error is None and replayed == written)
    return [Row(fault, expected,
                f"{written} pairs written; then {after} pairs processed, {ttm_after} TTM in 1.5 s; "
                f"logged {len(logged)}x; '{reason[:40]}'; replay reads {replayed}"
                + (f" ({replay_error})" if replay_error else ""), passed)]


def _replay_count(root: Path) -> tuple[int, str | None]:
    """How many pairs a replay reads from the recording, or the error that stops it."""
    from drivers.camera.replay import ReplaySource

    try:
        with ReplaySource(root) as source:
            n = sum(1 for _ in source)
            return n, None if source.skipped == 0 else f"{source.skipped} skipped"
    except Exception as exc:  # noqa: BLE001 - reported in the row
        return 0, f"{type(exc).__name__}: {exc}"


def _hang(bench: Bench, what: str, release: threading.Event, hung_at: list[float]) -> None:
    """Make `what` ("output" or "source") block until `release` is set."""
    def blocked(*_: object, **__: object) -> object:
        hung_at.append(time.monotonic())
        release.wait(30.0)
        return []

    if what == "output":
        nmea = next(o for o in bench.app.outputs.outputs if isinstance(o, NmeaSerialOutput))
        real = nmea.publish

        def publish(fixes, utc_ns):
            if not release.is_set():
                blocked()
            return real(fixes, utc_ns)

        nmea.publish = publish  # type: ignore[method-assign,assignment]
    else:
        source = bench.app.source
        assert source is not None
        real_read = source.read

        def read(*args, **kwargs):
            if not release.is_set():
                blocked()
            return real_read(*args, **kwargs)

        source.read = read  # type: ignore[method-assign]


def hung_stage(workdir: Path) -> list[Row]:
    limit_s = WATCHDOG_USEC / 1e6
    rows = []
    with Bench(workdir, stale_s=limit_s / 2, watchdog_usec=WATCHDOG_USEC) as bench:
        if not bench.ready():
            return [Row("daemon on fake cameras", "READY=1 and OK", "never ready", False)]
        for what, label in (("output", "NMEA output's publish blocks"),
                            ("source", "pair source's read blocks")):
            time.sleep(1.2)  # regular pings first
            release, hung_at = threading.Event(), []  # type: ignore[var-annotated]
            _hang(bench, what, release, hung_at)
            time.sleep(limit_s + 0.6)
            pings = bench.notify.times("WATCHDOG=1")
            statuses = [m for t, m in bench.notify.messages if hung_at and t > hung_at[0] + limit_s / 2 + 0.2
                        and m.startswith("STATUS=")]
            release.set()
            t_rel = time.monotonic()
            t_back = bench.wait(lambda t_rel=t_rel: bench.notify.times("WATCHDOG=1")[-1] > t_rel, 5.0)
            if not hung_at:
                rows.append(Row(label, "the hang happens", "the seam was never reached", False))
                continue
            before = [t for t in pings if t < hung_at[0]]
            last = max(pings) - hung_at[0] if pings else float("nan")
            rows.append(Row(label, f"WATCHDOG=1 stops within WatchdogSec ({limit_s:g} s)",
                            f"last ping {last:.2f} s after the hang ({len(before)} before); "
                            f"{statuses[-1][7:60] if statuses else 'no STATUS'}; pings resume "
                            + ("never" if t_back is None else f"{t_back - t_rel:.2f} s after release"),
                            len(before) >= 1 and last <= limit_s and t_back is not None,
                            None if t_back is None else t_back - t_rel))
    return rows


def watchdog_restart(workdir: Path) -> list[Row]:
    fault = "daemon hung (SIGSTOP) under systemd"
    expected = "systemd: watchdog timeout, unit restarted"
    test = "tests/vm/test_systemd_vm.py::test_a_stopped_daemon_is_restarted_by_the_watchdog"
    harness = Path(os.environ.get("APPLIANCE_VM", "/work/shared/tools/appliance-vm"))
    if not (harness / "run.sh").is_file() or not (ROOT / "tests" / "vm").is_dir():
        return [Row(fault, expected, "", False, skipped=f"needs the appliance VM ({test})")]
    t0 = time.monotonic()
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                           "tests/vm/test_systemd_vm.py", "-k", "restarted_by_the_watchdog"],
                          cwd=ROOT, capture_output=True, text=True, timeout=1200)
    tail = (done.stdout.strip().splitlines() or ["no output"])[-1]
    if "skipped" in tail and "passed" not in tail:
        return [Row(fault, expected, "", False, skipped=f"{test}: {tail}")]
    when = datetime.timedelta(seconds=round(time.monotonic() - t0))
    return [Row(fault, expected, f"{test}: {tail} ({when} incl. boot)", done.returncode == 0)]


CASES = [
    Case("wall-clock-step", "lifecycle", wall_clock_step),
    Case("disk-full-recording", "lifecycle", disk_full_recording),
    Case("hung-stage", "lifecycle", hung_stage),
    Case("watchdog-restart", "lifecycle", watchdog_restart, slow=True),
]
