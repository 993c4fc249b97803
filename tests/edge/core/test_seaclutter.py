"""Sea-clutter CFAR: the integer path against its float64 reference, known answers for a block on a
flat sea, and a levelled horizon step (constant along the rows) that gives no hits."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.seaclutter import A_MAX, CELL_H, CELL_W, cfar_contrast, cfar_hits, cfar_hits_float


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(CELL_H, 24), st.integers(1, 90),
       st.sampled_from([40, 120, 255]),
       st.integers(8, 40))
def test_integer_equals_float_reference_away_from_the_threshold(seed: int, h: int, w: int, top: int,
                                                                k4: int) -> None:
    img = np.random.default_rng(seed).integers(0, top + 1, (h, w), dtype=np.uint8)
    hits, a, _, _ = cfar_hits(img, k4, 8)
    ref, contrast = cfar_hits_float(img, k4 / 4.0, 2.0)
    # a is the float contrast in quarters of a DN, truncated and clipped
    np.testing.assert_array_equal(a, np.minimum(np.floor(4.0 * contrast + 1e-9), A_MAX).astype(np.uint8))
    # the decisions differ only where the quantisation of a (1/4 DN, and the ring's mean of it) can
    # move the ratio across K: a stricter reference's hits are hits, a looser one's include them all
    strict, _ = cfar_hits_float(img, 1.25 * k4 / 4.0, 2.25)
    loose, _ = cfar_hits_float(img, 0.8 * k4 / 4.0, 2.0)
    hit = hits.astype(bool)
    assert not (strict & ~hit).any()
    assert not (hit & ~loose).any()
    assert (hit == ref).mean() > 0.97


def test_a_block_on_a_flat_sea_is_a_hit_of_its_contrast_both_polarities() -> None:
    for sign in (1, -1):
        img = np.full((20, 80), 100, np.uint8)
        img[8:8 + CELL_H, 40:40 + CELL_W] = 100 + sign * 20
        hits, a, bright, _ = cfar_hits(img, 24, 8)
        assert a[8, 40] == 80  # 20 DN in quarters
        assert bright[8, 40] == (sign > 0)
        assert hits[8, 40] == 1
        assert hits.sum() <= 3 * CELL_W * CELL_H  # only cells overlapping the block


def test_a_levelled_horizon_step_and_row_gradients_give_no_hits() -> None:
    rows = np.concatenate([np.full(30, 200), 90 + np.arange(50)]).astype(np.uint8)
    img = np.repeat(rows[:, None], 120, axis=1)
    hits, a, _, _ = cfar_hits(img, 12, 1)
    assert a.max() == 0 and hits.sum() == 0


def test_glitter_raises_its_own_threshold() -> None:
    rng = np.random.default_rng(3)
    img = np.full((40, 400), 100, np.uint8)
    sparkle = rng.random((40, 200)) < 0.08  # glitter on the right half: many bright specks
    img[:, 200:][sparkle] = 180
    img[20:22, 100:104] = 130  # a 30 DN body on the quiet half
    hits, _, _, _ = cfar_hits(img, 24, 8)
    assert hits[20, 100] == 1
    assert hits[:, 240:360].mean() < 0.01  # the same contrast in glitter: rarely


def test_contrast_shape_and_bad_input() -> None:
    a, bright = cfar_contrast(np.zeros((5, 7), np.uint8))
    assert a.shape == bright.shape == (5, 7)
    with pytest.raises(ValueError):
        cfar_contrast(np.zeros((5, 7), np.float32))
