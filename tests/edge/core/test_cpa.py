"""CPA/TCPA between two constant-velocity tracks: known answers and the linearised sigma against
Monte Carlo (edge.core.cpa)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.cpa import pair_cpa, relative_cpa


def _two(a: list[float], b: list[float]) -> tuple[float, float]:
    res = pair_cpa(np.array([a, b]), np.zeros((2, 4, 4)))
    return float(res.cpa_m[0]), float(res.tcpa_s[0])


def test_head_on_meets_at_the_middle() -> None:
    cpa, tcpa = _two([0, 0, 0, 5], [0, 1000, 0, -5])
    assert cpa == 0.0 and tcpa == 100.0


def test_crossing_square_with_offset() -> None:
    # A north at 10 m/s from 1 km south, B east at 10 m/s from 1 km west, 100 m later on the line
    cpa, tcpa = _two([0, -1000, 0, 10], [-1100, 0, 10, 0])
    # relative p = (-1100, 1000), v = (10, -10): t = 2100 / 200, miss = |p x v| / |v|
    assert math.isclose(tcpa, 105.0)
    assert math.isclose(cpa, abs(-1100 * -10 - 1000 * 10) / math.hypot(10, 10))


def test_parallel_same_velocity_has_no_tcpa() -> None:
    cpa, tcpa = _two([0, 0, 3, 4], [300, 0, 3, 4])
    assert cpa == 300.0 and tcpa == math.inf


def test_diverging_has_negative_tcpa() -> None:
    cpa, tcpa = _two([0, 0, 0, -5], [100, 1000, 0, 5])
    assert tcpa == -100.0 and math.isclose(cpa, 100.0)


def test_pairs_are_all_i_below_j() -> None:
    res = pair_cpa(np.zeros((4, 4)) + np.arange(4)[:, None], np.zeros((4, 4, 4)))
    assert list(zip(res.i.tolist(), res.j.tolist(), strict=True)) == [
        (0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]


def _cov(rng: np.random.Generator, pos_sd: float, vel_sd: float) -> np.ndarray:
    a = rng.normal(size=(4, 4)) * np.array([pos_sd, pos_sd, vel_sd, vel_sd])[:, None]
    return a @ a.T / 4 + np.diag([pos_sd**2, pos_sd**2, vel_sd**2, vel_sd**2]) * 0.1


@settings(max_examples=25, deadline=None)
@given(st.floats(-2000, 2000), st.floats(-2000, 2000), st.floats(0, 2 * math.pi), st.floats(3.0, 8.0),
       st.floats(5, 40), st.floats(0.02, 0.1), st.integers(0, 2**31 - 1))
def test_linearised_sigma_matches_monte_carlo(px: float, py: float, heading: float, speed: float,
                                              pos_sd: float, vel_sd: float, seed: int) -> None:
    """Relative-velocity error small against the relative speed (a filtered ship): the
    linearised sigmas of the signed miss distance and the TCPA are those of a Monte Carlo of the
    same Gaussian states, within the sampling error (12 %) and the second-order terms the
    linearisation drops: about |p| r^2 on the miss and |t| 2 r^2 on the TCPA, r the relative
    velocity's error over its magnitude (a direction error of r rad bends the relative track by
    |p| r^2 / 2)."""
    rng = np.random.default_rng(seed)
    v = speed * np.array([math.sin(heading), math.cos(heading)])
    p = np.array([px, py])
    cov = _cov(rng, pos_sd, vel_sd)
    m, t, sm, stt = relative_cpa(p, v, cov)
    x = rng.multivariate_normal(np.concatenate([p, v]), cov, size=20000)
    mc_m, mc_t, _, _ = relative_cpa(x[:, :2], x[:, 2:])
    r2 = 2 * vel_sd**2 / speed**2
    second_m, second_t = math.hypot(px, py) * r2 + 0.5, 2 * abs(float(t)) * r2 + 0.2
    assert math.isclose(float(np.std(mc_m)), float(sm), rel_tol=0.12, abs_tol=second_m)
    assert math.isclose(float(np.std(mc_t)), float(stt), rel_tol=0.12, abs_tol=second_t)
    assert abs(float(np.mean(mc_m)) - float(m)) < 4 * float(sm) / math.sqrt(20000) + second_m


def test_sigma_is_zero_without_covariance_and_finite_through_zero_cpa() -> None:
    m, _, sm, _ = relative_cpa(np.array([0.0, 1000.0]), np.array([0.0, -5.0]),
                               np.diag([25.0, 25.0, 0.01, 0.01]))
    assert float(m) == 0.0 and 0 < float(sm) < 100
