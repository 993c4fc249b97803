"""`mast-stereo` command line: one dispatcher, one module per subcommand.

Each subcommand lives in its own module exposing ``add_arguments(parser)`` and
``run(args) -> int``; modules are imported only when their subcommand runs, so
`mast-stereo budget` does not pay for OpenCV or pymodbus. Any `ConfigError`
becomes one line on stderr and exit status 78 (EX_CONFIG), never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from edge.errors import EX_CONFIG, ConfigError

# subcommand -> (module, one-line help). Order is the order of `--help`.
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "run": ("edge.commands.run", "the appliance daemon (what systemd starts)"),
    "budget": ("edge.commands.budget", "error budget of a rig (eq. 4.5, 4.6, 3.12)"),
    "calibrate": ("edge.commands.calibrate", "fit camera models from surveyed landmarks"),
    "check-config": ("edge.commands.check_config", "load a configuration/calibration and print a summary"),
    "simulate": ("edge.commands.simulate", "render a stereo sea scene with ground truth to a recording"),
    "record": ("edge.commands.record", "capture pairs from the configured cameras into a recording"),
    "replay": ("edge.commands.replay", "run the pipeline over a recording: NMEA and a per-fix CSV"),
    "selftest": ("edge.commands.selftest", "the technician's checks: PASS/FAIL table, exit = failures"),
    "masks": ("edge.commands.masks", "draw the site masks and the horizon over a left frame (PNG)"),
}


def build_parser(chosen: str | None = None) -> argparse.ArgumentParser:
    """The parser; only the chosen subcommand's module is imported to declare its arguments."""
    parser = argparse.ArgumentParser(prog="mast-stereo", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", metavar="SUBCOMMAND", required=True)
    for name, (module_name, help_text) in SUBCOMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.set_defaults(_module=module_name)
        if name == chosen:
            importlib.import_module(module_name).add_arguments(p)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args_list = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(args_list[0] if args_list else None)
    args = parser.parse_args(args_list)
    try:
        return int(importlib.import_module(args._module).run(args) or 0)
    except ConfigError as exc:
        print(f"mast-stereo {args.command}: configuration error: {exc.message}", file=sys.stderr)
        return EX_CONFIG


if __name__ == "__main__":
    sys.exit(main())
