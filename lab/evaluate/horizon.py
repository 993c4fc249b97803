"""Can the image horizon measure the camera's pitch? The detector's horizon against the calibrated one.

    .venv/bin/python tools/horizon-offset RECORDING... [--pitch-error-deg D ...]

The height test (`edge.measure.tracks.TrackTable.height_m`) charges every point a fixed row uncertainty,
ROW_SIGMA_PX, for uncalibrated camera pitch and mast tilt. The detector refines the horizon from
the image (`edge.measure.detect.Detector`: the strongest mean vertical gradient near the predicted sea
horizon in each of HORIZON_BANDS column bands, sub-row by a parabola; `horizon_bands_px` holds
each band's offset from the prediction). If that image horizon were the sea horizon, the bands'
median offset from the calibrated one would measure the pitch error and their spread an
uncertainty for it.

This replays the detector alone over each recording (every `detect_every`-th left image, as the
pipeline runs it) and prints, per recording:

  offset      per pass, the median of the band offsets (passes with at least half the bands
              found, as the detector requires), full-resolution rows: median over the passes and
              5-95 % range (positive: the image horizon is below the calibrated one)
  bands       the share of band searches that found an edge
  spread      per pass, the RMS of the band offsets about their median (what a fit residual
              would call the measurement's sigma), median over the passes
  horizon     the sea horizon's distance (the tangent point, refraction as `edge.core.geo`) and
              the scenario's atmospheric transmission to it, exp(-3.912 d / V) (Koschmieder), for
              simulator recordings whose scenario is known

With --pitch-error-deg the detector is given the recording's calibration with both cameras
pitched by D degrees (a rig calibrated with that pitch error; the images are unchanged), and
"expected" is the offset at no error plus the shift of the predicted horizon that error causes:
the offset follows a pitch error when it moves by that much.

Simulator recordings are rendered with exactly the calibration they state, so their true pitch
error is zero: any offset at D = 0 is the image horizon's own bias.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path

import numpy as np

from edge.config.app import PipelineConfig
from edge.config.calibration import Calibration, recording_calibration
from edge.core.camera import CameraModel, StereoRig
from edge.core.geo import EARTH_RADIUS_M, REFRACTION_K, horizon_dip_rad
from edge.core.rectify import Rectifier
from edge.measure.detect import HORIZON_BANDS, Detector
from edge.replay import open_recording

KOSCHMIEDER = 3.912  # ln(1 / 0.02): the visibility V is where the transmission falls to 2 %


def pitched(cal: Calibration, pitch_deg: float) -> Calibration:
    """The calibration with both cameras pitched by `pitch_deg` (added to rotation_deg[0])."""
    rig = cal.rig

    def turn(cam: CameraModel) -> CameraModel:
        rx, ry, rz = cam.rotation_deg
        return dataclasses.replace(cam, rotation_deg=(rx + pitch_deg, ry, rz))  # type: ignore[type-var]  # a dataclass

    return Calibration(StereoRig(rig.baseline_m, rig.width, rig.height, turn(rig.left), turn(rig.right)),
                       cal.site)


def detector_for(cal: Calibration, cfg: PipelineConfig) -> Detector:
    if cal.site is None:
        raise ValueError("the recording states no site (height above the sea)")
    return Detector(Rectifier(cal.rig), cal.site.height_m, decimation=cfg.detect_decimation,
                    min_ship_px=cfg.min_ship_px)


def measure(root: Path, pitch_deg: float = 0.0, cfg: PipelineConfig | None = None) -> dict:
    """Replay the detector over a recording: per detection pass, the band offsets' median and their
    RMS about it (px; nan when fewer than half the bands are found) and the bands found; and the
    predicted horizon's median shift caused by the pitch error (px)."""
    cfg = cfg or PipelineConfig()
    source = open_recording(root)
    cal = recording_calibration(root, source.meta)
    det = detector_for(pitched(cal, pitch_deg), cfg)
    shift = float(np.median(detector_for(cal, cfg).horizon_raw - det.horizon_raw))
    offsets, spreads, found = [], [], []
    with source:
        for k, pair in enumerate(source):
            if k % cfg.detect_every:
                continue
            det.detect(pair.left)
            bands = det.horizon_bands_px
            found.append(len(bands))
            enough = len(bands) >= max(2, HORIZON_BANDS // 2)
            offsets.append(float(np.median(bands)) if enough else math.nan)
            spreads.append(float(np.sqrt(np.mean((bands - np.median(bands)) ** 2))) if enough else math.nan)
    assert cal.site is not None  # detector_for refused a recording without one
    return {"offset_px": np.array(offsets), "spread_px": np.array(spreads),
            "found": np.array(found),
            "shift_px": shift, "meta": source.meta, "height_m": cal.site.height_m}


def horizon_transmission(meta: dict, height_m: float) -> tuple[float, float] | None:
    """(distance to the sea horizon km, transmission to it) from the recording's scenario, if known."""
    try:
        from edge.sim.scenario import load_scenario
        visibility_m = load_scenario(str(meta["scenario"])).spec.atmosphere.visibility_m
    except Exception:  # not a simulator recording, or its scenario is not in config/scenarios
        return None
    r_e = EARTH_RADIUS_M / (1.0 - REFRACTION_K)
    distance_m = r_e * math.tan(horizon_dip_rad(height_m))
    return distance_m / 1000.0, math.exp(-KOSCHMIEDER * distance_m / visibility_m)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("recording", type=Path, nargs="+")
    ap.add_argument("--pitch-error-deg", type=float, nargs="*", default=[],
                    help="also run with the calibration pitched by these errors (deg)")
    args = ap.parse_args(argv)
    print(f"{'recording':<20} {'pitch err':>9} {'passes':>6} {'bands':>6} {'offset px':>9} "
          f"{'5-95 %':>13} {'expected':>8} {'spread px':>9} {'horizon':>8} {'transm.':>8}")
    for root in args.recording:
        base = None
        for pitch_deg in [0.0, *args.pitch_error_deg]:
            m = measure(root, pitch_deg)
            off = m["offset_px"][np.isfinite(m["offset_px"])]
            if not off.size:
                print(f"{root.name:<20} {pitch_deg:+9.3f} {len(m['offset_px']):6d}  no horizon found")
                continue
            med = float(np.median(off))
            base = med if base is None and pitch_deg == 0.0 else base
            lo, hi = np.percentile(off, [5, 95])
            found = float(np.mean(m["found"])) / HORIZON_BANDS
            spread = m["spread_px"][np.isfinite(m["spread_px"])]
            spread_s = f"{float(np.median(spread)):9.2f}" if spread.size else f"{'-':>9}"
            hz = horizon_transmission(m["meta"], m["height_m"])
            hz_s = f"{hz[0]:6.1f}km {hz[1]:8.1e}" if hz else f"{'-':>8} {'-':>8}"
            expected = f"{base + m['shift_px']:+8.2f}" if base is not None else f"{'-':>8}"
            print(f"{root.name:<20} {pitch_deg:+9.3f} {len(m['offset_px']):6d} {found:6.0%} {med:+9.2f} "
                  f"{lo:+6.2f}..{hi:+5.2f} {expected} {spread_s} {hz_s}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
