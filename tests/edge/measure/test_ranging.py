"""ranging: the Kalman designs are built once per noise level and acceleration rung and shared."""

from __future__ import annotations

import pytest

from edge.measure.ranging import Designs
from edge.measure.settings import PointSettings


def test_designs_are_shared_per_noise_and_acceleration() -> None:
    designs = Designs(PointSettings(fps=10.0))
    a = designs.disparity(0.08)
    assert designs.disparity(0.08) is a and designs.disparity(0.08, 0.05) is a
    b = designs.disparity(0.08, 0.05 / 8)
    assert b is not a and b.sigma_accel_pxps2 == 0.05 / 8
    # less process noise: the filter averages longer, so its steady-state variance is smaller, but
    # it reports no less than the configured design (errors correlated over time do not average)
    assert b.post_var[-1] < a.post_var[-1]
    assert b.sigma_floor_px**2 == pytest.approx(a.post_var[-1] + a.sigma_floor_px**2)
    # and refuses what the configured design refuses (its gate's covariance tables, eq. K.6)
    assert (b.cov_q36, b.coast_q_q36, b.r_q36, b.gate2_q8) == (a.cov_q36, a.coast_q_q36, a.r_q36, a.gate2_q8)
