"""The height test's row sigma from the calibration (issue 16, ruling 7): a surveyed rig with a small
pitch sigma confirms a far ship sooner; a calibration without standard errors keeps 0.5 px."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from edge.core.calibsigma import CameraSigma, Pointing, RigSigma
from edge.core.camera import PinholeCamera, StereoRig
from edge.core.rectify import Rectifier
from edge.measure.settings import PointSettings
from edge.measure.tracks import ROW_SIGMA_PX, TableSettings, TrackTable

W, H, F, B, HEIGHT = 720, 480, 900.0, 8.0, 25.0


def _table(pointing: Pointing | None) -> TrackTable:
    cam = PinholeCamera(F, F, (W - 1) / 2, (H - 1) / 2)
    table = TrackTable(Rectifier(StereoRig(B, W, H, cam, cam)), HEIGHT,
                       PointSettings(fps=1.0, baseline_m=B, focal_px=F), TableSettings())
    table.pointing = pointing
    return table


def _far_point(z_m: float = 3000.0, above_m: float = 4.0) -> SimpleNamespace:
    """A point standing about `above_m` over the sea at z_m (flat-sea row; the curved sea is lower)."""
    v = (H - 1) / 2 + F * (HEIGHT - above_m) / z_m
    return SimpleNamespace(u=400.0, v=v, disparity=F * B / z_m, sigma_px=0.02)


def _surveyed(pitch_deg: float) -> RigSigma:
    cam = CameraSigma((pitch_deg, 0.002, 0.01), 0.3)
    return RigSigma(cam, cam)


def test_without_standard_errors_the_row_sigma_stays_half_a_pixel() -> None:
    p = _far_point()
    for pointing in (None, Pointing(F, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), None)):
        row, col, disp = _table(pointing).calibration_sigmas_px(0.05, 0.007, p.disparity)
        assert (row, col, disp) == (ROW_SIGMA_PX, 0.0, 0.0)
    # a tilt bound alone adds to the 0.5 px
    tilted = Pointing(F, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), None, tilt_sigma_deg=0.05)
    row, _, _ = _table(tilted).calibration_sigmas_px(0.0, 0.0, p.disparity)
    assert row == pytest.approx(math.hypot(ROW_SIGMA_PX, F * math.radians(0.05)))


def test_a_small_pitch_sigma_confirms_a_far_ship_the_default_holds_back() -> None:
    p = _far_point()
    default = _table(None)
    surveyed = _table(Pointing(F, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), _surveyed(0.002), 0.0))
    h0, s0 = default.height_m(p)
    h1, s1 = surveyed.height_m(p)
    assert h0 == h1 and 4.0 < h0 < 5.0  # the same point (the curved sea lies below the flat one)
    min_h = TableSettings().min_height_m
    assert h0 < max(min_h, 3.0 * s0)  # the 0.5 px row: held by the height test
    assert h1 >= max(min_h, 3.0 * s1)  # 0.03 px of pitch: passes
    # the row term is what changed: z * row / f (0.5 px at 3 km and 900 px: 1.67 m)
    assert s0 > 3000.0 * ROW_SIGMA_PX / F > 3.0 * s1
    # and a poorly known pitch (0.1 deg ~ 1.6 px) holds it back more than the default
    rough = _table(Pointing(F, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), _surveyed(0.1), 0.0))
    assert rough.height_m(p)[1] > s0
