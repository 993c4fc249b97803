"""Error budget: known answers from docs/method.md and the thesis, and consistency with the error model
it solves."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.budget import (
    DEFAULT_RANGES_M,
    DEFAULT_TOLERANCES_M,
    detectable_distance,
    error_budget,
    max_range,
    max_range_first_order,
    near_range,
)
from edge.core.triangulation import epsilon, range_error

THESIS = {"width_px": 720, "fov_deg": 43.0, "baseline_m": 8.14}


def test_near_range_and_detectable_distance_known_answers() -> None:
    # "usable from ~20 m": 8.14 / tan(21.5 deg) = 20.66 m
    assert near_range(8.14, 43.0) == pytest.approx(20.6646, abs=1e-3)
    # eq. 3.12: a 50 m vessel on 20 px of a 2048 px, 43 deg image is detectable to ~6.5 km
    d = detectable_distance(50.0, 2048, 20, 43.0)
    assert d == pytest.approx(6500.0, rel=0.005)
    assert d == pytest.approx(50 * 2048 / (40 * math.tan(math.radians(21.5))), rel=1e-15)


def test_whole_pixel_error_at_1_5_km_is_the_thesis_order() -> None:
    """delta 0.5 px on the 720 px rig: the thesis saw about -170 .. +200 m over its track near 1.5 km."""
    b = error_budget(**THESIS, delta_px=0.5, ranges_m=[1500.0])
    row = b.range_errors[0]
    # independent path: the disparity in normalised units, shifted by -+eps, through eq. 2.12 / 4.1
    eps = 0.5 * 2 * math.tan(math.radians(21.5)) / 720
    d = 8.14 / 1500.0
    assert row.error_far_m == pytest.approx(8.14 / (d - eps) - 1500.0, rel=1e-10)
    assert row.error_near_m == pytest.approx(8.14 / (d + eps) - 1500.0, rel=1e-10)
    assert row.error_far_m == pytest.approx(168.2, abs=0.1)
    assert row.error_near_m == pytest.approx(-137.4, abs=0.1)
    assert -200.0 < row.error_near_m < -100.0 and 130.0 < row.error_far_m < 230.0
    assert row.error_far_pct == pytest.approx(100 * row.error_far_m / 1500.0)
    assert row.k == pytest.approx(1500 / 8.14) and row.disparity_px == pytest.approx(b.focal_px * d)


def test_150_m_tolerance_ranges_thesis_comparison() -> None:
    """Thesis: 150 m tolerance range grew from ~2600 m (delta 0.5) to ~5400 m (delta 0.11).

    The equations reproduce those with the 2048 px photo-mode width and the first-order formula
    (2520 m, 5372 m); with the 720 px video width they give 1494 m and 3185 m (exact 1421 m, 3111 m).
    """
    got = {}
    for width in (720, 2048):
        for delta in (0.5, 0.11):
            (m,) = error_budget(width, 43.0, 8.14, delta, tolerances_m=[150.0]).max_ranges
            got[width, delta] = (round(m.z_max_m), round(m.z_max_first_order_m))
    assert got == {
        (720, 0.5): (1421, 1494),
        (720, 0.11): (3111, 3185),
        (2048, 0.5): (2446, 2520),
        (2048, 0.11): (5297, 5372),
    }
    assert got[2048, 0.5][1] == pytest.approx(2600, rel=0.05) and got[2048, 0.11][1] == pytest.approx(
        5400, rel=0.01
    )


@settings(max_examples=60, deadline=None)
@given(
    width=st.integers(320, 8192),
    fov=st.floats(5.0, 120.0),
    baseline=st.floats(0.5, 50.0),
    delta=st.floats(0.01, 2.0),
    tol=st.floats(1.0, 1000.0),
)
def test_max_range_is_the_root_of_eq_4_5(
    width: int, fov: float, baseline: float, delta: float, tol: float
) -> None:
    eps = float(epsilon(delta, width, fov))
    z = float(max_range(tol, eps, baseline))
    assert float(range_error(z, eps, baseline)) == pytest.approx(tol, rel=1e-9)
    first = float(max_range_first_order(tol, eps, baseline))
    assert z < first
    assert first == pytest.approx(math.sqrt(tol * baseline / eps), rel=1e-12)


def test_first_order_converges_to_exact_for_small_tolerance() -> None:
    eps = float(epsilon(0.11, 720, 43.0))
    tol = np.array([0.01, 0.1, 1.0, 10.0])
    ratio = max_range(tol, eps, 8.14) / max_range_first_order(tol, eps, 8.14)
    # Z_max = sqrt(E L_B / eps) (1 - sqrt(E eps / (4 L_B)) + ...): the gap closes like sqrt(E)
    assert np.allclose(1.0 - ratio, np.sqrt(tol * eps / (4 * 8.14)), rtol=0.01)


def test_defaults_and_json_form() -> None:
    b = error_budget(**THESIS, delta_px=0.5)
    assert [m.tolerance_m for m in b.max_ranges] == list(DEFAULT_TOLERANCES_M) == [35.0, 50.0, 150.0]
    assert [r.range_m for r in b.range_errors] == list(DEFAULT_RANGES_M) == [500.0 * i for i in range(1, 13)]
    assert b.ship_length_m == 50.0 and b.min_pixels == 20.0
    assert b.epsilon == pytest.approx(float(epsilon(0.5, 720, 43.0)), rel=1e-15)
    d = b.to_dict()
    assert d["range_errors"][0]["error_far_m"] == b.range_errors[0].error_far_m
    # beyond L_B / eps the +delta error swallows the disparity: unmeasurable, null in JSON
    far = error_budget(**THESIS, delta_px=0.5, ranges_m=[20000.0])
    assert far.range_errors[0].error_far_m == math.inf
    assert far.to_dict()["range_errors"][0]["error_far_m"] is None


@pytest.mark.parametrize(
    "change",
    [
        {"width_px": 0}, {"width_px": 720.5}, {"fov_deg": 0.0}, {"fov_deg": 180.0}, {"baseline_m": -8.14},
        {"delta_px": 0.0}, {"delta_px": math.nan}, {"tolerances_m": [35.0, -1.0]}, {"ranges_m": [math.inf]},
        {"ship_length_m": 0.0}, {"min_pixels": -20.0},
    ],
)  # fmt: skip
def test_bad_inputs_are_refused_by_name(change: dict) -> None:
    args = {**THESIS, "delta_px": 0.5, **change}
    with pytest.raises(ValueError, match=next(iter(change))):
        error_budget(**args)
