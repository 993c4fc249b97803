"""Levelling: the Q8 integer path equals its float64 reference, whole-row shifts move rows exactly,
and a tilted step becomes one row."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.level import level_columns, level_columns_float, shifts_q8


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(2, 30), st.integers(1, 40), st.floats(-6.0, 6.0))
def test_integer_equals_float_reference(seed: int, h: int, w: int, tilt: float) -> None:
    rng = np.random.default_rng(seed)
    img = rng.integers(0, 256, (h, w), dtype=np.uint8)
    shift = shifts_q8(np.linspace(0.0, tilt, w) + rng.normal(0.0, 0.3, w))
    np.testing.assert_array_equal(level_columns(img, shift), level_columns_float(img, shift))


def test_whole_row_shifts_move_rows() -> None:
    img = np.random.default_rng(1).integers(0, 256, (30, 8), dtype=np.uint8)
    out = level_columns(img, np.full(8, 3 * 256))
    np.testing.assert_array_equal(out[:-3], img[3:])
    np.testing.assert_array_equal(out[-3:], np.repeat(img[-1:], 3, axis=0))
    np.testing.assert_array_equal(level_columns(img, np.zeros(8, int)), img)


def test_a_tilted_step_becomes_one_row() -> None:
    w = 200
    edge = 20.0 + 0.05 * np.arange(w)  # the step's row in each column, 10 rows of tilt
    rows = np.arange(60)[:, None]
    img = np.where(rows + 0.5 < edge[None, :], 200, 100).astype(np.uint8)
    out = level_columns(img, shifts_q8(edge - edge.mean()))
    step = np.argmax(np.diff(out.astype(int), axis=0) < -40, axis=0)
    assert np.ptp(step) <= 1


def test_rejects_a_shift_per_column_mismatch() -> None:
    with pytest.raises(ValueError):
        level_columns(np.zeros((4, 5), np.uint8), np.zeros(4, int))
