"""Sub-pixel reference point tracking on exact-shift renders (the scene moves by known fractions)."""

from __future__ import annotations

import numpy as np
import pytest

from edge.core.refpoint import FollowResult, follow_point
from edge.sim import synth

X0, Y0 = 8 * synth.SAMPLES_PER_PX, 8 * synth.ROWS_PER_PX     # view origin in the fine scene


def _frames(seed: int, u32: int, v8: int, noise_dn: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """prev and cur views of one scene; the scene moved by (u32/32, v8/8) px: cur(x+u) = prev(x)."""
    scene = synth.make_scene(np.random.default_rng(seed), 60, 80, "hull")
    rng = np.random.default_rng(seed + 1000)
    prev = synth.sensor(synth.render_view(scene, X0, Y0, 40, 60), rng, noise_dn)
    cur = synth.sensor(synth.render_view(scene, X0 - u32, Y0 - v8, 40, 60), rng, noise_dn)
    return prev, cur


def test_recovers_exact_sub_pixel_motion() -> None:
    rng = np.random.default_rng(0)
    errors = []
    for seed in range(8):
        for _ in range(6):
            u32, v8 = int(rng.integers(-96, 97)), int(rng.integers(-24, 25))
            prev, cur = _frames(seed, u32, v8)
            t = follow_point(prev, cur, 30.2, 20.4)
            assert t.valid, t.reason
            errors.append((t.dx_px - u32 / 32, t.dy_px - v8 / 8))
            assert t.x_px == pytest.approx(30.2 + t.dx_px) and t.y_px == pytest.approx(20.4 + t.dy_px)
    e = np.array(errors)
    assert np.sqrt((e**2).mean(axis=0)).max() <= 0.03
    assert np.abs(e).max() <= 0.08


def test_integer_path_matches_float_reference() -> None:
    for seed, (u32, v8) in enumerate([(37, 5), (-50, -11), (80, 20), (3, -3)]):
        prev, cur = _frames(seed, u32, v8)
        a = follow_point(prev, cur, 29.7, 19.9)
        b = follow_point(prev, cur, 29.7, 19.9, impl="float")
        assert a.valid and b.valid
        assert abs(a.dx_px - b.dx_px) <= 2 / 256 and abs(a.dy_px - b.dy_px) <= 2 / 256


def test_sub_pixel_point_keeps_its_fraction() -> None:
    prev, cur = _frames(3, 45, -7)
    a, b = follow_point(prev, cur, 30.2, 20.1), follow_point(prev, cur, 29.6, 19.7)   # same window
    assert a.dx_px == b.dx_px and a.dy_px == b.dy_px
    assert a.x_px - b.x_px == pytest.approx(0.6) and a.y_px - b.y_px == pytest.approx(0.4)


def test_follows_a_drifting_point_over_many_frames() -> None:
    scene = synth.make_scene(np.random.default_rng(9), 60, 90, "hull")
    rng = np.random.default_rng(10)
    step_u32, step_v8 = 11, 2                     # 0.34375 px/frame right, 0.25 px/frame down
    views = [synth.sensor(synth.render_view(scene, X0 + 200 - k * step_u32, Y0 - k * step_v8, 40, 60),
                          rng, 1.0) for k in range(16)]
    x, y = 25.0, 18.0
    for prev, cur in zip(views, views[1:], strict=False):
        t = follow_point(prev, cur, x, y, predicted_dx=0.34)
        assert t.valid, t.reason
        assert abs(t.dx_px - step_u32 / 32) <= 0.05 and abs(t.dy_px - step_v8 / 8) <= 0.05
        x, y = t.x_px, t.y_px
    # frame-to-frame errors of one texture are partly systematic (window-specific), so they
    # add up; the bound is 15 steps x 0.025 px, i.e. no runaway and no whole-pixel slips
    assert abs(x - (25.0 + 15 * step_u32 / 32)) < 0.375 and abs(y - (18.0 + 15 * step_v8 / 8)) < 0.375


def test_prediction_extends_the_search() -> None:
    prev, cur = _frames(4, -(32 * 7 + 9), 0)       # -7.28 px: outside a radius-4 search
    assert not follow_point(prev, cur, 30, 20).valid
    t = follow_point(prev, cur, 30, 20, predicted_dx=-7)
    assert t.valid and abs(t.dx_px + 7 + 9 / 32) < 0.05


def test_bad_input_is_invalid_with_a_reason() -> None:
    prev, cur = _frames(5, 10, 2)
    cases = [
        (follow_point(prev.astype(float), cur, 30, 20), "uint8"),
        (follow_point(prev, cur[:, :-1], 30, 20), "shapes differ"),
        (follow_point(prev, cur, 5, 20), "border"),
        (follow_point(prev, cur, 30, float("inf")), "finite"),
        (follow_point(np.full_like(prev, 90), np.full_like(cur, 90), 30, 20), "texture"),
    ]
    for result, reason in cases:
        assert isinstance(result, FollowResult) and not result.valid and reason in result.reason
