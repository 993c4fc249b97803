"""`mast-stereo record --config FILE --out RECORDING (--seconds N | --frames N) [--force]`.

Captures pairs from the configured cameras into a recording (docs/recordings.md) that `mast-stereo replay`
reads. The configuration is loaded and the source planned exactly as the daemon does
(`plan_source`), so a bad configuration exits 78 before any device opens or any file is written.
The capture and the writing are edge/recording/capture.py's: PNGs on a writer thread, every pair all or
nothing on disk, the recording clock starting at 0, the cameras' sequence numbers kept.

Exit status (the recording replays up to its last complete pair in every case but 73 and 78):

- 0: done (`--frames` or `--seconds` reached, or the source ended, e.g. a recording without loop);
- 130 / 143: stopped by SIGINT / SIGTERM (a second signal kills at once; the files stay consistent);
- 74 (EX_IOERR): writing failed, e.g. the disk is full (ENOSPC);
- 69 (EX_UNAVAILABLE): the cameras could not be opened or failed while recording (a read that
  merely times out, e.g. a camera unplugged, is counted and retried as the daemon does);
- 73 (EX_CANTCREAT): RECORDING exists (replace a recording with `--force`) or cannot be created;
- 78 (EX_CONFIG): a bad configuration, or cameras whose frame size is not the calibration's.
"""

from __future__ import annotations

import argparse
import datetime
import signal
import sys
import threading
from pathlib import Path
from types import FrameType

from edge.appliance.sources import plan_source
from edge.config.app import load_config
from edge.errors import EX_CONFIG
from edge.recording.capture import SIGNALLED, SOURCE_FAILED, WRITE_FAILED, WRONG_SIZE, record
from edge.recording.format import RecordingWriter, build_meta
from edge.sim.render_recording import ProgressBar

EX_UNAVAILABLE, EX_CANTCREAT, EX_IOERR = 69, 73, 74
PROG = "mast-stereo record"


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError("must be at least 1")
    return value


def _positive_float(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError("must be positive")
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", required=True, metavar="FILE", help="appliance configuration")
    parser.add_argument("--out", required=True, metavar="RECORDING", help="recording directory to create")
    limit = parser.add_mutually_exclusive_group(required=True)
    limit.add_argument("--seconds", type=_positive_float, metavar="N", help="record N s (wall clock)")
    limit.add_argument("--frames", type=_positive_int, metavar="N", help="record N captured pairs")
    parser.add_argument("--force", action="store_true", help="replace an existing recording")


def _utc(t_ns: int) -> str:
    return datetime.datetime.fromtimestamp(t_ns / 1e9, datetime.UTC).isoformat(timespec="milliseconds")


def run(args: argparse.Namespace) -> int:
    config = load_config(args.config)
    plan = plan_source(config, args.config)  # ConfigError -> exit 78, nothing opened or written yet
    started = datetime.datetime.now(datetime.UTC)
    notes = (f"Recorded by `mast-stereo record` from {plan.description} (configuration "
             f"{Path(args.config).resolve()}), starting {started.isoformat(timespec='seconds')} UTC. "
             "t_ns, t_left_ns and t_right_ns are relative to the first pair; `recorded` gives its "
             "own stamp and UTC instant.")
    meta = build_meta(plan.calibration, plan.fps, notes,
                      recorded={"source": plan.description, "config": str(Path(args.config).resolve()),
                                "started_utc": started.isoformat(timespec="milliseconds"),
                                "monotonic_stamps": plan.monotonic_stamps})
    try:
        files = RecordingWriter(args.out, meta, overwrite=args.force)
    except OSError as exc:  # FileExistsError included
        print(f"{PROG}: {exc}", file=sys.stderr)
        return EX_CANTCREAT
    try:
        source = plan.open()
    except (OSError, ValueError) as exc:
        files.close()
        print(f"{PROG}: cannot open the cameras ({plan.description}): {exc}", file=sys.stderr)
        return EX_UNAVAILABLE
    stop = threading.Event()
    signalled: list[int] = []

    def on_signal(signum: int, frame: FrameType | None) -> None:
        signalled.append(signum)
        stop.set()
        signal.signal(signum, signal.SIG_DFL)  # a second one ends the process at once

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    bar = ProgressBar(Path(args.out).name)

    drawn_full = [False]  # the bar ends its line itself at done == total, once; else we end it below

    def progress(done: int, total: int) -> None:
        if not drawn_full[0]:
            bar(done, total)
            drawn_full[0] = done >= total

    try:
        with source:
            result = record(source, files, live=plan.monotonic_stamps, frames=args.frames,
                            seconds=args.seconds, stop=stop, progress=progress)
        ended = datetime.datetime.now(datetime.UTC).isoformat(timespec="milliseconds")
        files.update_meta(recorded={**meta["recorded"], **result.summary(), "ended_utc": ended})
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        files.close()
    if bar.enabled and not drawn_full[0]:
        bar.stream.write("\n")
    for line in result.lines():
        print(f"{PROG}: {args.out}: {line}", file=sys.stderr)
    if result.t0_utc_ns is not None:
        print(f"{PROG}: {args.out}: first pair at {_utc(result.t0_utc_ns)} UTC", file=sys.stderr)
    if result.reason == WRITE_FAILED:
        if not isinstance(result.error, OSError):
            raise RuntimeError("the recording writer failed") from result.error
        return EX_IOERR
    if result.reason == SOURCE_FAILED:
        return EX_UNAVAILABLE
    if result.reason == WRONG_SIZE:
        return EX_CONFIG
    if result.reason == SIGNALLED and signalled:
        return 128 + signalled[0]
    return 0
