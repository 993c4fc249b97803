"""The serial fault cases of `lab.faults.outputs`: port gone and back, a reader that stops reading.

Both drive a real `NmeaSerialOutput` (the daemon's serial output: scheduler + `PySerialPort`
writer thread) over a socat pty pair, with the reader in another process, and feed the
output's health into a `HealthMonitor` with the daemon's stages, so the rows say what the unit
shows (state, fault code). The processing rate is always a ratio to a healthy run in the same
case (`serial_rig.step_times`), never an absolute time.
"""

from __future__ import annotations

import re
import statistics
import time
from collections.abc import Callable
from pathlib import Path

from drivers.serial_port import VirtualSerialPort
from edge.appliance.health import HealthMonitor, HealthSnapshot, Status, standard_stages
from edge.outputs.nmea_serial import NmeaSerialOutput
from lab.faults import serial_rig as rig
from lab.faults.matrix import Row

RATE_RATIO_MIN = 0.5  # a blocked write (0.3 s timeout) would cut the step rate to under 10 %
SENTENCE = re.compile(r"\$([^$*\r\n]{1,79})\*([0-9A-F]{2})\r\n")


def valid_sentences(lines: list[str]) -> tuple[int, int]:
    """(lines whose XOR checksum is right, lines that are not) — an independent check."""
    good = 0
    for line in lines:
        match = SENTENCE.fullmatch(line)
        if match:
            value = 0
            for char in match.group(1).encode("ascii", "replace"):
                value ^= char
            good += f"{value:02X}" == match.group(2)
    return good, len(lines) - good


class _Unit:
    """An output plus the daemon's health stages, beaten as the daemon's loop would."""

    def __init__(self, out: NmeaSerialOutput) -> None:
        self.out = out
        self.health = HealthMonitor(standard_stages([("nmea", Status.NMEA_ACTIVE)]))

    def publish(self, fixes: object) -> None:
        self.out.publish(fixes)  # type: ignore[arg-type]
        for stage in ("camera_left", "camera_right", "processing"):
            self.health.beat(stage, frames=1 if stage == "processing" else 0)
        fault, counters = self.out.health()
        self.health.beat("nmea", fault=fault, counters=counters)

    def snapshot(self) -> HealthSnapshot:
        return self.health.snapshot()

    def run_until(self, seconds: float, t_offset: float, done: Callable[[HealthSnapshot], bool],
                  stop_when_done: bool = False) -> tuple[float | None, list[float], float]:
        """Publish at ~30 Hz for up to `seconds`; (time `done` first held or None, steps, longest)."""
        start, steps, longest, seen = time.monotonic(), [], 0.0, None
        while (now := time.monotonic()) - start < seconds:
            d, worst = rig.step_times(self.publish, 1 / 30, t_offset + now - start)
            steps += d
            longest = max(longest, worst)
            if seen is None and done(self.snapshot()):
                seen = time.monotonic() - start
                if stop_when_done:
                    break
        return seen, steps, longest


def _shown(snap: HealthSnapshot) -> str:
    return f"{snap.state.value} code {snap.fault_code} ({snap.reason or 'ok'})"


def serial_gone(workdir: Path) -> list[Row]:
    pair = rig.SocatPair(workdir).start()
    unit = _Unit(NmeaSerialOutput(pair.a, baud=38400, write_timeout_s=0.3, queue_max=8))
    unit.out.start()
    reader = rig.start_reader(pair.b, idle_s=0.5, max_s=20.0)
    try:
        _, healthy_steps, _ = unit.run_until(1.0, 0.0, lambda s: False)
        pair.kill()  # the cable is pulled
        lost_s, down_steps, longest = unit.run_until(1.5, 10.0, lambda s: "serial port lost" in s.reason)
        lost_shown = _shown(unit.snapshot())
        before = [line for _, line in rig.reader_lines(reader)]
        pair.start()  # the same path again, new ptys
        t_back = time.monotonic()
        reader = rig.start_reader(pair.b, idle_s=0.5, max_s=20.0)
        ok_s, _, longest_up = unit.run_until(8.0, 20.0, lambda s: s.fault_code == 0, stop_when_done=True)
        unit.run_until(0.5, 30.0, lambda s: False)
        unit.out.close()
        after_rows = rig.reader_lines(reader)
        stats = unit.out.port.stats()
    finally:
        unit.out.close()
        pair.kill()
    after = [line for _, line in after_rows]
    good_before, _ = valid_sentences(before)
    good, bad = valid_sentences(after)
    ratio = statistics.median(healthy_steps) / statistics.median(down_steps)
    resumed_s = after_rows[0][0] - t_back if after_rows else None
    lost = "never" if lost_s is None else f"after {lost_s:.2f} s"
    ok = "never" if ok_s is None else f"after {ok_s:.2f} s"
    return [
        Row("serial far end gone 1.5 s", "fault shown within 1 s, processing unaffected",
            f"{good_before} sentences before; shown {lost}: "
            f"{lost_shown}; step rate x{ratio:.2f} of healthy, longest publish {1e3 * longest:.1f} ms",
            lost_s is not None and lost_s <= 1.0 and ratio >= RATE_RATIO_MIN and longest < 0.1),
        Row("serial far end back", "output resumes, checksums valid, OK again",
            f"{good} valid / {bad} bad sentences after; reconnects {stats.reconnects}, "
            f"errors {stats.errors}, dropped {stats.dropped}; OK {ok}; "
            f"longest publish {1e3 * longest_up:.1f} ms",
            good >= 10 and bad == 0 and ok_s is not None and stats.reconnects >= 1,
            recovery_s=resumed_s),
    ]


def serial_stalled(workdir: Path) -> list[Row]:
    with rig.SocatPair(workdir) as pair:
        unit = _Unit(NmeaSerialOutput(pair.a, baud=38400, xonxoff=True, queue_max=8, write_timeout_s=0.3))
        unit.out.start()
        deadline = time.monotonic() + 5.0
        while not unit.out.port.stats().connected and time.monotonic() < deadline:
            time.sleep(0.01)  # opening flushes input: XOFF must come after
        reader = rig.start_reader(pair.b, xoff=True, xon_after_s=3.5, idle_s=0.5, max_s=20.0)
        t_stall = time.monotonic()
        healthy = _Unit(NmeaSerialOutput("virtual", baud=38400, port=VirtualSerialPort(queue_max=8)))
        healthy.out.start()
        steps: dict[str, list[float]] = {"healthy": [], "stalled": []}
        longest = 0.0
        for round_ in range(3):  # interleaved, so machine load hits both alike
            for name, u in (("healthy", healthy), ("stalled", unit)):
                durations, worst = rig.step_times(u.publish, 0.5, 10.0 * round_)
                steps[name] += durations
                longest = max(longest, worst)
        stalled_shown = _shown(unit.snapshot())
        stats = unit.out.port.stats()
        unit.run_until(max(0.0, 3.5 - (time.monotonic() - t_stall)), 35.0, lambda s: False)
        ok_s, _, _ = unit.run_until(6.0, 40.0, lambda s: s.fault_code == 0, stop_when_done=True)
        unit.run_until(0.5, 50.0, lambda s: False)
        unit.out.close()
        healthy.out.close()
        rows = rig.reader_lines(reader)
    xon_t = next((float(line) for t, line in rows if t == "xon"), None)
    after = [(t, line) for t, line in rows if t != "xon"]
    good, bad = valid_sentences([line for _, line in after])
    rate = {name: 1.0 / statistics.median(d) for name, d in steps.items()}
    ratio = rate["stalled"] / rate["healthy"]
    resumed_s = after[0][0] - xon_t if after and xon_t is not None else None
    ok = "never" if ok_s is None else f"after {ok_s:.2f} s"
    stalled_ok = ratio >= RATE_RATIO_MIN and longest < 0.1 and stats.write_timeouts >= 1
    return [
        Row("reader stops reading (XOFF 3.5 s)", f"step rate >= {RATE_RATIO_MIN} x healthy, stall shown",
            f"rate x{ratio:.2f}, longest publish {1e3 * longest:.1f} ms, "
            f"write timeouts {stats.write_timeouts}, dropped {stats.dropped}; shown: {stalled_shown}",
            stalled_ok and "stalled" in stalled_shown),
        Row("reader resumes (XON)", "sentences flow again, checksums valid, OK again",
            f"{good} valid / {bad} bad lines after XON (a timed-out write may cut one); "
            f"OK {ok}",
            good >= 10 and bad <= max(1, stats.write_timeouts) and ok_s is not None, recovery_s=resumed_s),
    ]
