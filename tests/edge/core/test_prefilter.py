"""Clipped horizontal Sobel prefilter: equals OpenCV's Sobel + clip, keeps shifts exact; the
locally normalised one: integer vs float reference, odd symmetry, bounded, shift-exact."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.prefilter import xsobel, xsobel_normalised, xsobel_normalised_float


@settings(max_examples=30)
@given(st.integers(0, 2**32 - 1), st.integers(3, 40), st.integers(3, 40), st.integers(1, 127))
def test_equals_opencv_sobel_with_clip(seed: int, h: int, w: int, cap: int) -> None:
    img = np.random.default_rng(seed).integers(0, 256, (h, w), dtype=np.uint8)
    want = np.clip(cv2.Sobel(img, cv2.CV_16S, 1, 0, ksize=3), -cap, cap) + cap
    np.testing.assert_array_equal(xsobel(img, cap), want.astype(np.uint8))


def test_commutes_with_integer_shifts() -> None:
    img = np.random.default_rng(1).integers(0, 256, (20, 50), dtype=np.uint8)
    shifted = np.roll(img, 3, axis=1)
    np.testing.assert_array_equal(xsobel(shifted)[:, 5:-2], xsobel(img)[:, 2:-5])


def test_rejects_bad_input() -> None:
    with pytest.raises(ValueError):
        xsobel(np.zeros((5, 5)))
    with pytest.raises(ValueError):
        xsobel(np.zeros((5, 5), np.uint8), cap=0)


@settings(max_examples=40)
@given(st.integers(0, 2**32 - 1), st.integers(2, 30), st.integers(2, 40), st.sampled_from([8, 64, 255]))
def test_normalised_integer_equals_float_reference(seed: int, h: int, w: int, top: int) -> None:
    img = np.random.default_rng(seed).integers(0, top + 1, (h, w), dtype=np.uint8)
    got = xsobel_normalised(img).astype(int)
    assert np.abs(got - xsobel_normalised_float(img)).max() <= 1      # rounding ties only
    assert got.min() >= 1 and got.max() <= 255                        # |v| < 127 around 128
    # odd in x: mirroring the image negates the derivative and so the output around 128
    np.testing.assert_array_equal(xsobel_normalised(img[:, ::-1].copy()).astype(int), 256 - got[:, ::-1])


def test_normalised_flat_is_zero_and_shift_exact() -> None:
    assert (xsobel_normalised(np.full((9, 12), 77, np.uint8)) == 128).all()
    img = np.random.default_rng(2).integers(0, 256, (20, 50), dtype=np.uint8)
    shifted = np.roll(img, 3, axis=1)
    np.testing.assert_array_equal(xsobel_normalised(shifted)[:, 7:-4], xsobel_normalised(img)[:, 4:-7])
    with pytest.raises(ValueError):
        xsobel_normalised(np.zeros((5, 5)))
