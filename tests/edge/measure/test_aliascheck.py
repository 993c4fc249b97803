"""The aliasing check (edge.measure.aliascheck): its window cross-check stays quiet on clean
texture and widens the sigma over the biased disparities of aliased periodic detail."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.match import Match, match_point
from edge.measure.aliascheck import DEADZONE_PX, GAIN, MAX_SIGMA_PX, AliasCheck, check_window
from edge.sim import synth

WHOLE, WINDOW = 4, 15


def _sweep(kind: str, psf: float, seed: int, n: int = 8, fraction_8ths: int | None = None
           ) -> tuple[AliasCheck, list[float], list[float]]:
    """Matches of one scene at n fractional disparities (or n noisy pairs at one, `fraction_8ths`/8 px:
    a ship at a steady range), fed to an AliasCheck: (check, errors, sigmas)."""
    size_y, size_x = WINDOW + 6, WINDOW + 2 * WHOLE + 22
    xc, yc = size_x - WINDOW // 2 - 5, size_y // 2
    scene = synth.make_scene(np.random.default_rng([seed, 1]), size_y + 2 * synth.MARGIN_PX + 2,
                             size_x + WHOLE + 2 * synth.MARGIN_PX + 4, kind)
    rng = np.random.default_rng([seed, 2])
    check, errors, sigmas = AliasCheck(), [], []
    for k in range(n):
        step = k * synth.SAMPLES_PER_PX // n
        if fraction_8ths is not None:
            step = fraction_8ths * synth.SAMPLES_PER_PX // 8
        pair = synth.render_pair(scene, rng, WHOLE * synth.SAMPLES_PER_PX + step,
                                 height_px=size_y, width_px=size_x, x0_px=synth.MARGIN_PX + 1,
                                 psf_sigma_px=psf, noise_dn=1.0)
        m = match_point(pair.left, pair.right, xc, yc, max_disparity=12, max_sigma_px=0.5)
        if not m.valid:
            continue
        c = match_point(pair.left, pair.right, xc, yc, window=check_window(WINDOW), max_disparity=12,
                        max_sigma_px=0.5, predicted_disparity=m.disparity_px, search_radius=2)
        check.add(m, c)
        errors.append(m.disparity_px - pair.disparity_px)
        sigmas.append(m.sigma_px)
    return check, errors, sigmas


@settings(max_examples=6, deadline=None)
@given(st.integers(0, 10_000))
def test_clean_blurred_texture_adds_no_sigma(seed: int) -> None:
    check, errors, _ = _sweep("hull", 0.35, seed)
    assert check.persistent_px() is not None and check.persistent_px() <= DEADZONE_PX  # type: ignore[operator]
    assert check.sigma_px() == 0.0
    assert max(abs(e) for e in errors) < 0.05  # and indeed nothing to widen for


def test_on_aliased_periodic_detail_the_check_speaks_where_the_bias_is_and_widens_over_it() -> None:
    """Sharp periodic detail at a steady fractional disparity (a ship at a steady range), 5 noisy
    pairs per case: the biased cases (|mean error| > 3 predicted sigma) are many; the check speaks
    almost only on them, on a good share of them, and its uncapped term covers the bias on half.
    (bench-core's "aliasing" section has the figures; the check cannot see a window biased whole.)"""
    biased = spoke = spoke_biased = covered = 0
    for seed in range(8):
        for eighths in (2, 3, 5):
            check, errors, sigmas = _sweep("periodic", 0.0, seed, n=5, fraction_8ths=eighths)
            small = [e for e in errors if abs(e) < 1.0]  # whole-pixel slips are the gates' business
            if len(small) < 3:
                continue
            bias, sigma = abs(float(np.mean(small))), max(sigmas)
            biased += bias > 3.0 * sigma
            if check.sigma_px() > 0.0:
                spoke += 1
                spoke_biased += bias > 3.0 * sigma
                # the uncapped term sizes the window's bias; the product caps it (the pipeline's
                # 15-px windows are seldom biased whole by more: docs/accuracy.md, "Sharp optics")
                assert check.sigma_px() <= MAX_SIGMA_PX
                covered += bias <= 3.0 * math.hypot(sigma, GAIN * (check.persistent_px() or 0.0))
    assert biased >= 6  # the problem is there: the matcher's own sigma does not cover it
    assert spoke >= biased / 3 and spoke_biased >= 0.8 * spoke
    assert covered >= 0.5 * spoke  # 6 of 10 with the 11-px check (the 9-px one: 0.7, but see the module)


def test_window_and_invalid_matches() -> None:
    assert check_window(15) == 11 and check_window(9) == 7 and check_window(7) == 7
    check = AliasCheck()
    good = Match(True, 4.0, 1.0, 0.01)
    check.add(good, Match(False, math.nan, math.nan, math.inf))
    assert check.rms_px() is None and check.sigma_px() == 0.0
    for d in (4.2, 3.8, 4.2):  # disagreements that change sign: noise, no persistent bias
        check.add(good, Match(True, d, 1.0, 0.01))
    assert math.isclose(check.rms_px() or 0.0, 0.2)
    assert check.persistent_px() == 0.0 and check.sigma_px() == 0.0
    check.clear()
    for d in (3.8, 3.79, 3.81, 3.8):  # one window persistently 0.2 px off the other
        check.add(good, Match(True, d, 1.0, 0.01))
    assert 0.18 < check.persistent_px() < 0.2  # type: ignore[operator]
    assert math.isclose(check.sigma_px(), min(MAX_SIGMA_PX, GAIN * (check.persistent_px() or 0.0)))
    check.clear()
    assert check.rms_px() is None
