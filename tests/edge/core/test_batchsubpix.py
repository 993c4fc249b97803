"""Batched sub-pixel fits: bit-identical to the per-point integer routines (`match._gauss6` and
`match.refine`'s parabola, the references) on random and textured data, fits and failures alike."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.batchsubpix import gauss6_q8_batch, ncc_terms_batch, parabola3_q8, vertex_fits_q
from edge.core.match import NO_BRACKET, CostArithmetic, _gauss6, refine
from edge.core.subpixel import _ncc_terms, gauss_fit_q
from edge.sim.synth import make_scene, render_view, sensor

COLS = 80


def _bands(rng: np.random.Generator, w: int, kind: str, shift32: int = 96) -> tuple[np.ndarray, np.ndarray]:
    """A left band and a right band holding it 20 px to the left plus up to shift32 / 32 px, or noise."""
    if kind == "noise":
        return (rng.integers(0, 256, (w, COLS)).astype(np.uint8),
                rng.integers(0, 256, (w, COLS)).astype(np.uint8))
    if kind == "flat":
        return np.full((w, COLS), 100, np.uint8), np.full((w, COLS), 100, np.uint8)
    scene = make_scene(rng, 60, 130, "hull")
    u32 = int(rng.integers(-shift32, shift32 + 1))
    left = sensor(render_view(scene, 400, 64, w, COLS), rng, 1.0)
    right = sensor(render_view(scene, 400 - u32, 64, w, COLS), rng, 1.0)
    return left, np.ascontiguousarray(np.roll(right, -20, axis=1))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 12), st.sampled_from([15, 9, 3]))
def test_gauss6_batch_equals_the_per_point_routine(seed: int, n: int, w: int) -> None:
    rng = np.random.default_rng(seed)
    kinds = rng.choice(["scene", "scene", "scene", "noise", "flat"], n)
    bands = [_bands(rng, w, str(k)) for k in kinds]
    h = w // 2
    xls = [int(x) for x in rng.integers(34, COLS - h - 4, n)]   # both bands hold the passes
    d0s = [20 + int(d) for d in rng.integers(-3, 4, n)]          # near and off the true disparity
    got = gauss6_q8_batch([a for a, _ in bands], [b for _, b in bands], xls, d0s)
    arith = CostArithmetic("int", "zssd")
    ref = [_gauss6(arith, a, b, x, d) for (a, b), x, d in zip(bands, xls, d0s, strict=True)]
    assert got == ref


def test_gauss6_batch_covers_fits_and_failures() -> None:
    """Textured bands at their disparity give values, noise and flat bands give None, each as the
    reference does (so the test above exercises both outcomes)."""
    rng = np.random.default_rng(3)
    bands = [_bands(rng, 15, "scene", 15) for _ in range(20)] + [_bands(rng, 15, "flat") for _ in range(3)]
    xls, d0s = [40] * len(bands), [20] * len(bands)
    got = gauss6_q8_batch([a for a, _ in bands], [b for _, b in bands], xls, d0s)
    arith = CostArithmetic("int", "zssd")
    assert got == [_gauss6(arith, a, b, x, d) for (a, b), x, d in zip(bands, xls, d0s, strict=True)]
    assert sum(v is not None for v in got) >= 12
    assert got[-3:] == [None] * 3
    assert gauss6_q8_batch([], [], [], []) == []


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 6), st.sampled_from([15, 7]), st.booleans())
def test_ncc_terms_batch_equals_per_point(seed: int, n: int, w: int, extreme: bool) -> None:
    rng = np.random.default_rng(seed)
    h = w // 2
    lefts = rng.integers(0, 256, (n, w, 40)).astype(np.uint8)
    rights = rng.integers(0, 256, (n, w, 40)).astype(np.uint8)
    if extreme:
        lefts[:, :, ::2], rights[:, :, 1::2] = 255, 0
    xls, d0s = rng.integers(h + 2 + 6, 40 - h - 4, n), rng.integers(0, 6, n)
    regions = np.stack([np.stack((a[:, x - h - 2:x + h + 4], b[:, x - d - h - 2:x - d + h + 4]))
                        for a, b, x, d in zip(lefts, rights, xls, d0s, strict=True)])
    got = ncc_terms_batch(regions)
    for k in range(n):
        np.testing.assert_array_equal(got[k], _ncc_terms(lefts[k], rights[k], int(xls[k]), int(d0s[k])))


@settings(max_examples=100, deadline=None)
@given(st.lists(st.lists(st.integers(-(2**33), 2**33), min_size=4, max_size=4), min_size=1, max_size=8),
       st.integers(-200, 200))
def test_vertex_fits_equal_gauss_fit_q(curves: list[list[int]], first: int) -> None:
    """Any integer curves (ties, ends, flat, far vertices): the fit where gauss_fit_q has one, and
    not ok exactly where it has none."""
    fits, ok = vertex_fits_q(np.array(curves, dtype=np.int64), np.full(len(curves), first, np.int64))
    for c, f, good in zip(curves, fits.tolist(), ok.tolist(), strict=True):
        ref = gauss_fit_q(c, first)
        assert good == (ref is not None)
        if good:
            assert f == ref


@settings(max_examples=150, deadline=None)
@given(st.lists(st.lists(st.integers(-(2**40), 2**40), min_size=3, max_size=3), min_size=1, max_size=8),
       st.lists(st.integers(-300, 300), min_size=8, max_size=8))
def test_parabola3_equals_refine(curves: list[list[int]], d0s: list[int]) -> None:
    """Any 3-point integer curves (ties, no minimum, far vertices): refine's parabola where it has
    one, and not ok exactly where it has none."""
    d0 = np.array(d0s[:len(curves)], dtype=np.int64)
    got, ok = parabola3_q8(np.array(curves, dtype=np.int64), d0)
    arith = CostArithmetic("int", "zssd")
    for c, d, q, good in zip(curves, d0.tolist(), got.tolist(), ok.tolist(), strict=True):
        value, reason = refine(arith, np.zeros((1, 1), np.uint8), np.zeros((1, 1), np.uint8), 0, d - 1,
                               np.array(c, dtype=np.int64), 1, "parabola")
        assert good == (value is not None)
        if good:
            assert q == value
        else:
            assert reason == NO_BRACKET
