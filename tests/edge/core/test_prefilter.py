"""Clipped horizontal Sobel prefilter: equals OpenCV's Sobel + clip, keeps shifts exact."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.prefilter import xsobel


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
