"""Shift-and-refit (lab/subpix/refit.py): interpolator taps, the refit's pull
towards the truth from a wrong start, integer vs float, borders, and the acceptance bounds of
issue 4 with subpixel="refit" on exact-shift renders."""

from __future__ import annotations

import functools

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.match import match_point
from edge.sim.synth import Condition, make_scene, render_pair, sweep
from lab.subpix import refit as rf  # importing lab.subpix registers subpixel="refit"

SEEDS = range(9200, 9216)          # unit-test seeds (bench-core uses 1000+ and 5000+)
H = 7


def test_taps_sum_to_one_and_phase_zero_is_the_sample() -> None:
    taps = rf.taps_q14()
    assert taps.shape == (1 << rf.PHASE_BITS, 2 * rf.HALF_TAPS)
    assert (taps.sum(axis=1) == 1 << rf.TAP_BITS).all()
    assert taps[0].tolist() == [0, 0, 0, 0, 1 << rf.TAP_BITS, 0, 0, 0]
    # each tap rounded (1/2 LSB), the largest one also carries the row's rounding residue (<= 4 LSB)
    err = np.abs(taps / (1 << rf.TAP_BITS) - np.stack([rf.kernel_float(p / 256) for p in range(256)]))
    assert err.max() <= (0.5 + rf.HALF_TAPS) / (1 << rf.TAP_BITS)


@given(st.floats(0.0, 0.999), st.floats(0.02, 0.25), st.floats(0, 2 * np.pi))
def test_kernel_interpolates_band_limited_rows(q: float, freq: float, phase: float) -> None:
    # sum_j c_j R(x + j) ~ R(x - q) for a sinusoid well below Nyquist
    j = np.arange(-rf.HALF_TAPS, rf.HALF_TAPS)
    row = np.cos(2 * np.pi * freq * j + phase)
    want = np.cos(2 * np.pi * freq * (-q) + phase)
    assert abs(float(rf.kernel_float(q) @ row) - want) < 2e-3      # passband: up to 1/4 cycle per px


def _pair(seed: int, k32: int, noise_dn: float = 0.0):
    rng = np.random.default_rng(seed)
    return render_pair(make_scene(rng, 40, 80, "hull"), rng, 32 * 5 + k32, height_px=31, width_px=60,
                       noise_dn=noise_dn)


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**31), st.integers(0, 31), st.integers(-13, 13), st.sampled_from([None, 1.0]))
def test_refit_pulls_a_wrong_start_to_the_truth(seed: int, k32: int, start_error_q8: int,
                                                smooth: float | None) -> None:
    # noise-free exact shift: from a start up to 0.05 px off (several times the first stage's
    # error), one refit lands within 0.02 px and passes on at most 30 % of the start's error
    pair = _pair(seed, k32)
    a, b = pair.left[15 - H:15 + H + 1], pair.right[15 - H:15 + H + 1]
    truth_q8 = round(pair.disparity_px * 256)
    out = rf.refit_q8(a, b, 40, truth_q8 + start_error_q8, smooth)
    at_truth = rf.refit_q8(a, b, 40, truth_q8, smooth)
    assert out is not None and at_truth is not None
    assert abs(out - truth_q8) <= 0.02 * 256
    assert abs(out - at_truth) <= 0.3 * abs(start_error_q8) + 1


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31), st.integers(0, 31), st.sampled_from([1.0, 4.0]), st.integers(-300, 300),
       st.booleans())
def test_integer_refit_within_one_q8_lsb_of_float(seed: int, k32: int, noise_dn: float,
                                                  start_q8: int, smooth: bool) -> None:
    pair = _pair(seed, k32, noise_dn)
    a, b = pair.left[15 - H:15 + H + 1], pair.right[15 - H:15 + H + 1]
    first_q8 = round(pair.disparity_px * 256) + start_q8 // 10
    noise = noise_dn if smooth else None
    qi, qf = rf.refit_q8(a, b, 40, first_q8, noise), rf.refit_float(a, b, 40, first_q8 / 256, noise)
    assert (qi is None) == (qf is None)
    if qi is not None:
        assert abs(qi / 256 - qf) <= 1 / 256


def test_border_needs_the_interpolator_columns() -> None:
    pair = _pair(3, 9)
    a, b = pair.left[15 - H:15 + H + 1], pair.right[15 - H:15 + H + 1]
    first_q8 = round(pair.disparity_px * 256)
    assert rf.refit_q8(a, b, 40, first_q8) is not None
    assert rf.refit_q8(a, b, 40, (40 - H - 4) << 8) is None           # right columns before 0
    assert rf.refit_q8(a, b, a.shape[1] - H - 1, first_q8) is None    # left window at the edge
    assert rf.refit_float(a, b, a.shape[1] - H - 1, first_q8 / 256) is None
    # match_point still answers there, with the six-pass estimate
    m = match_point(pair.left, pair.right, 40, 15, max_disparity=12, subpixel="refit")
    assert m.valid and abs(m.disparity_px - pair.disparity_px) < 0.05


def test_smoothing_only_where_the_views_match_to_the_noise() -> None:
    # aligned windows that differ by noise only keep the [1 6 1] smoothing; a 0.25 px vertical
    # offset between the views is a mismatch noise does not explain, so the refit drops it
    rng = np.random.default_rng(11)
    scene = make_scene(rng, 40, 80, "hull")
    for vertical, want in ((0, False), (2, True)):
        pair = render_pair(scene, rng, 32 * 5 + 7, height_px=31, width_px=60, noise_dn=1.0,
                           vertical_offset_8ths=vertical)
        a, b = pair.left[15 - H:15 + H + 1], pair.right[15 - H:15 + H + 1]
        first_q8 = round(pair.disparity_px * 256)
        ls = a[:, 40 - H - 2:40 + H + 3].astype(np.float64) @ rf._smoother(2 * H + 5) / 8
        n = first_q8 >> 8
        rs = b[:, 40 - H - 2 - n - 4:40 + H + 3 - n + 3] @ rf._banded(rf.kernel_float((first_q8 & 255) / 256),
                                                                   2 * H + 5) @ rf._smoother(2 * H + 5) / 8
        noise_var = rf.SMOOTHED_NOISE_GAIN * (1 + 1 / 12)
        assert rf._mismatched((2 * H + 1) ** 2, rf._sums(ls, rs), noise_var) == want
        if want:
            assert rf.refit_q8(a, b, 40, first_q8, 1.0) == rf.refit_q8(a, b, 40, first_q8)


def _rms(e: np.ndarray) -> float:
    return float(np.sqrt(np.mean(e**2)))


def _errors(cond: Condition) -> np.ndarray:
    m = functools.partial(match_point, max_disparity=12, noise_dn=cond.noise_dn, subpixel="refit")
    return sweep(cond, SEEDS, m, n_fractions=16).errors


def test_refit_keeps_the_acceptance_bounds() -> None:
    # issue 4's bounds hold for subpixel="refit" too: textured, fog, gain/offset mismatch
    tex = _errors(Condition("tex"))
    assert np.isfinite(tex).all()
    assert _rms(tex) <= 0.02 and np.abs(tex.mean(axis=0)).max() <= 0.01
    fog = _errors(Condition("fog", fog_t=0.15))
    assert np.isfinite(fog).all() and np.abs(fog).max() < 1.0 and _rms(fog) <= 0.07
    for kw in ({"gain": 0.9}, {"gain": 1.1}, {"offset_dn": 10.0}, {"offset_dn": -10.0}):
        e = _errors(Condition("mismatch", **kw))
        assert np.isfinite(e).all() and _rms(e) <= 1.1 * _rms(tex), kw
