"""Horizon finder: a tilted sea horizon under clouds, with noise, found within a pixel; Theil-Sen
ignores a minority of wild points."""

from __future__ import annotations

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.horizon import find_horizon, theil_sen


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(-0.03, 0.03), st.floats(300.0, 700.0))
def test_a_tilted_horizon_under_clouds_is_found(seed: int, slope: float, y0: float) -> None:
    rng = np.random.default_rng(seed)
    h, w = 1080, 1920
    rows, cols = np.mgrid[0:h, 0:w].astype(np.float64)
    horizon = y0 + slope * cols
    img = np.where(rows < horizon, 170.0, 95.0) + 0.01 * np.clip(rows - horizon, 0, None)
    for _ in range(6):  # cloud edges: strong but short, above the horizon
        cy, cx = rng.uniform(50, y0 - 120), rng.uniform(0, w)
        img[int(cy):int(cy) + 40, int(cx):int(cx) + 200] += 40.0
    img = cv2.GaussianBlur(img, (0, 0), 1.0) + rng.normal(0.0, 2.0, img.shape)
    line = find_horizon(np.clip(img, 0, 255).astype(np.uint8))
    assert line is not None
    (x_a, y_a), (x_b, y_b) = line
    # the step sits between rows: the edge of row r - 1 and row r is at r - 0.5
    assert abs(y_a - (y0 + slope * x_a - 0.5)) < 1.0
    assert abs(y_b - (y0 + slope * x_b - 0.5)) < 1.0


def test_theil_sen_ignores_a_minority_of_wild_points() -> None:
    x = np.arange(20.0)
    y = 3.0 + 0.5 * x
    y[[2, 7, 11, 15]] += np.array([40.0, -30.0, 25.0, 60.0])
    slope, icpt = theil_sen(x, y)
    assert abs(slope - 0.5) < 1e-9 and abs(icpt - 3.0) < 1e-9


def test_a_flat_image_has_no_horizon() -> None:
    assert find_horizon(np.full((200, 300), 128, np.uint8)) is None
