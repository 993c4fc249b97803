"""Exact-shift generator: the two views really are one scene shifted by the stated amount."""

from __future__ import annotations

import numpy as np
import pytest

from edge.sim import synth


def test_whole_pixel_disparity_is_an_exact_crop() -> None:
    scene = synth.make_scene(np.random.default_rng(1), 30, 60, "hull")
    pair = synth.render_pair(scene, np.random.default_rng(2), 32 * 5, height_px=20, width_px=40,
                             noise_dn=0.0)
    # right(x) = left(x + d): the clean right view is the clean left view moved 5 px left
    np.testing.assert_allclose(pair.clean_right[:, :-5], pair.clean_left[:, 5:], atol=1e-9)
    assert pair.disparity_px == 5.0


def test_fractional_shifts_compose() -> None:
    # two 1/32-px steps from one origin equal one 2/32-px step: views depend on the offset only
    scene = synth.make_scene(np.random.default_rng(3), 30, 60, "sharp")
    a = synth.render_view(scene, 200 + 2, 40, 20, 40)
    b = synth.render_view(scene, 202, 40, 20, 40)
    np.testing.assert_array_equal(a, b)
    c = synth.render_view(scene, 200 + 32, 40, 20, 40)
    np.testing.assert_allclose(c[:, :-1], synth.render_view(scene, 200, 40, 20, 40)[:, 1:], atol=1e-9)


def test_sensor_noise_is_independent_and_radiometry_applies() -> None:
    clean = np.full((50, 50), 100.0)
    rng = np.random.default_rng(4)
    a, b = synth.sensor(clean, rng, 2.0), synth.sensor(clean, rng, 2.0)
    da, db = a.astype(float) - 100, b.astype(float) - 100
    assert abs(np.corrcoef(da.ravel(), db.ravel())[0, 1]) < 0.1
    assert np.std(da) == pytest.approx(np.sqrt(4 + 1 / 12), rel=0.1)
    fogged = synth.sensor(clean, rng, 0.0, fog_t=0.5, gain=1.1, offset_dn=-10)
    assert np.all(fogged == round(1.1 * (0.5 * 100 + 0.5 * synth.AIRLIGHT_DN) - 10))


def test_sweep_cramer_rao_is_consistent_with_noise_level() -> None:
    from edge.core.match import match_point
    cond = synth.Condition("t", noise_dn=2.0)
    s = synth.sweep(cond, range(3), lambda l, r, x, y: match_point(l, r, x, y, max_disparity=12),
                    n_fractions=4)
    assert s.errors.shape == (3, 4) and np.isfinite(s.errors).all()
    assert 0.005 < float(np.mean(s.crb_px)) < 0.05
    s4 = synth.sweep(synth.Condition("t", noise_dn=4.0), range(3), lambda *a: match_point(*a), n_fractions=4)
    q = np.sqrt(1 / 12)                          # uint8 rounding noise
    np.testing.assert_allclose(s4.crb_px / s.crb_px, np.hypot(4, q) / np.hypot(2, q), rtol=1e-9)


def test_views_outside_the_scene_are_refused() -> None:
    scene = synth.make_scene(np.random.default_rng(5), 20, 30, "sea")
    with pytest.raises(ValueError):
        synth.render_view(scene, 0, 0, 10, 10)
