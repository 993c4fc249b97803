"""The aliasing check (edge.measure.aliascheck): its window cross-check stays quiet on clean
texture and widens the sigma over the biased disparities of aliased periodic detail."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.match import Match, match_point
from edge.measure.aliascheck import DEADZONE_PX, AliasCheck, check_window
from edge.sim import synth

WHOLE, WINDOW = 4, 15


def _sweep(kind: str, psf: float, seed: int, n: int = 8) -> tuple[AliasCheck, list[float], list[float]]:
    """Matches of one scene at n fractional disparities, fed to an AliasCheck: (check, errors, sigmas)."""
    size_y, size_x = WINDOW + 6, WINDOW + 2 * WHOLE + 22
    xc, yc = size_x - WINDOW // 2 - 5, size_y // 2
    scene = synth.make_scene(np.random.default_rng([seed, 1]), size_y + 2 * synth.MARGIN_PX + 2,
                             size_x + WHOLE + 2 * synth.MARGIN_PX + 4, kind)
    rng = np.random.default_rng([seed, 2])
    check, errors, sigmas = AliasCheck(), [], []
    for k in range(n):
        pair = synth.render_pair(scene, rng, WHOLE * synth.SAMPLES_PER_PX + k * synth.SAMPLES_PER_PX // n,
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
    assert check.rms_px() is not None and check.rms_px() <= DEADZONE_PX  # type: ignore[operator]
    assert check.sigma_px() == 0.0
    assert max(abs(e) for e in errors) < 0.05  # and indeed nothing to widen for


@settings(max_examples=6, deadline=None)
@given(st.integers(0, 10_000))
def test_biased_aliased_windows_are_covered_once_the_check_speaks(seed: int) -> None:
    """On sharp periodic detail: where the errors are biased beyond 3 predicted sigmas and the
    check has spoken, the widened sigma covers the RMS error within 3 sigma."""
    check, errors, sigmas = _sweep("periodic", 0.0, seed)
    small = [e for e in errors if abs(e) < 1.0]  # gross whole-pixel slips are the gates' business
    if len(small) < 3 or check.sigma_px() == 0.0:
        return
    rms = math.sqrt(sum(e * e for e in small) / len(small))
    assert rms <= 3.0 * math.hypot(max(sigmas), check.sigma_px())


def test_window_and_invalid_matches() -> None:
    assert check_window(15) == 9 and check_window(9) == 7 and check_window(7) == 7
    check = AliasCheck()
    good = Match(True, 4.0, 1.0, 0.01)
    check.add(good, Match(False, math.nan, math.nan, math.inf))
    assert check.rms_px() is None and check.sigma_px() == 0.0
    for d in (4.2, 3.8, 4.2):
        check.add(good, Match(True, d, 1.0, 0.01))
    assert math.isclose(check.rms_px() or 0.0, 0.2)
    assert math.isclose(check.sigma_px(), 0.6)
    check.clear()
    assert check.rms_px() is None
