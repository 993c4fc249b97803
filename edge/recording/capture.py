"""Recording the configured cameras into a recording directory (docs/recordings.md), safely on a full disk.

`mast-stereo record` (edge/commands/record.py) plans the source exactly as the daemon does and
calls `record()`: the capture loop (the caller's thread) reads pairs and hands them to a bounded
queue; one writer thread encodes the PNGs and appends frames.csv, so a slow disk never holds up
the cameras.

On disk every pair is all or nothing: each PNG is written under a `.part` name and renamed, and
its frames.csv row is appended only once both PNGs are complete (a row cut short by a full disk
is truncated away again). Whatever stops the recording (the limit, a signal, ENOSPC, even a
kill), the directory replays up to the last complete pair.

Timestamps: `t_ns`, `t_left_ns` and `t_right_ns` are relative to the first pair's `t_ns`, so the
recording clock starts at 0 like a simulated one and the trigger skew survives; the first pair's
absolute stamp (CLOCK_MONOTONIC for live cameras) and its UTC instant go into meta.yaml's
`recorded` block. Sequence numbers are the cameras' own, so any pair lost on the way, by the
cameras or by us, shows in frames.csv as a jump that replay counts as dropped.

Queue policy: a live source (`monotonic_stamps`) cannot be paused, so when the writer falls
behind the *oldest* queued pair is dropped and counted (`dropped_by_writer`, also in meta.yaml).
Drop-oldest rather than drop-newest because the newest pair then always reaches the disk, and
the first pair is never dropped (the capture loop waits until the writer holds it): every loss
sits between two written pairs and shows as a sequence gap (dropping the incoming pair hid a
loss at the end of a recording: measured, 56 of 60 pairs lost with no gap to see). A recording
or an unpaced simulator can wait, so for those the capture loop blocks and nothing is lost.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from drivers.camera.base import FramePair, FramePairSource
from edge.recording.format import RecordingWriter

log = logging.getLogger(__name__)

QUEUE_BYTES = 128 * 1024 * 1024  # images held for the writer at most (grey pairs), 4..64 pairs

# why the recording stopped
DONE_FRAMES, DONE_SECONDS, SOURCE_ENDED = "frames", "seconds", "source ended"
SIGNALLED, WRITE_FAILED, SOURCE_FAILED, WRONG_SIZE = "signal", "write failed", "source failed", "wrong size"


def queue_capacity(width: int, height: int) -> int:
    """Pairs the writer queue holds: QUEUE_BYTES of grey pairs, at least 4, at most 64."""
    return max(4, min(64, QUEUE_BYTES // max(2 * width * height, 1)))


def utc_anchor_ns(pair: FramePair) -> int:
    """The wall-clock time of a recording's first pair: its own UTC stamp, or now."""
    return pair.t_utc_ns if pair.t_utc_ns is not None else time.time_ns()


def rebased(pair: FramePair, t0_ns: int) -> FramePair:
    """The pair with its stamps counted from the recording's first pair (frames.csv's clock)."""
    return replace(pair, t_ns=pair.t_ns - t0_ns, t_left_ns=pair.t_left_ns - t0_ns,
                   t_right_ns=pair.t_right_ns - t0_ns)


class PairWriter:
    """The writer thread and its bounded queue (policy in the module docstring)."""

    def __init__(self, files: RecordingWriter, capacity: int, block: bool) -> None:
        self.files, self.block = files, block
        self._queue: queue.Queue[FramePair | None] = queue.Queue(capacity)
        self.written = 0  # pairs complete on disk (= the next index)
        self.dropped = 0  # queued pairs thrown away for newer ones (live sources only)
        self.abandoned = 0  # pairs queued when writing failed, never written
        self.error: BaseException | None = None
        self._took_first = threading.Event()
        self._thread = threading.Thread(target=self._run, name="record-writer", daemon=True)
        self._thread.start()

    def put(self, pair: FramePair) -> bool:
        """Queue a pair; False once writing has failed (the caller stops)."""
        if self.error is not None:
            return False
        while not self.block:
            try:
                self._queue.put_nowait(pair)
                if not self._took_first.is_set():  # the first pair is never dropped: losses stay between
                    while not self._took_first.wait(0.1) and self.error is None:  # two written pairs
                        pass
                return True
            except queue.Full:
                try:
                    self._queue.get_nowait()  # only this thread puts, so it is a pair, never the end mark
                    self.dropped += 1
                except queue.Empty:  # the writer took it meanwhile
                    pass
        while self.error is None:
            try:
                self._queue.put(pair, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def finish(self) -> None:
        """Write what is queued (unless writing failed), then stop the thread."""
        self._queue.put(None)  # the thread keeps draining after a failure, so this never blocks for long
        self._thread.join()

    def _run(self) -> None:
        while (pair := self._queue.get()) is not None:
            self._took_first.set()
            if self.error is not None:
                self.abandoned += 1
                continue
            try:
                self.files.add(self.written, pair)
                self.written += 1
            except BaseException as exc:  # reported by the capture side; the thread must not die silently
                self.error = exc


@dataclass
class RecordResult:
    """What `record` did and why it stopped."""

    reason: str = SOURCE_ENDED
    captured: int = 0  # pairs read from the source
    written: int = 0
    dropped_by_writer: int = 0
    dropped_by_source: int = 0
    skipped_by_source: int = 0
    abandoned: int = 0
    read_timeouts: int = 0  # reads that timed out (TimeoutError) and were retried
    elapsed_s: float = 0.0
    t0_ns: int | None = None  # the first pair's own timestamp (CLOCK_MONOTONIC when live)
    t0_utc_ns: int | None = None
    error: BaseException | None = field(default=None, repr=False)

    def lines(self) -> list[str]:
        rate = self.written / self.elapsed_s if self.elapsed_s > 0 else 0.0
        text = [f"{self.written} pairs written ({rate:.1f} pairs/s over {self.elapsed_s:.1f} s), "
                f"stopped: {self.reason}",
                f"captured {self.captured}; dropped by the writer {self.dropped_by_writer}, by the source "
                f"{self.dropped_by_source}; skipped by the source {self.skipped_by_source}; read time-outs "
                f"{self.read_timeouts}"]
        if self.abandoned:
            text.append(f"{self.abandoned} captured pairs were not written after the failure")
        if self.error is not None:
            text.append(f"error: {self.error}")
        return text

    def summary(self) -> dict:
        """The counters for meta.yaml's `recorded` block."""
        return {"pairs": self.written, "captured": self.captured, "dropped_by_writer": self.dropped_by_writer,
                "dropped_by_source": self.dropped_by_source, "skipped_by_source": self.skipped_by_source,
                "read_timeouts": self.read_timeouts, "stopped": self.reason, "t0_ns": self.t0_ns,
                "t0_utc_ns": self.t0_utc_ns}


def record(
    source: FramePairSource,
    files: RecordingWriter,
    *,
    live: bool,
    frames: int | None = None,
    seconds: float | None = None,
    stop: threading.Event | None = None,
    progress: Callable[[int, int], None] | None = None,
    clock: Callable[[], float] = time.monotonic,
) -> RecordResult:
    """Capture until `frames` pairs, `seconds` of wall time, the source's end, `stop`, or a failure.

    Stops are checked before each read, so a stop takes effect within one frame period (or one
    read time-out). A read that times out (TimeoutError, e.g. a camera unplugged) is counted and
    retried, as the daemon does; any other source exception stops the recording (SOURCE_FAILED)
    rather than propagate: what was captured is still written. `progress(done, total)` gets the
    pairs captured against the expected total.
    """
    width, height = int(files.meta["width"]), int(files.meta["height"])
    fps = float(files.meta.get("fps") or 0.0)
    total = frames if frames is not None else max(1, round((seconds or 0.0) * fps))
    writer = PairWriter(files, queue_capacity(width, height), block=not live)
    result = RecordResult()
    start = clock()
    try:
        while True:
            if stop is not None and stop.is_set():
                result.reason = SIGNALLED
                break
            if seconds is not None and clock() - start >= seconds:
                result.reason = DONE_SECONDS
                break
            try:
                pair = source.read()
            except TimeoutError as exc:  # no pair in time (a camera away): the daemon's policy, keep trying
                result.read_timeouts += 1
                log.warning("no pair from the cameras in time (%s); still trying", exc)
                continue
            except Exception as exc:  # a camera failing for good mid-recording: keep what we have
                result.reason, result.error = SOURCE_FAILED, exc
                break
            if pair is None:
                result.reason = SOURCE_ENDED
                break
            if pair.left.shape[:2] != (height, width) or pair.right.shape[:2] != (height, width):
                result.reason = WRONG_SIZE
                result.error = ValueError(f"the cameras deliver {pair.left.shape[1]}x{pair.left.shape[0]} "
                                          f"and {pair.right.shape[1]}x{pair.right.shape[0]}, the "
                                          f"calibration is for {width}x{height}")
                break
            if result.t0_ns is None:
                result.t0_ns, result.t0_utc_ns = pair.t_ns, utc_anchor_ns(pair)
            if not writer.put(rebased(pair, result.t0_ns)):
                break
            result.captured += 1
            if progress is not None:
                progress(min(result.captured, total), total)
            if frames is not None and result.captured >= frames:
                result.reason = DONE_FRAMES
                break
    finally:
        writer.finish()
        result.elapsed_s = clock() - start
        result.written, result.dropped_by_writer, result.abandoned = (
            writer.written, writer.dropped, writer.abandoned)
        result.dropped_by_source, result.skipped_by_source = source.dropped, source.skipped
        if writer.error is not None:
            result.reason, result.error = WRITE_FAILED, writer.error
    return result
