"""ranging: the Kalman designs are built once per noise level and acceleration rung and shared, with the
correlated-noise gain of their reported sigma (eq. K.8)."""

from __future__ import annotations

import math

import pytest

from edge.core.kalman_design import correlated_noise_gain
from edge.measure.filter_designs import MATCH_ERROR_CORR_S, Designs
from edge.measure.settings import PointSettings


def test_designs_are_shared_per_noise_and_acceleration() -> None:
    designs = Designs(PointSettings(fps=10.0))
    a = designs.disparity(0.08)
    assert designs.disparity(0.08) is a and designs.disparity(0.08, 0.05) is a
    b = designs.disparity(0.08, 0.05 / 8)
    assert b is not a and b.sigma_accel_pxps2 == 0.05 / 8
    # less process noise: the filter averages longer, so its steady-state variance is smaller; the
    # matcher's correlated error (eq. K.8) costs it more of that averaging than the configured design
    assert b.post_var[-1] < a.post_var[-1]
    assert b.sigma_floor_px**2 == pytest.approx(b.corr_rho * a.post_var[-1] + a.sigma_floor_px**2)
    assert b.corr_gain > a.corr_gain > 1.0
    assert b.corr_gain == pytest.approx(correlated_noise_gain(b.alpha[-1], b.beta[-1],
                                                              math.exp(-1.0 / (10.0 * MATCH_ERROR_CORR_S))))
    assert Designs(PointSettings(fps=1.0)).disparity(0.08).corr_gain < 1.01   # 1 fps: nearly independent
    # and refuses what the configured design refuses (its gate's covariance tables, eq. K.6)
    assert (b.cov_q36, b.coast_q_q36, b.r_q36, b.gate2_q8) == (a.cov_q36, a.coast_q_q36, a.r_q36, a.gate2_q8)
