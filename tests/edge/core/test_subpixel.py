"""Sub-pixel fits: integer parabola and half-pixel cancellation vs exact answers and float references,
pixel-locking removal on exact-shift renders."""

from __future__ import annotations

import functools
import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from edge.core import subpixel as sp
from edge.core.costs import cost_curve_reference
from edge.core.fixedpoint import FIT_ONE, LOG_BITS, SUBPIX_ONE, log2_q, round_shift
from edge.core.match import match_point
from edge.sim.synth import Condition, sweep


@given(st.integers(1, 1 << 20), st.integers(-512, 512), st.integers(0, 1 << 30))
def test_parabola_recovers_vertex_of_a_true_parabola(a: int, x0_q10: int, c0: int) -> None:
    # c(x) = a * (1024 x - x0)^2 + c0 sampled at x = -1, 0, 1 (exact integers)
    c = [a * (1024 * x - x0_q10) ** 2 + c0 for x in (-1, 0, 1)]
    if min(c) != c[1]:
        return                                   # vertex not bracketed by the centre sample
    assert sp.parabola_q(*c) == x0_q10


@given(st.integers(0, 1 << 36), st.integers(0, 1 << 36), st.integers(0, 1 << 36))
def test_parabola_q_matches_float_within_half_lsb(cm: int, c0: int, cp: int) -> None:
    q, f = sp.parabola_q(cm, c0, cp), sp.parabola_float(cm, c0, cp)
    if q is None or f is None:
        assert q is None and (f is None or abs(abs(f) - 0.5) < 1e-9)
        return
    assert abs(q / FIT_ONE - f) <= 0.5 / FIT_ONE + 1e-12


def test_parabola_rejects_non_minimum() -> None:
    assert sp.parabola_q(5, 5, 5) is None        # flat: den = 0
    assert sp.parabola_q(1, 9, 3) is None        # maximum
    assert sp.parabola_q(0, 1, 10) is None       # vertex beyond -1/2


@given(st.lists(st.integers(-(1 << 20), 1 << 20), min_size=4, max_size=4))
def test_cancellation_rounding_within_one_q8_lsb(fits: list[int]) -> None:
    a, b, ra, rb = fits
    f = [v / FIT_ONE for v in fits]
    assert abs(sp.cancel_q8(a, b) / SUBPIX_ONE - sp.cancel_float(f[0], f[1])) < 1 / SUBPIX_ONE
    assert abs(sp.symmetric_q8(a, b, ra, rb) / SUBPIX_ONE - sp.symmetric_float(*f)) < 1 / SUBPIX_ONE


@given(st.lists(st.integers(-(1 << 20), 1 << 20), min_size=6, max_size=6))
def test_six_pass_rounding_within_one_q8_lsb(fits: list[int]) -> None:
    f = [v / FIT_ONE for v in fits]
    assert abs(sp.symmetric6_q8(*fits) / SUBPIX_ONE - sp.symmetric6_float(*f)) < 1 / SUBPIX_ONE
    # consistent estimates d, d - 1/2, d, d + 1/2 (and the mirrored pair) average back to d exactly
    d = fits[0]
    half = FIT_ONE // 2
    assert sp.symmetric6_q8(d, d - half, d, d + half, d - half, d + half) == round_shift(d, 2)


@given(st.lists(st.integers(1, (1 << 62) - 1), min_size=1, max_size=40))
def test_integer_log2_within_table_error(values: list[int]) -> None:
    got = log2_q(np.array(values, dtype=np.int64))
    for v, q in zip(values, got.tolist(), strict=True):
        assert abs(q / (1 << LOG_BITS) - math.log2(v)) < 2**-21
        if v & (v - 1) == 0:                          # powers of two are exact
            assert q == (v.bit_length() - 1) << LOG_BITS


@given(st.integers(1, 1 << 20), st.integers(-1000, 1000), st.integers(-(1 << 40), 1 << 40))
def test_gauss_fit_recovers_vertex_of_a_log_parabola(a: int, t_q10: int, c0: int) -> None:
    # y(k) = a (1024 k - t)^2 + c0 for k = 0, 1, 2 around the cost minimum at k = 1
    model = [a * (1024 * (k - 1) - t_q10) ** 2 + c0 for k in range(3)]
    model = [model[0] + 1] + model + [model[2] + 1]             # a curve of 5 with its minimum inside
    if min(model[1:4]) != min(model) or model.index(min(model)) != 2:
        return
    assert sp.gauss_fit_q(model, 6) == (8 << 10) + t_q10
    f = sp.gauss_fit_float([float(v) for v in model], 6)
    assert f is not None and abs(f - 8 - t_q10 / 1024) < 1e-6


@given(st.integers(0, 2**32 - 1), st.integers(3, 9))
def test_ncc_log_curves_integer_equals_float_reference(seed: int, d0: int) -> None:
    rng = np.random.default_rng(seed)
    left = rng.integers(20, 230, (9, 40), dtype=np.uint8)
    right = np.clip(left.astype(int) + rng.integers(-20, 21, left.shape), 0, 255).astype(np.uint8)
    model = sp.ncc_log_curves(left, right, 22, d0)
    f_model = sp.ncc_log_curves(left, right, 22, d0, as_float=True)
    assert (model is None) == (f_model is None)
    if model is not None:
        for m, fm in zip(model, f_model, strict=True):
            # integer Q24 logs of N-scaled sums: the float model plus one constant (log2 of N, 2)
            offset = np.array(m) / (1 << LOG_BITS) - np.array(fm)
            assert np.ptp(offset) < 2**-18
    half = right // 2
    base, doubled = (sp.ncc_log_curves(left, r, 22, d0) for r in (half, 2 * half))
    assert (base is None) == (doubled is None)
    if base is not None:                       # NCC ignores a camera gain (here exactly 2)
        for b, g in zip(base, doubled, strict=True):
            assert np.ptp((np.array(g) - np.array(b)) / (1 << LOG_BITS)) < 2**-18


def _explicit_curve(t_img: np.ndarray, b_img: np.ndarray, x: int, ds: range, h: int) -> np.ndarray:
    """Independent route: slice each candidate window of pre-built images, plain int64 SSD."""
    t = t_img[:, x - h:x + h + 1]
    return np.array([cost_curve_reference(t, b_img[:, x - d - h:x - d + h + 1], "ssd")[0] for d in ds])


@given(st.integers(0, 2**32 - 1), st.integers(3, 9))
def test_cancellation_costs_equal_explicit_half_pixel_images(seed: int, d0: int) -> None:
    rng = np.random.default_rng(seed)
    w, h = 9, 4
    left = rng.integers(0, 256, (w, 40), dtype=np.uint8)
    right = rng.integers(0, 256, (w, 40), dtype=np.uint8)
    xl = 22
    lh = left[:, :-1].astype(np.int64) + left[:, 1:]
    rh = right[:, :-1].astype(np.int64) + right[:, 1:]
    a, b, ra, rb = sp.cancellation_costs(left, right, xl, d0, "ssd")
    np.testing.assert_array_equal(a, _explicit_curve(lh, rh, xl, range(d0 - 2, d0 + 3), h))
    np.testing.assert_array_equal(b, _explicit_curve(lh, 2 * right.astype(np.int64), xl,
                                                     range(d0 - 2, d0 + 2), h))
    xr = xl - d0
    np.testing.assert_array_equal(ra, _explicit_curve(rh, lh, xr, range(-d0 - 2, -d0 + 3), h))
    np.testing.assert_array_equal(rb, _explicit_curve(rh, 2 * left.astype(np.int64), xr,
                                                      range(-d0 - 2, -d0 + 2), h))
    six = sp.cancellation_costs(left, right, xl, d0, "ssd", six=True)
    for four, same in zip((a, b, ra, rb), six[:4], strict=True):
        np.testing.assert_array_equal(four, same)
    # mirrored passes: 2L(x) vs Rh(x - d - 1) puts Rh's half-pixel centre at x - d - 1/2, so the
    # curve entry for d = d0-2 .. d0+1 is the explicit SSD against Rh shifted by one more column
    np.testing.assert_array_equal(six[4], _explicit_curve(2 * left.astype(np.int64), rh, xl,
                                                          range(d0 - 1, d0 + 3), h))
    np.testing.assert_array_equal(six[5], _explicit_curve(2 * right.astype(np.int64), lh, xr,
                                                          range(-d0 - 1, -d0 + 3), h))


def test_contrast_equalisation_makes_costs_gain_invariant() -> None:
    rng = np.random.default_rng(5)
    left = rng.integers(10, 150, (15, 60), dtype=np.uint8)     # gains stay inside [1/2, 2]
    right = rng.integers(10, 100, (15, 60), dtype=np.uint8)
    doubled = (2 * right).astype(np.uint8)          # exact gain 2 on the right camera
    for as_float in (False, True):
        base = sp.cancellation_costs(left, right, 30, 6, "zssd", as_float)
        gained = sp.cancellation_costs(left, doubled, 30, 6, "zssd", as_float)
        for c1, c2 in zip(base, gained, strict=True):
            # the float gain is exact; the integer one is quantised to Q8 (relative 2^-9)
            np.testing.assert_allclose(c1 / c1.sum(), c2 / c2.sum(), rtol=1e-12 if as_float else 2e-3)
        plain = sp.cancellation_costs(left, doubled, 30, 6, "ssd", as_float)
        assert not np.allclose(plain[0] / plain[0].sum(), base[0] / base[0].sum())
    assert sp.contrast_gain_q8(4 * 10**6, 10**6) == 512
    assert abs(sp.contrast_gain_q8(10**6, 1_210_000) - 256 / 1.1) <= 0.5


def test_integer_widths_for_15x15_worst_case() -> None:
    # contrast-equalised 9-bit sums: |D| <= 510 * 512, ZSSD <= N * N * D^2, den <= 4 max (int64)
    n = 15 * 15
    worst = n * n * (510 * 512) ** 2
    assert worst.bit_length() <= 52 and (4 * worst).bit_length() <= 54
    rng = np.random.default_rng(0)              # and a worst-case window really stays in int64
    left = np.where(rng.random((15, 40)) < 0.5, 0, 255).astype(np.uint8)
    right = (left // 2).astype(np.uint8)        # half the contrast: gain clamps at 2
    costs = sp.cancellation_costs(left, right, 20, 3, "zssd")
    exact = sp.cancellation_costs(left, right, 20, 3, "zssd", as_float=True)
    for c, f in zip(costs, exact, strict=True):
        assert c.max() < 2**52
        np.testing.assert_allclose(c / c.max(), f / f.max(), rtol=1e-6)


def _stats(condition: Condition, subpixel: str, cost: str = "zssd") -> tuple[float, float]:
    m = functools.partial(match_point, max_disparity=12, subpixel=subpixel, cost=cost,
                          noise_dn=condition.noise_dn)
    s = sweep(condition, range(9000, 9012), m, n_fractions=16)
    e = s.errors
    assert np.isfinite(e).all()
    return float(np.sqrt((e**2).mean())), float(np.abs(e.mean(axis=0)).max())


def test_cancellation_removes_pixel_locking() -> None:
    for cond in (Condition("tex", noise_dn=0.5), Condition("sharp", kind="sharp", psf_sigma_px=0.25,
                                                             noise_dn=0.5)):
        rms_p, bias_p = _stats(cond, "parabola", "ssd")
        rms_c, bias_c = _stats(cond, "cancel")
        assert bias_p > 0.04                      # the thesis method locks to whole pixels
        assert bias_c < bias_p / 4 and rms_c < rms_p / 3
