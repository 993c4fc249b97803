"""The compiled kernels (native/, edge.core.native) against the NumPy reference beside them: patches,
matches and follows bit for bit, the ground filter's IMM within a bound (its NumPy products go through
the BLAS, whose summation order is its own); and the batched NumPy path still checked now that the
pipeline runs the compiled one."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core import native
from edge.measure.groundtrack import GroundTrack, measurement_cov

_SPEC = importlib.util.spec_from_file_location("batchmatch_properties",
                                               Path(__file__).with_name("test_batchmatch.py"))
assert _SPEC is not None and _SPEC.loader is not None
batched = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(batched)

COMPILED = native.kernels


def test_the_compiled_kernels_are_installed() -> None:
    """tools/_setup.sh builds them (native/): without them the pipeline runs about three times slower."""
    assert COMPILED is not None, "mast_native is not installed: run tools/test (tools/_setup.sh builds it)"


needs_kernels = pytest.mark.skipif(COMPILED is None, reason="the compiled kernels are not installed")


@pytest.fixture
def numpy_only(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(native, "kernels", None)


def test_the_batched_numpy_path_still_equals_the_per_point_reference(numpy_only: None) -> None:
    """test_batchmatch's properties with the kernels off (the pipeline's fallback, and the reference the
    compiled path was written against)."""
    batched.test_track_points_equal_track_point()
    batched.test_track_points_fast_path_is_taken_and_exact()
    batched.test_match_points_equal_match_point()
    batched.test_match_points_fast_path_is_taken_and_exact()


@needs_kernels
@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(2, 70), st.integers(2, 70), st.integers(-12, 80),
       st.integers(-12, 80), st.integers(1, 40), st.integers(1, 40))
def test_a_patch_is_cv2_remap_bit_for_bit(seed: int, height: int, width: int, x0: int, y0: int, w: int,
                                          h: int) -> None:
    """Random fixed-point maps (every fraction, positions off the image, unmappable pixels), patches
    inside and across the map's edges: Rectifier.patch's indexing of the maps, then cv2.remap."""
    rng = np.random.default_rng(seed)
    image = rng.integers(0, 256, (height, width), dtype=np.uint8)
    fx = rng.uniform(-3, width + 3, (height, width)).astype(np.float32)
    fy = rng.uniform(-3, height + 3, (height, width)).astype(np.float32)
    fx[rng.random((height, width)) < 0.05] = -1e4
    map1, map2 = cv2.convertMaps(fx, fy, cv2.CV_16SC2)
    rows = np.clip(np.arange(y0, y0 + h), 0, height - 1)
    cols = np.clip(np.arange(x0, x0 + w), 0, width - 1)
    ref = cv2.remap(image, map1[np.ix_(rows, cols)], map2[np.ix_(rows, cols)], cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_REPLICATE)
    out = np.empty((h, w), np.uint8)
    COMPILED.remap(image, map1, map2, x0, y0, out)
    np.testing.assert_array_equal(out, ref)


def _drive(track: GroundTrack, steps: list[tuple]) -> list[tuple[bool, np.ndarray, np.ndarray]]:
    out = []
    for t_s, z, r, reseat in steps:
        taken = track.update(t_s, z, r, reseat=reseat)
        x, p = track.state()
        out.append((taken, x, p))
    return out


@needs_kernels
@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_compiled_ground_filter_agrees_with_numpy_to_1e9(seed: int) -> None:
    """A ship's fixes with outliers, gaps, re-seats and irregular periods through both IMMs: the same
    decisions (taken, gated, re-seated) and states within 1e-9 of the largest entry (measured: 1.4e-12;
    the last-place differences of the BLAS's products, nothing that reaches a decision or an output)."""
    rng = np.random.default_rng(seed)
    pos, vel = rng.uniform(-3000, 3000, 2), rng.uniform(-8, 8, 2)
    steps, t_s = [], 0.0
    for _ in range(50):
        dt = float(rng.choice([0.1, 0.1, 0.3, 1.0]))
        t_s += dt
        pos = pos + vel * dt
        z = pos + rng.normal(0, 5, 2) + (300.0 if rng.random() < 0.05 else 0.0)
        r = measurement_cov(float(rng.uniform(0, 2 * np.pi)), float(rng.uniform(1, 50)),
                            float(rng.uniform(0.5, 5)))
        gap = rng.random() < 0.1
        steps.append((t_s, None if gap else z, None if gap else r, bool(rng.random() < 0.02)))
    compiled = _drive(GroundTrack(), steps)
    native.kernels = None
    try:
        reference = _drive(GroundTrack(), steps)
    finally:
        native.kernels = COMPILED
    for (taken, x, p), (taken_ref, x_ref, p_ref) in zip(compiled, reference, strict=True):
        assert taken == taken_ref
        assert np.max(np.abs(x - x_ref)) <= 1e-9 * np.max(np.abs(x_ref))
        assert np.max(np.abs(p - p_ref)) <= 1e-9 * np.max(np.abs(p_ref))


@needs_kernels
def test_the_six_pass_fallback_is_compiled_and_exact() -> None:
    """Windows where the six-pass Gaussian has no fit (a correlation not positive, a log curve without
    an interior minimum): the compiled matcher's parabola fits of the six passes, and their failures,
    equal refine's."""
    from edge.core.match import CostArithmetic, _gauss6, match_point, round_half_away

    lefts, rights = batched._views(11, 160, flat_share=0.0)
    rng = np.random.default_rng(12)
    fallbacks = 0
    for left, right in zip(lefts, rights, strict=True):
        right = np.ascontiguousarray(np.roll(right, -20, axis=1))
        noisy = np.clip(right.astype(int) + rng.integers(-60, 61, right.shape), 0, 255).astype(np.uint8)
        x, y = float(rng.uniform(45, 75)), float(rng.uniform(10, 34))
        got = batched.match_points([left, left], [right, noisy], [x, x], [y, y], [40, 40], [20.0, 20.0],
                                   search_radius=4)
        for m, r in zip(got, (right, noisy), strict=True):
            ref = match_point(left, r, x, y, max_disparity=40, predicted_disparity=20.0, search_radius=4)
            assert repr(m) == repr(ref)
            gated = ref.reason.startswith(("minimum at the edge", "ambiguous", "half-pixel passes run off"))
            if ref.disparity_int is not None and not gated:
                yi, h = round_half_away(y), 7
                if _gauss6(CostArithmetic("int", "zssd"), left[yi - h:yi + h + 1], r[yi - h:yi + h + 1],
                           round_half_away(x), ref.disparity_int) is None:
                    fallbacks += 1
    assert fallbacks >= 3, "no window took the fallback: the test lost its point"
