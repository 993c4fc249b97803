"""The soak's scene: ships that keep coming and going, rendered once at a small size and looped.

Why this shape: the simulator's ray renderer costs ~0.45 s a pair at 720x480, so 100 000 pairs
rendered live would take half a day, while the pipeline itself needs a few milliseconds. So the
soak renders one *lap* of a generated scenario with the real simulator at 360x240 (the thesis
rig scaled by one half: the same field of view, baseline and site), stores it as an ordinary
recording, and the daemon replays it with `cameras: {kind: replay, pace: false, loop: true}`:
the real capture thread, PNG decoding, pipeline and outputs, at full speed. The replay source
shifts each lap's timestamps by the lap's length, so time keeps increasing, and every lap's
ships are new ships to the tracker: new track ids, new NMEA target numbers, old ones dropped.

`soak_scenario(lap)` generates the lap: `lap.ships` ships crossing the field of view at ranges
`near_m`..`far_m`, alternately left to right and right to left, their crossings staggered so two
or three are in view at a time and the first and last seconds of the lap are empty sea (a lap
boundary then never teleports a ship the tracker still holds). Any seed gives other ships, so
the generator supports arbitrarily long runs of fresh traffic; the soak loops one lap because
each lap costs minutes of rendering.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from edge.sim.render_recording import write_recording
from edge.sim.scenario import Scenario, scenario_from_dict
from edge.sim.simulator import Simulation

FPS = 10.0
EMPTY_S = 3.0  # the lap's first and last seconds: no ship in view
COMPLETE = "complete"  # marker file of a finished rendering
HALF_FOV_TAN = 360.0 / 913.9  # tan(half the horizontal field of view) of the thesis rig
KINDS_LENGTHS_M = (("ferry", 70.0), ("coaster", 60.0), ("tug", 30.0), ("freighter", 110.0), ("boat", 25.0))
KNOT_MPS = 1852.0 / 3600.0


@dataclass(frozen=True)
class Lap:
    """One lap's shape: the soak's (60 s, 6 ships, 360x240) or the tests' short one."""

    seed: int = 0
    lap_s: float = 60.0
    ships: int = 6
    scale: float = 0.5  # of the thesis rig's 720x480
    near_m: float = 400.0
    far_m: float = 1400.0

    @property
    def name(self) -> str:
        return f"soak-lap-{self.seed}-{self.lap_s:g}s-{self.ships}-{self.scale:g}"

    @property
    def pairs(self) -> int:
        return round(self.lap_s * FPS)


SOAK_LAP = Lap()
TEST_LAP = Lap(lap_s=14.0, ships=3, scale=0.25, near_m=250.0, far_m=450.0)


def _calibration(scale: float) -> dict[str, Any]:
    """The thesis rig (config/calibration/akashi-pinhole.yaml) scaled to a smaller image."""
    width, height = round(720 * scale), round(480 * scale)

    def cam(fx: float, fy: float, dist: list[float], rot: list[float]) -> dict[str, Any]:
        return {"model": "pinhole", "fx": fx * scale, "fy": fy * scale, "cx": (width - 1) / 2,
                "cy": (height - 1) / 2, "dist": dist, "rotation_deg": rot}
    return {"baseline_m": 8.14, "image": {"width": width, "height": height},
            "cameras": {"left": cam(913.9, 914.6, [-0.085, 0.06, 0.0002, -0.0001, 0.0], [-1.5, -0.15, 0.1]),
                        "right": cam(915.1, 915.8, [-0.08, 0.05, -0.0001, 0.0002, 0.0], [-1.45, 0.1, -0.05])},
            "site": {"lat_deg": 34.63, "lon_deg": 135.02, "height_m": 25.0, "heading_deg": 180.0}}


def _ships(lap: Lap) -> list[dict[str, Any]]:
    """Ships whose crossings of the field of view tile the lap between the empty margins."""
    rng = np.random.default_rng([lap.seed, 0x50A4])
    usable_s = lap.lap_s - 2 * EMPTY_S
    ships = []
    for i in range(lap.ships):
        kind, length_m = KINDS_LENGTHS_M[i % len(KINDS_LENGTHS_M)]
        z_m = float(rng.uniform(lap.near_m, lap.far_m))
        half_m = HALF_FOV_TAN * z_m + length_m  # out of view at both ends
        crossing_s = float(rng.uniform(0.45, 0.6)) * usable_s
        enter_s = EMPTY_S + (usable_s - crossing_s) * i / max(1, lap.ships - 1)
        speed_mps = 2 * half_m / crossing_s
        sign = 1.0 if i % 2 == 0 else -1.0
        drift_m = float(rng.uniform(-60.0, 60.0))  # crossings are not all square to the view
        ships.append({
            "id": i + 1, "kind": kind, "length_m": length_m, "paint_seed": int(rng.integers(0, 50)),
            "track": {"waypoints_m": [[-sign * half_m, z_m - drift_m], [sign * half_m, z_m + drift_m]],
                      "speed_kn": [speed_mps / KNOT_MPS], "start_s": enter_s},
        })
    return ships


def soak_scenario(lap: Lap = SOAK_LAP) -> Scenario:
    """One lap of generated traffic (see the module docstring); another seed, other ships."""
    data = {
        "description": f"{lap.name}: {lap.ships} ships crossing the view",
        "calibration": _calibration(lap.scale), "fps": FPS, "duration_s": lap.lap_s,
        "atmosphere": {"visibility_m": 20000}, "sun": {"azimuth_deg": 200, "elevation_deg": 35},
        "imaging": {"psf_sigma_px": 0.6, "read_noise_dn": 1.2, "electrons_per_dn": 15.0},
        "ships": _ships(lap),
    }
    return scenario_from_dict(data, f"<{lap.name}>", name=lap.name)


def lap_recording(cache: Path, lap: Lap = SOAK_LAP, jobs: int = 1) -> Path:
    """The lap rendered to `cache`/NAME once (a `complete` marker, written last, says the
    rendering finished; an interrupted one is rendered again)."""
    out = cache / lap.name
    if not (out / COMPLETE).is_file():
        write_recording(Simulation(soak_scenario(lap), lap.seed), out, jobs=jobs, overwrite=True)
        (out / COMPLETE).write_text("rendered\n")
    return out
