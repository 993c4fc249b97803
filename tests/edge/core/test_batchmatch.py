"""Batched matching: bit-identical to the per-point core functions (the reference) on every input,
the fast path and the fallbacks alike."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.batchmatch import _share_curves, batch_costs, match_points, track_points
from edge.core.costs import cost_curve_reference
from edge.core.match import SUBPIXEL_METHODS, match_point, search_range
from edge.core.refpoint import follow_point
from edge.sim.synth import make_scene, render_view, sensor

ROWS, COLS = 44, 90


def _views(seed: int, n: int, flat_share: float = 0.0) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """n pairs of views of textured scenes, the second moved by a random sub-pixel (u, v) (stereo:
    the same rows, a disparity), some of them flat (no texture) to exercise the gates."""
    rng = np.random.default_rng(seed)
    firsts, seconds = [], []
    for _ in range(n):
        scene = make_scene(rng, 60, 130, "hull")
        u32, v8 = int(rng.integers(-96, 97)), int(rng.integers(-16, 17))
        a = sensor(render_view(scene, 400, 64, ROWS, COLS), rng, 1.0)
        b = sensor(render_view(scene, 400 - u32, 64 - v8, ROWS, COLS), rng, 1.0)
        if rng.random() < flat_share:
            a[:], b[:] = 100, 100
        firsts.append(a)
        seconds.append(b)
    return firsts, seconds


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([1, 2, 3, 5, 7, 8, 11, 14]), st.integers(1, 14),
       st.integers(0, 12), st.integers(0, 12))
def test_batch_costs_are_the_reference_integers(seed: int, half: int, n_items: int, extra_rows: int,
                                                extra_cols: int) -> None:
    rng = np.random.default_rng(seed)
    w = 2 * half + 1
    templates = rng.integers(0, 256, (n_items, w, w)).astype(np.uint8)
    regions = rng.integers(0, 256, (n_items, w + extra_rows, w + extra_cols)).astype(np.uint8)
    if seed % 4 == 0:
        templates[:], regions[:] = 0, 255              # extreme values
    elif seed % 4 == 1:
        templates[:], regions[:] = 255, 255            # the largest cross-correlation
    for cost in ("zssd", "ssd"):
        got = batch_costs(templates, regions, cost)
        for k in range(n_items):
            for v in range(extra_rows + 1):
                ref = cost_curve_reference(templates[k], regions[k, v:v + w], cost)
                np.testing.assert_array_equal(got[k, v], ref)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 9), st.sampled_from(["parabola", "cancel", "none"]),
       st.sampled_from([(15, 4), (11, 3), (7, 2)]), st.floats(0.3, 2.0))
def test_track_points_equal_track_point(seed: int, n: int, subpixel: str, window_radius: tuple[int, int],
                                        max_sigma_px: float) -> None:
    window, radius = window_radius
    prevs, curs = _views(seed, n, flat_share=0.15)
    rng = np.random.default_rng(seed + 1)
    xs = rng.uniform(-5, COLS + 5, n)                  # some too near the border, some outside
    ys = rng.uniform(-5, ROWS + 5, n)
    dxs, dys = rng.uniform(-3, 3, n), rng.uniform(-1.5, 1.5, n)
    if n > 2:
        xs[0] = np.nan                                  # not finite
        curs[1] = curs[1][:-1]                          # shapes differ
    kw = dict(window=window, search_radius=radius, subpixel=subpixel, noise_dn=1.0, max_sigma_px=max_sigma_px)
    got = track_points(prevs, curs, xs, ys, dxs, dys, **kw)
    ref = [follow_point(prevs[i], curs[i], xs[i], ys[i], predicted_dx=dxs[i], predicted_dy=dys[i], **kw)
           for i in range(n)]
    assert repr(got) == repr(ref)                       # repr: NaN fields compare equal


def test_track_points_fast_path_is_taken_and_exact() -> None:
    """Points well inside textured views: all valid, each equal to the per-point result."""
    prevs, curs = _views(5, 24)
    rng = np.random.default_rng(6)
    xs, ys = rng.uniform(30, 60, 24), rng.uniform(18, 26, 24)
    got = track_points(prevs, curs, xs, ys, [0.0] * 24, [0.0] * 24, subpixel="parabola", max_sigma_px=1.0)
    ref = [follow_point(p, c, x, y, subpixel="parabola", max_sigma_px=1.0)
           for p, c, x, y in zip(prevs, curs, xs, ys, strict=True)]
    assert sum(t.valid for t in got) >= 20
    assert got == ref


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 9), st.sampled_from(SUBPIXEL_METHODS),
       st.sampled_from(["zssd", "ssd"]),
       st.sampled_from([15, 9]), st.sampled_from([None, 2, 4]))
def test_match_points_equal_match_point(seed: int, n: int, subpixel: str, cost: str, window: int,
                                        radius: int | None) -> None:
    lefts, rights = _views(seed, n, flat_share=0.15)
    rights = [np.ascontiguousarray(np.roll(r, -20, axis=1)) for r in rights]    # disparities around 20
    rng = np.random.default_rng(seed + 2)
    xs, ys = rng.uniform(-4, COLS + 4, n), rng.uniform(-4, ROWS + 4, n)
    max_d = [int(m) for m in rng.integers(3, 60, n)]
    preds = [None if rng.random() < 0.4 else float(rng.uniform(-5, 45)) for _ in range(n)]
    if n > 2:
        preds[0] = float("inf")                         # a prediction that is not finite
        lefts[1] = lefts[1].astype(np.int16)            # not 8-bit
    kw = dict(window=window, cost=cost, subpixel=subpixel, noise_dn=1.0, max_sigma_px=0.5)
    got = match_points(lefts, rights, xs, ys, max_d, preds, search_radius=radius, **kw)
    ref = [match_point(lefts[i], rights[i], xs[i], ys[i], max_disparity=max_d[i],
                       predicted_disparity=preds[i], search_radius=None if preds[i] is None else radius, **kw)
           for i in range(n)]
    assert repr(got) == repr(ref)


def test_match_points_fast_path_is_taken_and_exact() -> None:
    lefts, rights = _views(7, 24)
    rights = [np.ascontiguousarray(np.roll(r, -20, axis=1)) for r in rights]
    rng = np.random.default_rng(8)
    xs, ys = rng.uniform(45, 75, 24), rng.uniform(10, 34, 24)
    preds = [None if k % 3 == 0 else 20.0 + float(rng.uniform(-2, 2)) for k in range(24)]
    got = match_points(lefts, rights, xs, ys, [40] * 24, preds, search_radius=4)
    ref = [match_point(lefts[k], rights[k], xs[k], ys[k], max_disparity=40, predicted_disparity=preds[k],
                       search_radius=None if preds[k] is None else 4) for k in range(24)]
    assert sum(m.valid for m in got) >= 18
    assert repr(got) == repr(ref)


def test_match_points_share_one_product_across_range_lengths() -> None:
    """Predictions near zero clip the search range to different lengths; the short ranges are widened
    to share a product (fewer groups than lengths) and the results still equal match_point's."""
    lefts, rights = _views(9, 16)
    rights = [np.ascontiguousarray(np.roll(r, -3, axis=1)) for r in rights]    # disparities around 3
    rng = np.random.default_rng(10)
    xs, ys = rng.uniform(40, 70, 16), rng.uniform(10, 34, 16)
    preds = [float(p) for p in np.linspace(0.0, 6.0, 16)]
    got = match_points(lefts, rights, xs, ys, [30] * 16, preds, search_radius=4)
    ref = [match_point(lefts[k], rights[k], xs[k], ys[k], max_disparity=30, predicted_disparity=preds[k],
                       search_radius=4) for k in range(16)]
    assert repr(got) == repr(ref)
    assert sum(m.valid for m in got) >= 10
    searches = [(k, 0.0, 0.0, round(xs[k]), 20, lo, hi) for k, lo, hi in
                [(k, *search_range(round(xs[k]), COLS, 15, 0, 30, preds[k], 4)) for k in range(16)]]
    lengths = {hi - lo + 1 for *_, lo, hi in searches}
    assert len(lengths) >= 3 and len(_share_curves(searches, [COLS] * 16, 7)) < len(lengths)
