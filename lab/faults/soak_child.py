"""The daemon under soak: `Appliance` on a looped recording at full speed, watching itself.

Run by `tools/soak` as a child process (`python -m lab.faults.soak_child`), so the figures are the
daemon's own and not the harness's. It is the real `Appliance` (capture thread, processing thread,
outputs with their writer threads, the Modbus TCP server) built from a configuration file like
`mast-stereo run`, with three additions that only observe:

- every `sample_every` pairs one JSON line on stdout: pairs, seconds, RSS (VmRSS), open fds (by
  kind; not counting a PNG the capture thread happens to be reading at that instant),
  threads (from /proc/self), the block's per-pair latency (capture to outputs: p50, p99, max)
  and step time (the processing alone: p50, max);
- the live tracks sent once more as L at shutdown (fixes the pipeline did not compute);
- track ids: a new id must be above every id seen before (ids are never reused); a bounded
  window of recently seen ids lets a coasting track come back under its own id;
- target numbers: the first NMEA port's allocator is wrapped; a number lent to another track
  than its last owner less than `quarantine_s` after that owner's last L sentence went out, or
  while it is still live or lost, is a violation.

After `--pairs` pairs it stops like SIGTERM would, and prints a final JSON line with the
pipeline's counters, every output's counters and the violations found.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from drivers.camera.base import FramePair
from drivers.notify import SystemdNotifier
from edge.appliance.daemon import Appliance
from edge.config.app import load_config
from edge.encode.target_numbers import TargetNumbers
from edge.fix import ShipFix, TrackStatus
from edge.outputs.nmea_serial import NmeaSerialOutput

RECENT_STEPS = 2000  # a track id unseen this many pairs is retired: seeing it again is reuse


def proc_self() -> dict[str, Any]:
    """RSS (kB), threads and open file descriptors of this process, from /proc."""
    out = {"rss_kb": 0, "threads": 0}
    with open("/proc/self/status", encoding="ascii") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                out["rss_kb"] = int(line.split()[1])
            elif line.startswith("Threads:"):
                out["threads"] = int(line.split()[1])
    kinds: dict[str, int] = {}
    for fd in os.listdir("/proc/self/fd"):
        try:
            target = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:  # the listing's own descriptor, closed by now
            continue
        kind = target.split(":")[0] if ":" in target else "png" if target.endswith(".png") else "file"
        kinds[kind] = kinds.get(kind, 0) + 1
    out["fds"] = sum(n for k, n in kinds.items() if k != "png")  # not the frame the capture is reading
    return {**out, "fd_kinds": kinds}


class AuditedNumbers(TargetNumbers):
    """`TargetNumbers` that records each lending against the quarantine it must respect."""

    def __init__(self, max_number: int, quarantine_s: float) -> None:
        super().__init__(max_number, quarantine_s)
        self.owner: dict[int, int] = {}  # number -> last track id it was lent to
        self.retired_s: dict[int, float] = {}  # number -> when its last L went out
        self.lendings = 0
        self.violations: list[str] = []
        self.min_gap_s = float("inf")  # shortest retirement-to-new-owner interval seen

    def assign(self, track_id: int, now_s: float) -> int | None:
        fresh = track_id not in self._live
        number = super().assign(track_id, now_s)
        if number is None or not fresh:
            return number
        self.lendings += 1
        previous = self.owner.get(number)
        if previous is not None and previous != track_id:
            retired = self.retired_s.get(number)
            if retired is None:
                self.violations.append(f"number {number} lent to {track_id} while {previous} held it")
            else:
                self.min_gap_s = min(self.min_gap_s, now_s - retired)
                if now_s - retired < self.quarantine_s:
                    self.violations.append(f"number {number} reused after {now_s - retired:.1f} s")
        self.owner[number] = track_id
        self.retired_s.pop(number, None)
        return number

    def retire(self, number: int, now_s: float) -> None:
        super().retire(number, now_s)
        self.retired_s[number] = now_s


class SoakAppliance(Appliance):
    """The appliance with the soak's observers (see the module docstring)."""

    pairs_goal = 0
    sample_every = 500
    stop_event: threading.Event | None = None

    def start_watching(self) -> None:
        self.latency_ns: list[int] = []
        self.step_ns: list[int] = []
        self.recent: dict[int, int] = {}  # track id -> last step it had a fix
        self.max_id = 0
        self.id_violations: list[str] = []
        self.t0_s = time.monotonic()
        self.numbers: AuditedNumbers | None = None
        first = next((o for o in self.outputs.outputs if isinstance(o, NmeaSerialOutput)), None)
        if first is not None:
            old = first.scheduler.numbers
            self.numbers = first.scheduler.numbers = AuditedNumbers(old.max_number, old.quarantine_s)

    def _step(self, pair: FramePair, captured_ns: int) -> None:
        t0 = time.monotonic_ns()
        super()._step(pair, captured_ns)
        now = time.monotonic_ns()
        self.latency_ns.append(now - captured_ns)
        self.step_ns.append(now - t0)
        self._check_ids(self.last_fixes)
        if self.steps % self.sample_every == 0:
            self._sample()
        if self.steps >= self.pairs_goal and self.stop_event is not None:
            self.stop_event.set()

    def _check_ids(self, fixes: Sequence[ShipFix]) -> None:
        for fx in fixes:
            tid = fx.track_id
            if tid not in self.recent and tid <= self.max_id:
                self.id_violations.append(f"track id {tid} seen again after max id {self.max_id}")
            self.recent[tid] = self.steps
            self.max_id = max(self.max_id, tid)
        if self.steps % RECENT_STEPS == 0:
            self.recent = {t: s for t, s in self.recent.items() if self.steps - s < RECENT_STEPS}

    def _sample(self) -> None:
        lat, step = sorted(self.latency_ns), sorted(self.step_ns)
        self.latency_ns, self.step_ns = [], []

        def q(v: list[int], p: float) -> float:
            return v[min(len(v) - 1, int(p * len(v)))] / 1e6 if v else 0.0

        now_s = time.monotonic()  # CLOCK_MONOTONIC: the harness's clock too
        rec = {"pairs": self.steps, "t_s": round(now_s - self.t0_s, 3), "mono_s": now_s, **proc_self(),
               "lat_p50_ms": q(lat, 0.5), "lat_p99_ms": q(lat, 0.99), "lat_max_ms": q(lat, 1.0),
               "step_p50_ms": q(step, 0.5), "step_max_ms": q(step, 1.0),
               "tracks_max_id": self.max_id}
        print(json.dumps(rec), flush=True)

    def _send_lost(self) -> None:
        self.lost_at_stop = sum(f.status is not TrackStatus.LOST for f in self.last_fixes)
        super()._send_lost()

    def final(self) -> dict:
        outputs = {}
        for out in self.outputs.outputs:
            fault, counters = out.health()
            outputs[out.unit] = {"fault": fault, **counters}
        c = self.pipeline.counters
        numbers = self.numbers
        return {
            "final": True, "steps": self.steps,
            "pipeline": {"pairs": c.pairs, "processed": c.processed, "fixes": c.fixes, "failed": c.failed,
                         "bad_input": c.bad_input, "gaps": c.gaps},
            "lost_at_stop": getattr(self, "lost_at_stop", 0),  # live tracks sent once more as L at shutdown
            "input_dropped_pairs": self.queue.dropped, "capture_errors": self.capture_errors,
            "outputs": outputs, "id_violations": self.id_violations[:20], "max_track_id": self.max_id,
            "number_violations": numbers.violations[:20] if numbers else None,
            "number_lendings": numbers.lendings if numbers else 0,
            "number_min_gap_s": numbers.min_gap_s if numbers and numbers.min_gap_s != float("inf") else None,
            **{f"end_{k}": v for k, v in proc_self().items()},
        }


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="soak_child", description=__doc__)
    ap.add_argument("--config", required=True, type=Path)
    ap.add_argument("--pairs", required=True, type=int)
    ap.add_argument("--sample-every", type=int, default=500)
    args = ap.parse_args(argv)
    config = load_config(args.config)
    appliance = SoakAppliance.build(config, args.config, SystemdNotifier())
    assert isinstance(appliance, SoakAppliance)
    appliance.pairs_goal, appliance.sample_every = args.pairs, args.sample_every
    stop = threading.Event()
    appliance.stop_event = stop
    appliance.start_watching()
    appliance.run(stop)
    print(json.dumps(appliance.final()), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
