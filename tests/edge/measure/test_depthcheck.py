"""The depth check (edge.measure.depthcheck): its sub-windows agree on a fronto-parallel patch and
disagree, by about the step, where the window straddles two depths; its term on known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import band_texture
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.match import Match, match_point
from edge.measure.depthcheck import GAIN, MAX_SIGMA_PX, OFFSETS, SUB_WINDOW, DepthCheck

H, W, U, V, D_PX = 41, 96, 60, 20, 6.0


def _pair(rng: np.random.Generator, seed: int, step_px: float) -> tuple[np.ndarray, np.ndarray]:
    """A textured patch whose part right of column U lies step_px farther in disparity (a depth
    step through the point), read noise 1 DN on both views."""
    tex = band_texture(seed, H, W + 20)
    cols = np.arange(W, dtype=np.float32)
    right = np.empty((H, W), np.float32)
    for y in range(H):  # right(x) shows left(x + d), d by the side of the step the left point is on
        src = cols + D_PX
        src = np.where(src >= U, cols + D_PX + step_px, src)
        right[y] = np.interp(src, np.arange(W + 20), tex[y])
    noisy = [np.clip(np.round(a + rng.normal(0.0, 1.0, a.shape)), 0, 255).astype(np.uint8)
             for a in (tex[:, :W], right)]
    return noisy[0], noisy[1]


def _check(seed: int, step_px: float, pairs: int = 6) -> DepthCheck:
    rng, check = np.random.default_rng(seed), DepthCheck()
    for _ in range(pairs):
        left, right = _pair(rng, seed, step_px)
        m = match_point(left, right, U, V, max_disparity=16, max_sigma_px=0.5)
        assert m.valid
        for k, (du, dv) in enumerate(OFFSETS):
            sub = match_point(left, right, U + du, V + dv, window=SUB_WINDOW, max_disparity=16,
                              max_sigma_px=0.5, predicted_disparity=m.disparity_px, search_radius=2)
            check.add(k, m, sub)
    return check


@settings(max_examples=5, deadline=None)
@given(st.integers(0, 10_000))
def test_a_fronto_parallel_patch_adds_next_to_nothing(seed: int) -> None:
    assert _check(seed, 0.0).sigma_px() < 0.03  # the noise of 7-px windows averages out


@pytest.mark.parametrize("step_px", [0.3, 0.6])
def test_a_depth_step_through_the_window_widens_by_about_the_step(step_px: float) -> None:
    # left and right sub-windows lie wholly on either side: they disagree with the mixed main match
    # by about +-step/2, the ones above and below by ~0, so the term is GAIN x step / (2 sqrt 2)
    want = min(MAX_SIGMA_PX, GAIN * step_px / (2.0 * math.sqrt(2.0)))
    got = [_check(seed, step_px).sigma_px() for seed in range(3)]
    assert all(0.6 * want <= g <= 1.3 * want for g in got), (want, got)


def test_known_answers_and_invalid_matches() -> None:
    main, check = Match(True, 5.0, 1.0, 0.01), DepthCheck()
    assert check.sigma_px() == 0.0
    for _ in range(4):
        check.add(0, main, Match(True, 5.2, 1.0, 0.01))  # one sub-window steadily 0.2 px off
        check.add(1, main, Match(False, math.nan, math.nan, math.inf))  # never valid: ignored
    assert math.isclose(check.sigma_px(), GAIN * math.sqrt(0.2**2 / 4))
    for k in range(4):
        for _ in range(4):
            check.add(k, main, Match(True, 6.0, 1.0, 0.01))
    assert check.sigma_px() == MAX_SIGMA_PX  # capped
    check.clear()
    for d in (5.1, 4.9, 5.1, 4.9):  # disagreements that change sign: noise
        check.add(2, main, Match(True, d, 1.0, 0.01))
    assert check.sigma_px() == 0.0
