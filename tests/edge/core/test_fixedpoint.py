"""Fixed-point helpers: rounding shifts, the restoring division an FPGA would use, saturation."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core import fixedpoint as fp


def _round_half_away(q: Fraction) -> int:
    mag = int(abs(q) + Fraction(1, 2))          # floor(|q| + 1/2)
    return mag if q >= 0 else -mag


@given(st.integers(-(1 << 62), 1 << 62), st.integers(0, 40))
def test_round_shift_is_exact_rounding(value: int, bits: int) -> None:
    assert fp.round_shift(value, bits) == _round_half_away(Fraction(value, 1 << bits))


@given(st.lists(st.integers(-(1 << 60), 1 << 60), min_size=1, max_size=20), st.integers(1, 30))
def test_round_shift_array_matches_scalar(values: list[int], bits: int) -> None:
    got = fp.round_shift_array(np.array(values, dtype=np.int64), bits)
    assert got.tolist() == [fp.round_shift(v, bits) for v in values]


@given(st.integers(-(1 << 50), 1 << 50), st.integers(1, 1 << 40))
def test_div_round_is_exact_rounding(num: int, den: int) -> None:
    assert fp.div_round(num, den) == _round_half_away(Fraction(num, den))


@settings(max_examples=300)
@given(st.data(), st.integers(1, 1 << 37), st.integers(1, 16))
def test_restoring_division_equals_int64_rounding(data: st.DataObject, den: int, bits: int) -> None:
    num = data.draw(st.integers(-den, den))
    assert fp.restoring_divide(num, den, bits) == fp.div_round(num << bits, den)


def test_restoring_division_edges() -> None:
    assert fp.restoring_divide(5, 5, 8) == 256
    assert fp.restoring_divide(-5, 5, 8) == -256
    assert fp.restoring_divide(0, 7, 10) == 0
    assert fp.restoring_divide(1, 2, 8) == 128
    assert fp.restoring_divide(1, 512, 8) == 1          # 0.5 LSB rounds away from zero
    assert fp.restoring_divide(-1, 512, 8) == -1


def test_saturate_never_wraps() -> None:
    assert fp.saturate(1 << 40) == fp.INT32_MAX
    assert fp.saturate(-(1 << 40)) == fp.INT32_MIN
    assert fp.saturate(123) == 123
    assert fp.saturate(200, bits=8) == 127


@given(st.floats(-1000, 1000, allow_nan=False), st.integers(0, 24))
def test_q_round_trip_within_half_lsb(value: float, bits: int) -> None:
    q = fp.to_q(value, bits)
    assert abs(fp.from_q(q, bits) - value) <= 0.5 / (1 << bits) + 1e-12


def test_scales_are_consistent() -> None:
    assert fp.SUBPIX_ONE == 256 and fp.FIT_BITS > fp.SUBPIX_BITS
    assert fp.BIQUAD_STATE_BITS == fp.SUBPIX_BITS + fp.BIQUAD_COEF_BITS
    assert fp.AB_ONE == 1 << 24


@given(st.integers(1, (1 << 62) - 1))
def test_scalar_log2_is_bit_identical_to_the_vector_one(v: int) -> None:
    assert fp.log2_q_int(v) == int(fp.log2_q(np.array([v], dtype=np.int64))[0])


@given(st.lists(st.tuples(st.integers(-(1 << 50), 1 << 50), st.integers(1, 1 << 40)),
                min_size=1, max_size=20))
def test_array_division_is_div_round_elementwise(pairs: list[tuple[int, int]]) -> None:
    num = np.array([p[0] for p in pairs], dtype=np.int64)
    den = np.array([p[1] for p in pairs], dtype=np.int64)
    assert fp.div_round_array(num, den).tolist() == [fp.div_round(a, b) for a, b in pairs]
