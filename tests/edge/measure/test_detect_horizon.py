"""The detector's horizon refinement against synthetic horizons at a known row: it finds the offset
of the horizon from the calibrated prediction, and it follows a pitch error in the calibration
(tools/horizon-offset measures both on the recordings)."""

from __future__ import annotations

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.camera import PinholeCamera, StereoRig
from edge.core.rectify import Rectifier
from edge.measure.detect import HORIZON_BANDS, Detector

WIDTH, HEIGHT, F_PX, SITE_M = 720, 480, 900.0, 25.0
# A lens-blurred step, decimated by 2 and located by a three-point parabola on its Sobel gradient:
# the parabola's bias on a peak about one decimated row wide and 1.5 DN noise on a 60 DN step,
# median over 8 bands, leave a few hundredths of a row (60 random offsets and rolls: max 0.08 px,
# RMS 0.04 px); measured from the rounded prediction instead, the error was up to 0.5 px here
TOLERANCE_PX = 0.2


def _detector(pitch_deg: float = 0.0, roll_deg: float = 0.0) -> Detector:
    cam = PinholeCamera(F_PX, F_PX, 359.5, 239.5, rotation_deg=(pitch_deg, 0.0, roll_deg))
    return Detector(Rectifier(StereoRig(8.0, WIDTH, HEIGHT, cam, cam)), SITE_M, decimation=2, min_ship_px=20)


def _horizon_image(horizon_row: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Sky (180 DN) over sea (120 DN) meeting at `horizon_row` (per column, fractional: each pixel row
    holds the sky's share of its area), blurred by a 1 px lens and with 1.5 DN sensor noise."""
    top = np.arange(HEIGHT, dtype=np.float64)[:, None] - 0.5  # each row's upper edge
    sky_share = np.clip(horizon_row[None, :] - top, 0.0, 1.0)
    image = 120.0 + 60.0 * sky_share
    image = cv2.GaussianBlur(image, (0, 0), 1.0) + rng.normal(0.0, 1.5, image.shape)
    return np.clip(np.round(image), 0, 255).astype(np.uint8)


def _refined(det: Detector, image: np.ndarray) -> float:
    det.detect(image)
    assert len(det.horizon_bands_px) == HORIZON_BANDS
    return float(np.median(det.horizon_bands_px))


@settings(max_examples=25, deadline=None)
@given(st.floats(-6.0, 6.0), st.floats(-0.5, 0.5), st.integers(0, 2**31 - 1))
def test_the_refined_offset_is_the_horizons_offset_from_the_prediction(offset_px: float, roll_deg: float,
                                                                       seed: int) -> None:
    det = _detector(roll_deg=roll_deg)
    image = _horizon_image(det.horizon_raw + offset_px, np.random.default_rng(seed))
    assert abs(_refined(det, image) - offset_px) < TOLERANCE_PX


@settings(max_examples=15, deadline=None)
@given(st.floats(-0.3, 0.3), st.integers(0, 2**31 - 1))
def test_a_pitch_error_in_the_calibration_moves_the_offset_by_its_rows(error_deg: float, seed: int) -> None:
    # the horizon where the true camera sees it; the detector calibrated with a pitch error: the
    # offset it measures is the predicted horizon's shift, f tan(error) rows near the centre
    true = _detector()
    wrong = _detector(pitch_deg=error_deg)
    image = _horizon_image(true.horizon_raw, np.random.default_rng(seed))
    shift = float(np.median(true.horizon_raw - wrong.horizon_raw))
    assert abs(shift) > 0.9 * F_PX * abs(np.tan(np.radians(error_deg))) - 1e-9
    assert abs(_refined(wrong, image) - shift) < TOLERANCE_PX

