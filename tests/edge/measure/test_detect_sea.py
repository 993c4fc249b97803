"""Detection on synthetic seas: the sea's own texture and a tilted horizon give no blobs, a hull on
them still does; the levelling and row-median helpers against plain references."""

from __future__ import annotations

import math

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.camera import PinholeCamera, StereoRig
from edge.core.rectify import Rectifier
from edge.measure.detect import Detector, _row_median

WIDTH, HEIGHT, F_PX = 720, 480, 900.0


def _detector(roll_deg: float = 0.0) -> Detector:
    cam = PinholeCamera(F_PX, F_PX, 359.5, 239.5, rotation_deg=(0.0, 0.0, roll_deg))
    return Detector(Rectifier(StereoRig(8.0, WIDTH, HEIGHT, cam, cam)), 25.0, decimation=2, min_ship_px=20)


def _scene(det: Detector, rng: np.random.Generator, wave_dn_per_row: float = 0.0,
           haze_dn: float = 0.0, sky_dn: float = 180.0) -> np.ndarray:
    """Sky over a sea that darkens away from the horizon (the haze just below it), with wave bands
    long along the horizon whose contrast grows with the rows below it (nearer sea, larger waves),
    and 1.5 DN sensor noise; rows follow the detector's predicted horizon, column by column."""
    rows = np.arange(HEIGHT, dtype=np.float64)[:, None] - det.horizon_raw[None, :]
    below = np.clip(rows, 0.0, None)
    image = np.where(rows < 0, sky_dn, 100.0 + haze_dn * np.exp(-below / 6.0))
    bands = cv2.GaussianBlur(rng.normal(0.0, 1.0, (HEIGHT, WIDTH)), (0, 0), sigmaX=25.0, sigmaY=1.5)
    bands /= bands.std()
    image += np.where(rows < 0, 0.0, wave_dn_per_row * below * bands)
    image = cv2.GaussianBlur(image, (0, 0), 1.0)  # the lens: no edge is sharper than about a pixel
    image += rng.normal(0.0, 1.5, image.shape)
    return np.clip(np.round(image), 0, 255).astype(np.uint8)


def _with_hull(image: np.ndarray, det: Detector, x0: int, length_px: int, height_px: int) -> np.ndarray:
    """A dark hull standing on the sea, its waterline 12 rows under the horizon."""
    out = image.copy()
    bottom = int(round(det.horizon_raw[x0])) + 12
    out[bottom - height_px:bottom, x0:x0 + length_px] = 40
    return out


def test_wave_texture_growing_toward_the_camera_gives_no_blobs() -> None:
    # the sea's contrast rises smoothly with depression: the threshold must follow it row by row,
    # not step once per row band (the near edge of each band would pass as a long flat blob). The
    # sky is as bright as the far sea here, as in fog: the horizon step is the other test's subject
    rng = np.random.default_rng(1)
    det = _detector()
    for _ in range(4):
        image = _scene(det, rng, wave_dn_per_row=0.12, sky_dn=100.0)
        assert det.detect(image) == []
    hull = _with_hull(image, det, 300, 40, 10)
    found = det.detect(hull)
    assert any(b.x0 <= 305 and b.x1 >= 335 for b in found), found


def test_a_tilted_horizon_over_haze_gives_no_blobs() -> None:
    # a rolled camera tilts the horizon by ~6 rows across the image; where the haze below it
    # darkens fast, a levelling error of half a row would leave a hull-strength residual
    rng = np.random.default_rng(2)
    det = _detector(roll_deg=0.5)
    tilt = det.horizon_raw[-1] - det.horizon_raw[0]
    assert abs(tilt) > 5.0
    for _ in range(4):
        image = _scene(det, rng, haze_dn=40.0)
        assert det.detect(image) == []
    found = det.detect(_with_hull(image, det, 500, 30, 8))
    assert any(b.x0 <= 505 and b.x1 >= 525 for b in found), found


@settings(max_examples=40, deadline=None)
@given(st.integers(3, 40), st.integers(1, 60), st.integers(0, 2**31 - 1))
def test_row_median_is_numpy_median(rows: int, cols: int, seed: int) -> None:
    values = np.random.default_rng(seed).normal(0.0, 10.0, (rows, cols)).astype(np.float32)
    work = np.empty_like(values)
    np.testing.assert_allclose(_row_median(values, work), np.median(values, axis=1), rtol=0, atol=1e-5)


@settings(max_examples=30, deadline=None)
@given(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0), st.integers(0, 2**31 - 1))
def test_levelling_is_linear_interpolation_down_each_column(start: float, end: float, seed: int) -> None:
    det = _detector()
    hs, ws = HEIGHT // 2, WIDTH // 2
    small = np.random.default_rng(seed).integers(0, 256, (hs, ws)).astype(np.uint8)
    shifts = np.linspace(start, end, ws).astype(np.float32)
    flat = det._level(small, shifts, det._buffers(hs, ws))
    rows = np.arange(hs, dtype=np.float64)
    for c in range(0, ws, 37):
        ref = np.interp(np.clip(rows + shifts[c], 0, hs - 1), rows, small[:, c].astype(np.float64))
        np.testing.assert_allclose(flat[:, c], ref, rtol=0, atol=1e-3)
    whole = det._level(small, np.full(ws, 2.0, np.float32), det._buffers(hs, ws))
    assert np.array_equal(whole[:-2], small[2:].astype(np.float32))
    assert math.isclose(float(whole[-1, 0]), float(small[-1, 0]))
