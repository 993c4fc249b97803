"""median() equals numpy's, line_fit() polyfit's, slope_sigma() the regression standard error."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import linregress

from edge.core.linefit import line_fit, median, slope_sigma


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


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 50), st.floats(-100, 100)), min_size=3, max_size=12,
                unique_by=lambda p: p[0]), st.floats(0.0, 2.0))
def test_slope_sigma_is_the_regression_standard_error(points: list[tuple[int, float]], floor: float) -> None:
    """Against scipy's linregress: the slope's standard error from the residual scatter, or from
    `floor` where the points scatter less than it."""
    points.sort()
    t = np.array([p[0] for p in points], float)
    y = np.array([p[1] for p in points])
    intercept, slope = line_fit(points)
    reference = linregress(t, y).stderr
    stt = float(((t - t.mean()) ** 2).sum())
    expected = max(reference, floor / math.sqrt(stt))
    assert slope_sigma(points, intercept, slope, floor) == pytest.approx(expected, rel=1e-6, abs=1e-6)


def test_slope_sigma_is_unknown_below_three_points() -> None:
    assert math.isinf(slope_sigma([(0, 1.0), (1, 2.0)], 2.0, 1.0, 0.05))
