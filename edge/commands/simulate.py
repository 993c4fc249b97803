"""`mast-stereo simulate SCENARIO --out RECORDING`: render a scenario to a recording with ground truth.

SCENARIO is a name in config/scenarios (e.g. akashi-crossing) or a path to a
scenario YAML. The same seed gives a byte-identical recording; frames are
rendered in parallel on every core (`--jobs`). A bad scenario is a
configuration error (exit 78, naming the file and key).
"""

from __future__ import annotations

import argparse
import sys
import time

from edge.errors import EX_CONFIG
from edge.sim.render_recording import ProgressBar, default_jobs, write_recording
from edge.sim.scenario import load_scenario
from edge.sim.simulator import Simulation

EX_CANTCREAT = 73  # sysexits: cannot create the output


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "scenario", metavar="SCENARIO", help="scenario name in config/scenarios or a YAML path"
    )
    parser.add_argument("--out", required=True, metavar="RECORDING", help="recording directory to create")
    parser.add_argument("--seed", type=int, default=0, help="noise/jitter/glint seed (default 0)")
    parser.add_argument("--frames", type=int, default=None, metavar="N", help="only the first N triggers")
    parser.add_argument(
        "--jobs",
        type=int,
        default=default_jobs(),
        metavar="N",
        help="worker processes (default: the available cores)",
    )
    parser.add_argument("--force", action="store_true", help="replace an existing recording")


def run(args: argparse.Namespace) -> int:
    if args.frames is not None and args.frames < 1:
        print("mast-stereo simulate: --frames must be at least 1", file=sys.stderr)
        return EX_CONFIG
    start = time.monotonic()
    scenario = load_scenario(args.scenario)
    sim = Simulation(scenario, seed=args.seed)
    try:
        written = write_recording(
            sim,
            args.out,
            frames=args.frames,
            jobs=max(1, args.jobs),
            overwrite=args.force,
            progress=ProgressBar(scenario.name),
        )
    except (FileExistsError, OSError) as exc:
        print(f"mast-stereo simulate: {exc}", file=sys.stderr)
        return EX_CANTCREAT
    print(
        f"{args.out}: {written} pairs of {scenario.name} ({scenario.calibration.rig.width}x"
        f"{scenario.calibration.rig.height}, seed {args.seed}) in {time.monotonic() - start:.1f} s",
        file=sys.stderr,
    )
    return 0
