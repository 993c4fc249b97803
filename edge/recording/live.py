"""`run --record DIR`: the daemon records the pairs it processes, and a full disk is a fault, not a stop.

`LiveRecorder` writes the recording format (docs/recordings.md) through edge/recording/format.py's
`RecordingWriter` and
`PairWriter` (every pair all or nothing on disk, PNGs encoded on the writer's own thread). The
processing thread only offers each pair to the writer's bounded queue: when the writer falls
behind the oldest queued pair is dropped and counted (the live-source policy of edge/recording/capture.py),
so recording never slows tracking. Timestamps are rebased on the first pair, as `record` does.

When a write fails (ENOSPC, EIO, any OSError) the recording stops for good: the files replay up
to the last complete pair, the failure is counted and shown on the `recording` health stage
(fault code 72, logged once by the daemon's FaultLog), and the daemon tracks and emits on.
"""

from __future__ import annotations

import datetime
import logging
from pathlib import Path

from drivers.camera.base import FramePair
from edge.appliance.health import HealthMonitor, Stage, Status
from edge.config.calibration import Calibration
from edge.recording.capture import PairWriter, queue_capacity, rebased, utc_anchor_ns
from edge.recording.format import RecordingWriter, build_meta

log = logging.getLogger(__name__)

STAGE = "recording"
STAGE_CODE = 7  # after the outputs' 4..6, whatever outputs are configured: fault code 72 = write failed


def recording_stage(stall_after_s: float) -> Stage:
    """The health stage of `run --record`: non-critical (a failed recording is DEGRADED, never STALLED)."""
    return Stage(STAGE, STAGE_CODE, max(5.0, stall_after_s), Status(0), critical=False)


class LiveRecorder:
    """Records offered pairs into `root`; `offer` never blocks on the disk."""

    def __init__(self, root: str | Path, calibration: Calibration, fps: float, description: str) -> None:
        started = datetime.datetime.now(datetime.UTC)
        notes = (f"Recorded by `mast-stereo run --record` from {description}, starting "
                 f"{started.isoformat(timespec='seconds')} UTC: the pairs the daemon processed. t_ns, "
                 "t_left_ns and t_right_ns are relative to the first pair; `recorded` gives its own stamp.")
        meta = build_meta(calibration, fps, notes, recorded={"source": description, "by": "run --record",
                                                             "started_utc": started.isoformat()})
        self.files = RecordingWriter(root, meta)  # OSError here: the daemon refuses to start (exit 73)
        width, height = int(meta["width"]), int(meta["height"])
        self.writer = PairWriter(self.files, queue_capacity(width, height), block=False)
        self.offered = 0
        self.failures = 0
        self.fault: str | None = None
        self.t0_ns: int | None = None
        self.t0_utc_ns: int | None = None
        self._closed = False

    def offer(self, pair: FramePair) -> None:
        """Queue one processed pair (dropped-oldest if the writer is behind); nothing once failed."""
        if self.fault is not None or self._closed:
            return
        if self.t0_ns is None:
            self.t0_ns, self.t0_utc_ns = pair.t_ns, utc_anchor_ns(pair)
        if self.writer.put(rebased(pair, self.t0_ns)):
            self.offered += 1
        self._check()

    def _check(self) -> None:
        if self.fault is None and self.writer.error is not None:
            self.failures += 1
            self.fault = f"stopped, write failed: {self.writer.error}"

    def beat(self, health: HealthMonitor) -> None:
        """The recording stage's heartbeat: its fault once writing failed, and its counters."""
        self._check()
        health.beat(STAGE, fault=self.fault, counters=self.counters)

    @property
    def counters(self) -> dict[str, int]:
        w = self.writer
        return {"offered": self.offered, "written": w.written, "dropped_by_writer": w.dropped,
                "abandoned": w.abandoned, "write_failures": self.failures}

    def close(self) -> None:
        """Write what is queued (unless writing failed), note the counters in meta.yaml, close."""
        if self._closed:
            return
        self._closed = True
        self.writer.finish()
        self._check()
        summary = {**self.counters, "t0_ns": self.t0_ns, "t0_utc_ns": self.t0_utc_ns,
                   "stopped": self.fault or "daemon stopped",
                   "ended_utc": datetime.datetime.now(datetime.UTC).isoformat()}
        if not self.files.update_meta(recorded={**self.files.meta["recorded"], **summary}):
            log.warning("recording %s: meta.yaml could not be updated (disk full?)", self.files.root)
        self.files.close()
