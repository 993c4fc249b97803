"""reference_points(): texture in the upper part, spread out; median() equals numpy's; ship_window()."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import band_texture, shifted_u8
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.anchor import SHIP_WINDOW_MARGIN_PX, line_fit, median, reference_points, ship_window


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


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1e3, 1e3), min_size=1, max_size=25))
def test_median_equals_numpy(values: list[float]) -> None:
    assert median(values) == pytest.approx(float(np.median(values)))


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 50), st.floats(-100, 100)), min_size=3, max_size=12,
                unique_by=lambda p: p[0]))
def test_line_fit_equals_polyfit(points: list[tuple[int, float]]) -> None:
    points.sort()
    t = np.array([p[0] for p in points], float) - points[-1][0]
    slope, intercept = np.polyfit(t, [p[1] for p in points], 1)
    got = line_fit(points)
    assert got[0] == pytest.approx(intercept, abs=1e-6) and got[1] == pytest.approx(slope, abs=1e-6)


@settings(max_examples=60, deadline=None)
@given(st.floats(1.0, 200.0), st.sampled_from([9, 11, 15, 21]))
def test_ship_window_spans_a_small_ship_and_keeps_the_window_for_a_big_one(box_px: float,
                                                                           window: int) -> None:
    w = ship_window(box_px, window)
    assert w % 2 == 1 and window <= w <= 2 * window - 1
    if box_px > 2 * window:
        assert w == window
    elif w < 2 * window - 1:
        assert w >= box_px + SHIP_WINDOW_MARGIN_PX  # both outlines and a margin inside
