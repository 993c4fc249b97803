"""Render a scenario at another image width, same field of view: e.g. approach-2048 at 720 px.

    .venv/bin/python tools/render-variant SCENARIO --width 720 --out DIR [--frames N] [--seed N]

The scenario's calibration is scaled by width / original width: pinhole fx, fy, cx, cy
(pixel centres kept: c' = (c + 0.5) s - 0.5), distortion unchanged (it acts on normalised
coordinates); poly10 coefficients of degree k divided by s^k. The height scales with the
width; ships, sea and weather are untouched, so the same scene is seen by a coarser camera.
The recording's meta.yaml names the variant (scenario: NAME@WIDTH) for tools/evaluate.
"""

from __future__ import annotations

import argparse
import copy
import sys
from pathlib import Path

from edge.config.schema import load_yaml
from edge.sim.render_recording import default_jobs, write_recording
from edge.sim.scenario import scenario_from_dict, scenario_path
from edge.sim.simulator import Simulation

POLY_DEGREES = (1, 1, 2, 3, 3, 1, 1, 2, 3, 3)  # a0..a9 of eq. 3.5


def scale_camera(cam: dict, s: float) -> dict:
    out = dict(cam)
    out["cx"], out["cy"] = (cam["cx"] + 0.5) * s - 0.5, (cam["cy"] + 0.5) * s - 0.5
    if cam["model"] == "pinhole":
        out["fx"], out["fy"] = cam["fx"] * s, cam["fy"] * s
    else:
        out["coeffs"] = [a / s**k for a, k in zip(cam["coeffs"], POLY_DEGREES, strict=True)]
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario")
    parser.add_argument("--width", type=int, required=True)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--frames", type=int)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    path = scenario_path(args.scenario)
    data = copy.deepcopy(load_yaml(path))
    cal = data["calibration"]
    if isinstance(cal, str):
        cal = load_yaml((path.parent / cal).resolve())
    s = args.width / cal["image"]["width"]
    cal["image"] = {"width": args.width, "height": round(cal["image"]["height"] * s)}
    cal["cameras"] = {side: scale_camera(c, s) for side, c in cal["cameras"].items()}
    data["calibration"] = cal
    name = f"{path.stem}@{args.width}"
    sim = Simulation(scenario_from_dict(data, path, name), seed=args.seed)
    write_recording(sim, args.out, frames=args.frames, jobs=default_jobs(), overwrite=True)
    print(f"{args.out}: {name}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
