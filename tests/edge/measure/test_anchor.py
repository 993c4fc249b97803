"""reference_points(): texture in the upper part, spread out; ship_window() and spanning_width()."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import band_texture, shifted_u8
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.measure.anchor import (
    SHIP_WINDOW_MARGIN_PX,
    reference_points,
    ship_window,
    spanning_width,
)


def test_reference_points_pick_texture_in_the_upper_part_and_spread_out() -> None:
    patch = np.full((60, 100), 100, np.uint8)
    patch[12:24, 30:60] = shifted_u8(band_texture(5, 12, 30), 0.0)  # textured superstructure, top of the box
    patch[40:50, 10:90] = 60  # flat dark hull below
    pts = reference_points(patch, (10, 10, 90, 50), (0, 0), 9, count=4)
    assert 30 <= pts[0][0] < 60 and 12 <= pts[0][1] < 24
    assert all(10 <= v < 10 + 0.6 * 40 + 1 for _, v in pts)  # only the upper 60 % of the box
    for i, a in enumerate(pts):
        for b in pts[i + 1:]:
            assert max(abs(a[0] - b[0]), abs(a[1] - b[1])) > 4  # at least half a window apart


def _scene(box_w: int, sea_dn: float, seed: int) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    """A dark ship (vertical texture) on a background of `sea_dn` RMS noise; window margin 15."""
    rng = np.random.default_rng(seed)
    image = 150.0 + sea_dn * rng.standard_normal((100, 120))
    box = (40, 40, 40 + box_w, 52)
    image[40:52, 40:40 + box_w] = 80.0 + 20.0 * (np.arange(box_w) % 3 == 0)
    return np.clip(image, 0, 255).astype(np.uint8), box


@pytest.mark.parametrize("box_w", [8, 12, 16, 22, 28])
def test_ship_window_spans_a_small_ship_on_a_quiet_background(box_w: int) -> None:
    image, box = _scene(box_w, 0.5, box_w)
    w = ship_window(image, (0, 0), box, 15)
    assert w % 2 == 1 and 15 <= w <= 29
    if box_w + SHIP_WINDOW_MARGIN_PX > 15:
        assert w >= min(box_w + SHIP_WINDOW_MARGIN_PX, 29)  # both outlines and a margin inside
    else:
        assert w == 15


@pytest.mark.parametrize("box_w", [12, 22])
def test_ship_window_keeps_the_window_on_a_textured_sea(box_w: int) -> None:
    image, box = _scene(box_w, 25.0, box_w)
    assert ship_window(image, (0, 0), box, 15) == 15


def test_ship_window_keeps_the_window_for_a_big_ship() -> None:
    image = np.full((120, 160), 150, np.uint8)
    image[40:52, 20:130] = 80
    assert ship_window(image, (0, 0), (20, 40, 130, 52), 15) == 15


@settings(max_examples=60, deadline=None)
@given(st.floats(1.0, 80.0), st.sampled_from([9, 15, 21]))
def test_spanning_width_is_ship_windows_side_from_the_box_alone(box_w: float, window: int) -> None:
    """An odd side holding the box and its margin (at most 2 window - 1), or the window itself for a
    ship too narrow to need more or wider than two windows; ship_window on a quiet background
    agrees whenever the box spans whole pixels."""
    w = spanning_width(box_w, window)
    if w == window:
        assert math.ceil(box_w) + SHIP_WINDOW_MARGIN_PX <= window or box_w > 2 * window
    else:
        assert w % 2 == 1 and window < w <= 2 * window - 1
        assert w >= min(math.ceil(box_w) + SHIP_WINDOW_MARGIN_PX, 2 * window - 1)
    if window == 15 and box_w == int(box_w) and box_w <= 60:
        image, box = _scene(int(box_w), 0.5, int(box_w))
        assert ship_window(image, (0, 0), box, 15) == w
