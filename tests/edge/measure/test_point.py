"""TrackPoint on synthetic stereo pairs with known motion and disparity."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import band_texture, shifted_u8

from edge.core.camera import PinholeCamera, StereoRig
from edge.core.rectify import Rectifier
from edge.core.shipmotion import MAX_SHIP_ACCEL_MPS2
from edge.measure.filter_designs import Designs
from edge.measure.point import FOLLOW_GATE_PX, TrackPoint
from edge.measure.settings import PointSettings

W, H = 320, 160


def _rig() -> StereoRig:
    cam = PinholeCamera(900.0, 900.0, (W - 1) / 2, (H - 1) / 2)
    return StereoRig(8.0, W, H, cam, cam)


def test_point_follows_a_moving_ship_and_measures_its_disparity() -> None:
    """A textured 'hull' at disparity 12.4 px (Z = f B / d) moving 0.6 px/frame right."""
    rect = Rectifier(_rig())
    tex = band_texture(11, H, W + 40)
    d_true, speed = 12.4, 0.6
    settings_ = PointSettings(fps=10.0, window=15, max_disparity=40, baseline_m=8.0, focal_px=900.0)
    point = TrackPoint(150.0, 80.0, settings_, Designs(settings_))
    for k in range(40):
        left = shifted_u8(tex, speed * k)[:, 20:W + 20]
        right = shifted_u8(tex, speed * k - d_true)[:, 20:W + 20]
        rng = np.random.default_rng(k)
        left = np.clip(left + rng.normal(0, 1, left.shape), 0, 255).astype(np.uint8)
        right = np.clip(right + rng.normal(0, 1, right.shape), 0, 255).astype(np.uint8)
        assert point.step(left, right, rect)
    assert not point.searching
    assert point.u == pytest.approx(150.0 + speed * 39, abs=0.3)  # followed the texture
    assert point.v == pytest.approx(80.0, abs=0.3)
    assert point.disparity == pytest.approx(d_true, abs=0.05)
    assert point.u_rate_pxps == pytest.approx(speed * 10.0, abs=0.5)
    assert point.sigma_px < 0.1 and math.isfinite(point.sigma_px)


def test_point_refuses_a_jump_to_another_range_and_searches() -> None:
    """After 20 frames at d = 10, the right image suddenly says d = 16 (a ship in front): the filter
    refuses it, the point turns to searching instead of adopting the other range."""
    rect = Rectifier(_rig())
    tex = band_texture(12, H, W + 40)
    settings_ = PointSettings(fps=10.0, window=15, max_disparity=40, baseline_m=8.0, focal_px=900.0)
    point = TrackPoint(150.0, 80.0, settings_, Designs(settings_))
    left = shifted_u8(tex, 0.0)[:, 20:W + 20]
    for k in range(30):
        d = 10.0 if k < 20 else 16.0
        right = shifted_u8(tex, -d)[:, 20:W + 20]
        point.step(left, right, rect, candidates=lambda: [])
    assert point.searching
    assert point.predicted_disparity() == pytest.approx(10.0, abs=0.1)


@pytest.mark.parametrize("box_error_px", [-3.0, 0.0, 3.0])
def test_a_newborn_at_1_fps_follows_where_the_box_went(box_error_px: float) -> None:
    """At 1 fps a ship crosses 25 px per pair, far beyond the +-4 px search around a newborn's zero
    motion: told the box's step (off by up to 3 px, inside the search radius) the point follows the
    texture until its own line gives the motion; without it the first follow misses the texture
    (it fails, or locks onto other texture within the radius)."""
    rect = Rectifier(_rig())
    tex = band_texture(13, H, W + 240)
    d_true, step = 12.0, 25.0
    settings_ = PointSettings(fps=1.0, window=15, max_disparity=40, baseline_m=8.0, focal_px=900.0)
    guided = TrackPoint(60.0, 80.0, settings_, Designs(settings_))
    alone = TrackPoint(60.0, 80.0, settings_, Designs(settings_))
    for k in range(7):
        left = shifted_u8(tex, step * k)[:, 20:W + 20]
        right = shifted_u8(tex, step * k - d_true)[:, 20:W + 20]
        if k:
            guided.box_step_px = step + box_error_px
            alone.box_step_px = None
        assert guided.step(left, right, rect)
        alone.step(left, right, rect)
        assert guided.u == pytest.approx(60.0 + step * k, abs=0.3)  # on the same texture every pair
        assert guided.followed or k == 0
        if k == 1:
            assert abs(alone.u - (60.0 + step)) > 4.0
    assert guided.moved and guided.u_rate_pxps == pytest.approx(step, abs=0.5)  # its own motion now
    assert guided.disparity == pytest.approx(d_true, abs=0.1)


def test_a_ship_accelerating_at_the_bound_is_followed_at_1_fps_without_a_search() -> None:
    """At 1 fps the column line's step lags a ship accelerating at MAX_SHIP_ACCEL_MPS2 across the
    view by pixels (1.5 a_img T^2 for three follows, a_img = d a / L_B): no jump to another object."""
    rect = Rectifier(_rig())
    d_true = 24.0
    a_img = d_true * MAX_SHIP_ACCEL_MPS2 / 8.0  # px/s^2
    tex = band_texture(14, H, W + 240)
    settings_ = PointSettings(fps=1.0, window=15, max_disparity=60, baseline_m=8.0, focal_px=900.0)
    point = TrackPoint(60.0, 80.0, settings_, Designs(settings_))
    for k in range(9):
        shift = 10.0 * k + 0.5 * a_img * k * k
        if 0 < k < 3:  # a newborn is told its box's step until its own line has three follows
            point.box_step_px = shift - (10.0 * (k - 1) + 0.5 * a_img * (k - 1) ** 2)
        left = shifted_u8(tex, shift)[:, 20:W + 20]
        right = shifted_u8(tex, shift - d_true)[:, 20:W + 20]
        assert point.step(left, right, rect, candidates=lambda: [])
        assert not point.searching
        assert point.u == pytest.approx(60.0 + shift, abs=0.3)
    assert 1.5 * a_img > FOLLOW_GATE_PX  # the lag the gate allows for is more than its fixed part
