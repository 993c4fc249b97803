"""`mast-stereo run --config FILE`: the daemon systemd starts (Type=notify).

Loads and checks the configuration, calibration and outputs before opening
any device (a mistake exits 78 with one line naming file and key; so does a
configuration or calibration file that others can write: edge.config.trust), then runs
`edge.appliance.daemon.Appliance` until SIGTERM/SIGINT, the end of a finite source, or
`--seconds`; SIGHUP reloads the configuration file (`systemctl reload`). READY=1,
STATUS=, WATCHDOG=1, RELOADING=1 and STOPPING=1 go to systemd when $NOTIFY_SOCKET is
set; under systemd the log goes to the journal as structured records. `--print-nmea`
also writes the NMEA sentences to stdout (the demo uses it). `--record DIR` also records the
processed pairs into a new recording directory (docs/recordings.md, what `record` writes and
`replay` reads); a write failure (a full disk) stops only the recording, shown as a fault on the
`recording` health stage; a DIR that cannot be created exits 73 before anything opens.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading

from edge.config.app import load_config
from edge.config.trust import check_config_files

EX_CANTCREAT = 73


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", required=True, metavar="FILE", help="appliance configuration (YAML)")
    parser.add_argument("--seconds", type=float, metavar="N", help="stop after N seconds (default: run)")
    parser.add_argument("--print-nmea", action="store_true", help="also write NMEA sentences to stdout")
    parser.add_argument("--record", metavar="DIR",
                        help="also record the processed pairs into this new recording directory")
    parser.add_argument("--watch", action="store_true",
                        help="show a live table of the tracks on stdout (refreshed in place on a terminal)")


def run(args: argparse.Namespace) -> int:
    check_config_files(args.config)  # a file others can change is refused (exit 78) before it is used
    config = load_config(args.config)
    # imported only now: a configuration mistake exits 78 without loading OpenCV, pymodbus and the rest
    from drivers.notify import SystemdNotifier
    from edge.appliance.console import LiveTable
    from edge.appliance.daemon import Appliance
    from edge.appliance.journal import setup_logging
    from edge.outputs.asterix import AsterixOutput
    from edge.outputs.nmea_stream import NmeaStreamOutput

    setup_logging(config.logging.level)
    extra = [NmeaStreamOutput(sys.stdout)] if args.print_nmea else []
    try:
        appliance = Appliance.build(config, args.config, SystemdNotifier(), extra_nmea=extra,
                                    record=args.record)
    except OSError as exc:  # --record DIR exists or cannot be created (ConfigError is exit 78, elsewhere)
        print(f"mast-stereo run: --record: {exc}", file=sys.stderr)
        return EX_CANTCREAT
    if args.watch:
        view = LiveTable(sys.stdout, lambda fixes: appliance.outputs.target_numbers(fixes))
        appliance.on_fixes, appliance.on_health = view.update, view.draw
    stop, reload = threading.Event(), threading.Event()
    for signum in (signal.SIGTERM, signal.SIGINT):
        signal.signal(signum, lambda *_: stop.set())
    signal.signal(signal.SIGHUP, lambda *_: reload.set())
    status = appliance.run(stop, args.seconds, reload)
    c = appliance.pipeline.counters
    logging.getLogger("mast-stereo").info(
        "stopped: %d pairs processed, %d dropped before processing, %d bad, %d failed, %d fixes",
        c.processed, appliance.queue.dropped, c.bad_input, c.failed, c.fixes)
    for out in appliance.outputs.outputs:
        if isinstance(out, AsterixOutput):  # what a VTS should have received (tools/asterix-check --live)
            _, counters = out.health()
            logging.getLogger("mast-stereo").info(
                "ASTERIX: %d records in %d data blocks, %d datagrams sent, %d dropped, %d send errors",
                out.counts["records"], out.counts["blocks"], counters["asterix_udp_datagrams"],
                counters["asterix_udp_dropped"], counters["asterix_udp_errors"])
    return status
