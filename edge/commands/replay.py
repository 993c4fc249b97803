"""`mast-stereo replay RECORDING [--config FILE] [--nmea FILE] [--tracks FILE] [--asterix FILE]
[--asterix-send]`: run the pipeline.

NMEA sentences go to `--nmea` (default standard output, `-` too), the per-fix
CSV (the columns of docs/outputs.md) to `--tracks` when given, and a short summary with
the counts (pairs read, skipped, dropped, refused, fixes, tracks) to standard
error. `--asterix` writes the ASTERIX data blocks to a file, `--asterix-send` sends them to the
configured UDP destinations. The same recording always gives byte-identical outputs. A directory
that is not a recording, or a bad configuration, is a configuration error
(exit 78); an output file that cannot be created exits 73.
"""

from __future__ import annotations

import argparse
import contextlib
import sys

from edge.replay import replay

EX_CANTCREAT = 73  # sysexits: cannot create the output


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", metavar="RECORDING", help="recording directory (meta.yaml, frames.csv)")
    parser.add_argument("--config", metavar="FILE", help="configuration whose calibration/site/pipeline "
                        "settings override the recording's")
    parser.add_argument("--nmea", metavar="FILE", default="-", help="NMEA output file (default: stdout)")
    parser.add_argument("--tracks", metavar="FILE", help="per-fix CSV output file")
    parser.add_argument("--asterix", metavar="FILE", help="ASTERIX CAT 010 data blocks, raw, back to back "
                        "(a VTS fed offline); settings from --config's outputs.asterix")
    parser.add_argument("--asterix-send", action="store_true", help="also send them over UDP to "
                        "--config's outputs.asterix destinations (as the daemon would)")


def run(args: argparse.Namespace) -> int:
    with contextlib.ExitStack() as stack:
        try:
            nmea = sys.stdout if args.nmea == "-" else stack.enter_context(
                open(args.nmea, "w", encoding="ascii", newline=""))
            tracks = None if args.tracks is None else stack.enter_context(
                open(args.tracks, "w", encoding="ascii", newline=""))
            asterix = None if args.asterix is None else stack.enter_context(open(args.asterix, "wb"))
        except OSError as exc:
            print(f"mast-stereo replay: cannot create output: {exc}", file=sys.stderr)
            return EX_CANTCREAT
        summary = replay(args.recording, config_path=args.config, nmea=nmea, tracks=tracks, asterix=asterix,
                         asterix_send=args.asterix_send)
    for line in summary.lines():
        print(f"mast-stereo replay: {line}", file=sys.stderr)
    return 0
