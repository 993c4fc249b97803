"""The fix's sigma with calibration standard errors (issue 16): eq. 4.5 along the line of sight for
the filter's and the calibration's disparity sigma in quadrature, the bearing share across it;
without standard errors exactly eq. 4.5 as before."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from edge.config.calibration import Calibration, load_calibration
from edge.core.calibsigma import CameraSigma, RigSigma
from edge.core.triangulation import position_error, triangulate_normalised
from edge.pipeline import Pipeline

ROOT = Path(__file__).resolve().parents[2]
CAL = load_calibration(ROOT / "config/calibration/akashi-pinhole.yaml")
YAW = RigSigma(CameraSigma((0.0, 0.003, 0.0), 0.0), CameraSigma((0.0, 0.003, 0.0), 0.0))


def _fix(pipe: Pipeline, u: float, v: float, d: float, sigma_d: float) -> float:
    f, b = pipe.rect.f_px, pipe.rig.baseline_m
    xy_l = pipe.rect.rect_to_normalised(np.array([[u, v]]))
    world = triangulate_normalised(xy_l, xy_l - np.array([[d / f, 0.0]]), b)
    range_m = np.hypot(world[:, 0], world[:, 2])
    return float(pipe._sigma_m(world, xy_l, np.array([d]), np.array([sigma_d]), range_m)[0])


def test_without_standard_errors_the_sigma_is_eq_4_5() -> None:
    pipe = Pipeline(CAL, fps=10.0)
    f, b = pipe.rect.f_px, pipe.rig.baseline_m
    xy_l = pipe.rect.rect_to_normalised(np.array([[500.0, 250.0]]))
    world = triangulate_normalised(xy_l, xy_l - np.array([[5.0 / f, 0.0]]), b)
    err = position_error(world, 0.02 / f, b)
    assert _fix(pipe, 500.0, 250.0, 5.0, 0.02) == math.hypot(err[0, 0], err[0, 2])


def test_yaw_standard_errors_widen_range_and_bearing_as_propagated() -> None:
    plain, surveyed = Pipeline(CAL, fps=10.0), Pipeline(Calibration(CAL.rig, CAL.site, YAW), fps=10.0)
    u, v, d, sd = 360.0, 245.0, 5.0, 0.02
    _, col, disp = (float(a[()]) for a in surveyed.pointing.sigmas(
        *surveyed.rect.rect_to_normalised(np.array([u, v])), np.array(d)))
    # both cameras' yaw: about f * rad * sqrt(2) of disparity, f * rad of column near the centre
    assert disp == pytest.approx(surveyed.rect.f_px * math.radians(0.003) * math.sqrt(2), rel=0.02)
    assert col == pytest.approx(surveyed.rect.f_px * math.radians(0.003), rel=0.02)
    z = surveyed.rect.f_px * surveyed.rig.baseline_m / d
    along_plain = _fix(plain, u, v, d, sd)
    along = _fix(plain, u, v, d, math.hypot(sd, disp))
    assert _fix(surveyed, u, v, d, sd) == pytest.approx(math.hypot(along, z * col / surveyed.rect.f_px),
                                                         rel=1e-3)
    assert _fix(surveyed, u, v, d, sd) > 2.0 * along_plain
