"""Disparity filters: Q14 Butterworth and Q24 Kalman vs float references, theory and the track test."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import sosfilt, sosfilt_zi, sosfreqz

from edge.core.butterworth import ButterworthFloat, ButterworthQ, butterworth_sos, design_q14, group_delay_s
from edge.core.fixedpoint import BIQUAD_COEF_BITS, round_shift
from edge.core.kalman import DisparityKalman, DisparityKalmanFloat, design_kalman
from edge.sim import tracksim as ts

SETTINGS = [(0.5, 10.0), (0.2, 10.0), (0.5, 30.0), (0.2, 30.0), (0.1, 30.0)]


@pytest.mark.parametrize("fc,fs", SETTINGS)
def test_q14_design_has_exact_dc_gain_and_butterworth_response(fc: float, fs: float) -> None:
    c = design_q14(fc, fs)
    assert c.b0 + c.b1 + c.b2 == (1 << BIQUAD_COEF_BITS) + c.a1 + c.a2
    _, h = sosfreqz(c.as_float(), worN=[0.0, fc], fs=fs)
    assert abs(h[0]) == pytest.approx(1.0, abs=1e-12)
    assert 20 * np.log10(abs(h[1])) == pytest.approx(-3.01, abs=0.35)
    exact_poles = np.roots(butterworth_sos(fc, fs)[0][3:])
    q_poles = np.roots(c.as_float()[0][3:])
    assert np.allclose(np.sort(np.abs(q_poles)), np.sort(np.abs(exact_poles)), atol=2e-4)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(SETTINGS))
def test_integer_biquad_within_2_lsb_of_float(seed: int, setting: tuple[float, float]) -> None:
    rng = np.random.default_rng(seed)
    x_q8 = np.round((20 + np.cumsum(rng.normal(0, 0.02, 2000)) + rng.normal(0, 0.3, 2000)) * 256)
    fi, ff = ButterworthQ(*setting), ButterworthFloat(*setting)
    for x in x_q8.astype(int):
        assert abs(fi.update(int(x)) - 256 * ff.update(x / 256)) <= 2


def test_float_reference_equals_scipy_streaming() -> None:
    rng = np.random.default_rng(1)
    x = 12 + rng.normal(0, 0.2, 500)
    sos = butterworth_sos(0.5, 10)
    want, _ = sosfilt(sos, x, zi=sosfilt_zi(sos) * x[0])
    f = ButterworthFloat(0.5, 10, quantised=False)
    np.testing.assert_allclose([f.update(v) for v in x], want, rtol=0, atol=1e-12)


def _narrow_state_df1(fc: float, fs: float, xs: list[int]) -> list[int]:
    """The CMSIS-q15-style trap: output fed back already rounded to Q8 (for contrast only)."""
    c = design_q14(fc, fs)
    x1 = x2 = y1 = y2 = xs[0]
    out = []
    for x in xs:
        y = round_shift(c.b0 * x + c.b1 * x1 + c.b2 * x2 - c.a1 * y1 - c.a2 * y2, BIQUAD_COEF_BITS)
        x2, x1, y2, y1 = x1, x, y1, y
        out.append(y)
    return out


@pytest.mark.parametrize("fc,fs", SETTINGS)
def test_no_stuck_error_on_constant_input(fc: float, fs: float) -> None:
    steps = [1000] * 50 + [5123] * 10_000          # a step, then 10 000 constant samples
    f = ButterworthQ(fc, fs)
    out = [f.update(x) for x in steps]
    assert out[-2000:] == [5123] * 2000
    if fc / fs <= 0.2 / 30:                         # the wide state is what makes this pass:
        assert abs(_narrow_state_df1(fc, fs, steps)[-1] - 5123) > 2


def test_ramp_lag_is_the_group_delay() -> None:
    fs, fc, rate = 30.0, 0.5, 1.0                  # 1 px/s
    f = ButterworthFloat(fc, fs, quantised=False)
    t = np.arange(3000) / fs
    y = np.array([f.update(v) for v in rate * t])
    assert (rate * t[-1] - y[-1]) / rate == pytest.approx(group_delay_s(fc), rel=0.01)


def _kalata(sigma_a: float, sigma_n: float, fs: float) -> tuple[float, float]:
    lam = sigma_a / fs**2 / sigma_n
    r = (4 + lam - np.sqrt(8 * lam + lam**2)) / 4
    alpha = 1 - r**2
    return alpha, 2 * (2 - alpha) - 4 * np.sqrt(1 - alpha)


@pytest.mark.parametrize("fs,sa", [(10, 0.007), (10, 0.15), (30, 0.05), (30, 0.5)])
def test_steady_state_gains_match_kalata(fs: float, sa: float) -> None:
    d = design_kalman(fs, 0.1, sa)
    alpha, beta = _kalata(sa, 0.1, fs)
    assert d.alpha[-1] == pytest.approx(alpha, rel=1e-6)
    assert d.beta[-1] == pytest.approx(beta, rel=1e-6)
    assert abs(d.alpha_q24[-1] / 2**24 - alpha) < 2**-24 and abs(d.beta_q24[-1] / 2**24 - beta) < 2**-24


def _feed(design, zs):
    fi, ff = DisparityKalman(design), DisparityKalmanFloat(design)
    return [(fi.update(z), ff.update(z)) for z in zs]


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([(10.0, 0.05), (30.0, 0.2), (10.0, 0.5)]))
def test_integer_kalman_within_2_lsb_of_float(seed: int, setting: tuple[float, float]) -> None:
    rng = np.random.default_rng(seed)
    n = 3000
    truth = 30 + 3 * np.sin(np.arange(n) / 400)
    # bounded noise (|e| <= 0.12 px, well inside the 0.31 px gate) and 5 px outliers: no sample
    # sits on the gate boundary, where 1 LSB of state difference could flip a decision
    z = truth + rng.uniform(-0.12, 0.12, n)
    z[rng.random(n) < 0.03] += 5
    zs = [None if 1200 <= i < 1240 else float(v) for i, v in enumerate(z)]
    for a, b in _feed(design_kalman(setting[0], 0.1, setting[1]), zs):
        assert (a.valid, a.accepted, a.misses) == (b.valid, b.accepted, b.misses)
        if a.valid:
            assert abs(a.disparity_q8 - 256 * b.disparity_px) <= 2


def test_integer_kalman_within_2_lsb_of_float_through_starts_and_restarts() -> None:
    """The paths the noise test rarely takes: a start with an outlier among its samples, an
    unconfirmed start restarting on a jump (eq. K.7), a start on a fast ramp, a gap longer than
    the re-acquisition."""
    rng = np.random.default_rng(7)
    ramp = list(40 + 0.25 * np.arange(60) + rng.uniform(-0.1, 0.1, 60))
    zs = ([20.0, 20.1, 26.0, 19.9, 20.05, 20.0] + list(21.5 + rng.uniform(-0.1, 0.1, 30))
          + [None] * 35 + ramp)
    pairs = _feed(design_kalman(10.0, 0.1, 0.05), zs)
    assert any(a.valid and a.accepted and abs(a.disparity_px - 21.5) < 0.3 for a, _ in pairs[6:15])
    for a, b in pairs:
        assert (a.valid, a.accepted, a.misses) == (b.valid, b.accepted, b.misses)
        if a.valid:
            assert abs(a.disparity_q8 - 256 * b.disparity_px) <= 2


def test_kalman_constant_input_has_no_stuck_error() -> None:
    design = design_kalman(30, 0.1, 0.05)
    f = DisparityKalman(design)
    for z in [10.0] * 5 + [10.5] * 10_000:
        e = f.update(z)
    assert e.disparity_q8 == round(10.5 * 256) and abs(e.rate_pxps) < 1e-4


def test_gate_coast_and_reacquire() -> None:
    design = design_kalman(10, 0.1, 0.05)
    f = DisparityKalman(design)
    rng = np.random.default_rng(3)
    for z in 20 + rng.normal(0, 0.1, 300):
        f.update(float(z))
    before = f.update(20.0)
    spike = f.update(22.0)                          # a single glint: gated, coasted
    assert not spike.accepted and spike.misses == 1 and abs(spike.disparity_px - before.disparity_px) < 0.01
    burst = [f.update(23.0) for _ in range(20)]    # 2 s burst at 10 fps
    assert not any(e.accepted for e in burst) and burst[-1].sigma_px > before.sigma_px
    assert abs(burst[-1].disparity_px - 20) < 0.1
    assert f.update(20.02).accepted
    gap = [f.update(None) for _ in range(31)]       # > 3 s without measurements: restart
    assert gap[-1].misses == 31 and not gap[-1].valid
    restart = [f.update(float(z)) for z in [35.0, 35.1, 48.0, 34.9, 35.0, 35.05]]  # one outlier among six
    assert [e.valid for e in restart] == [False] * 5 + [True]     # the outlier fails the line fit: dropped
    assert abs(restart[-1].disparity_px - 35.0) < 0.11


SCENARIOS = [(ts.SHIP, 10.0, 0.1), (ts.FAST_BOAT, 10.0, 0.5)]
MATCHER_BIAS = 0.008 * np.sin(2 * np.pi * np.arange(32) / 32)




@pytest.mark.parametrize("scenario,fs,sa", SCENARIOS, ids=lambda v: getattr(v, "name", str(v)))
def test_track_acceptance(scenario: ts.Scenario, fs: float, sa: float) -> None:
    make = ts.kalman_filter_maker(fs, 0.1, sa)
    lags = [ts.lag_px(ts.run_track(scenario, fs, ts.Disturbances(), s, make)) for s in (21, 22, 23)]
    assert abs(np.mean(lags)) <= 0.02
    dirty = ts.Disturbances(outlier_rate=0.02, burst_s=2.0, bias_curve=MATCHER_BIAS)
    run = ts.run_track(scenario, fs, dirty, 31, make)
    rel = ts.range_errors(run)
    assert np.sqrt(np.nanmean(rel**2)) <= 0.015
    ratio = np.abs(run.d_est - run.d_true) / run.sigma_est
    assert np.nanmax(ratio) < 4.0 and np.nanmean(ratio > 3) < 0.002
