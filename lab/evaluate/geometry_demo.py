"""Triangulation demo on the thesis rig: a ship's bridge crossing at ~1.5 km.

Projects a known track through the example calibration (eq. 4.1's inverse),
measures the disparity at whole-pixel precision (rounded) and with random
matching errors of the thesis's sub-pixel (0.15 px) and filtered (0.11 px)
stages, and prints the range error that results next to eq. 4.5's envelope
for +-0.5 px. It exercises the geometry only; the measured chain is tools/evaluate.
Run: .venv/bin/python tools/demo-geometry
"""

from __future__ import annotations

import argparse

import numpy as np

from edge.core.camera import PinholeCamera, StereoRig
from edge.core.triangulation import epsilon, position_error

WIDTH, HEIGHT, FOV_DEG, BASELINE_M = 720, 480, 43.0, 8.14


def main(argv: list[str] | None = None) -> None:
    argparse.ArgumentParser(prog="demo-geometry", description=__doc__).parse_args(argv)
    fx = WIDTH / (2 * np.tan(np.radians(FOV_DEG / 2)))
    cam = PinholeCamera(fx=fx, fy=fx, cx=(WIDTH - 1) / 2, cy=(HEIGHT - 1) / 2)
    rig = StereoRig(BASELINE_M, WIDTH, HEIGHT, cam, cam)
    t_s = np.arange(0, 38.5, 5.5)
    bridge_m = np.stack([-150 + 7.0 * t_s, np.full_like(t_s, 20.0), 1500 + 0.5 * t_s], axis=-1)
    uv_l, uv_r = rig.project(bridge_m)
    rng = np.random.default_rng(7)
    print(f"rig: {WIDTH}x{HEIGHT} px, {FOV_DEG} deg, baseline {BASELINE_M} m, f = {fx:.1f} px")
    print(f"{'t_s':>5} {'true Z m':>9} {'disp px':>8} | {'whole-px err m':>14} {'N(0,.15px) m':>12}"
          f" {'N(0,.11px) m':>14} | {'eq.4.5 +-0.5px':>15}")
    for k in range(len(t_s)):
        d_true = uv_l[k, 0] - uv_r[k, 0]
        errs = []
        for delta_px in (np.round(d_true) - d_true, rng.normal(0, 0.15), rng.normal(0, 0.11)):
            uv_r_meas = uv_r[k] - np.array([delta_px, 0.0])
            errs.append(rig.triangulate(uv_l[k], uv_r_meas)[2] - bridge_m[k, 2])
        eps = epsilon(0.5, WIDTH, FOV_DEG)
        lo = position_error(bridge_m[k], -eps, BASELINE_M)[2]
        hi = position_error(bridge_m[k], eps, BASELINE_M)[2]
        print(f"{t_s[k]:5.1f} {bridge_m[k, 2]:9.1f} {d_true:8.3f} | {errs[0]:14.1f} {errs[1]:12.1f}"
              f" {errs[2]:14.1f} | {lo:+7.1f}/{hi:+6.1f}")


if __name__ == "__main__":
    main()
