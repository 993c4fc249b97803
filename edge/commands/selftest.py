"""`mast-stereo selftest [--config FILE] [--json]`: the technician's checks (edge.appliance.selftest).

Prints a PASS/FAIL/WARN/SKIP table with a hint under each failure or warning (or JSON with
--json); the exit status is the number of failed checks (a WARN is not one). A broken
configuration is a failed check here, not exit 78: the technician wants the whole table.
"""

from __future__ import annotations

import argparse
import sys

from edge.appliance.selftest import FAIL, Selftest, as_json, report

DEFAULT_CONFIG = "/etc/mast-stereo/config.yaml"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", default=DEFAULT_CONFIG, metavar="FILE",
                        help=f"appliance configuration (default {DEFAULT_CONFIG})")
    parser.add_argument("--json", action="store_true", help="machine-readable output")


def run(args: argparse.Namespace) -> int:
    checks = Selftest(args.config).run()
    sys.stdout.write((as_json(checks) if args.json else report(checks)) + "\n")
    return sum(c.result == FAIL for c in checks)
