"""match_point: exact integer costs, acceptance accuracy on exact-shift renders, integer vs float
reference, sub-pixel left points, validity gates and bad input."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core import Match, match_point, match_point_float
from edge.core.costs import cost_curve, cost_curve_float, cost_curve_reference
from edge.sim.synth import Condition, make_scene, render_pair, sweep

SEEDS = range(9100, 9116)          # evaluation-style seeds for unit tests (bench uses its own)


@settings(max_examples=60)
@given(st.integers(0, 2**32 - 1), st.integers(1, 10), st.integers(1, 40), st.sampled_from([255, 510]),
       st.sampled_from(["ssd", "zssd"]))
def test_fast_curve_is_bit_exact(seed: int, half: int, n: int, top: int, cost: str) -> None:
    rng = np.random.default_rng(seed)
    w = 2 * half + 1
    band = rng.integers(0, top + 1, (w, w + n - 1))
    template = rng.integers(0, top + 1, (w, w))
    if seed % 3 == 0:
        band[:], template[:] = top, 0                  # extreme values
    ref = cost_curve_reference(template, band, cost)
    np.testing.assert_array_equal(cost_curve(template, band, cost), ref)
    scale = w * w if cost == "zssd" else 1
    np.testing.assert_allclose(cost_curve_float(template, band, cost) * scale, ref, rtol=1e-9, atol=1e-3)


def _scene_pair(d32: int, noise_dn: float = 1.0, seed: int = 3, **kw: float):
    scene = make_scene(np.random.default_rng(seed), 40, 160, "hull")
    return render_pair(scene, np.random.default_rng(seed + 1), d32, height_px=31, width_px=100,
                       noise_dn=noise_dn, **kw)


def test_known_disparity_all_methods_and_impls() -> None:
    pair = _scene_pair(32 * 37 + 11)                    # d = 37.34375 px
    for sub, tol in (("none", 0.5), ("parabola", 0.1), ("cancel-oneway", 0.04), ("cancel", 0.03),
                     ("cancel6", 0.03), ("cancel6-gauss", 0.03)):
        results = [match_point(pair.left, pair.right, 70.0, 15.0, max_disparity=60, subpixel=sub,
                               impl=impl) for impl in ("int", "int-ref", "float")]
        assert all(m.valid for m in results), [m.reason for m in results]
        assert results[0] == results[1]                 # fast integer == plain int64 definition
        assert abs(results[0].disparity_px - pair.disparity_px) <= tol
        assert abs(results[0].disparity_px - results[2].disparity_px) <= 1 / 256
        assert results[0].disparity_int == 37
        assert results[0].disparity_q8 == round(results[0].disparity_px * 256)


def _errors(cond: Condition, **kw: object) -> np.ndarray:
    m = functools.partial(match_point, max_disparity=12, noise_dn=cond.noise_dn, **kw)
    return sweep(cond, SEEDS, m, n_fractions=16).errors


def _rms(e: np.ndarray) -> float:
    return float(np.sqrt(np.mean(e**2)))


def test_acceptance_textured_fog_and_mismatch() -> None:
    tex = _errors(Condition("tex"))
    assert np.isfinite(tex).all()
    rms_tex = _rms(tex)
    assert rms_tex <= 0.02
    assert np.abs(tex.mean(axis=0)).max() <= 0.01
    fog = _errors(Condition("fog", fog_t=0.15))
    assert np.isfinite(fog).all() and np.abs(fog).max() < 1.0          # no gross errors
    assert _rms(fog) <= 0.07
    for kw in ({"gain": 0.9}, {"gain": 1.1}, {"offset_dn": 10.0}, {"offset_dn": -10.0}):
        e = _errors(Condition("mismatch", **kw))
        assert np.isfinite(e).all() and _rms(e) <= 1.1 * rms_tex, kw


def test_rms_near_cramer_rao_bound() -> None:
    cond = Condition("tex4", noise_dn=4.0)
    s = sweep(cond, SEEDS, functools.partial(match_point, max_disparity=12, noise_dn=4.0), n_fractions=8)
    ratio = _rms(s.errors) / float(np.sqrt(np.mean(s.crb_px**2)))
    assert 1.0 <= ratio <= 1.5          # a ratio below 1 would mean the harness leaks information


@pytest.mark.parametrize("cond", [Condition("tex"), Condition("sharp", kind="sharp", psf_sigma_px=0.25),
                                  Condition("fog", fog_t=0.15), Condition("gain", gain=0.9, noise_dn=4),
                                  Condition("vert", vertical_8ths=2)], ids=lambda c: c.name)
@pytest.mark.parametrize("sub", ["cancel", "cancel6", "cancel6-gauss", "parabola"])
def test_integer_within_one_q8_lsb_of_float_reference(cond: Condition, sub: str) -> None:
    rng = np.random.default_rng(7)
    scene = make_scene(rng, 40, 80, cond.kind)
    for k in range(0, 32, 3):
        pair = render_pair(scene, rng, 32 * 5 + k, height_px=31, width_px=60, noise_dn=cond.noise_dn,
                           fog_t=cond.fog_t, gain=cond.gain, psf_sigma_px=cond.psf_sigma_px,
                           vertical_offset_8ths=cond.vertical_8ths)
        mi = match_point(pair.left, pair.right, 40, 15, max_disparity=12, subpixel=sub)
        mf = match_point_float(pair.left, pair.right, 40, 15, max_disparity=12, subpixel=sub)
        assert mi.valid and mf.valid
        assert abs(mi.disparity_px - mf.disparity_px) <= 1 / 256


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31), st.integers(0, 31),
       st.sampled_from(["cancel", "cancel6", "cancel6-gauss"]))
def test_integer_half_pixel_passes_match_float_on_random_renders(seed: int, k: int, sub: str) -> None:
    rng = np.random.default_rng(seed)
    pair = render_pair(make_scene(rng, 40, 80, "hull"), rng, 32 * 5 + k, height_px=31, width_px=60)
    mi = match_point(pair.left, pair.right, 40, 15, max_disparity=12, subpixel=sub)
    mf = match_point_float(pair.left, pair.right, 40, 15, max_disparity=12, subpixel=sub)
    assert mi.valid == mf.valid
    if mi.valid:
        assert abs(mi.disparity_px - mf.disparity_px) <= 1 / 256


def test_sub_pixel_left_point_uses_the_rounded_window() -> None:
    pair = _scene_pair(32 * 20 + 8)
    at = {x: match_point(pair.left, pair.right, x, 15.2) for x in (60.0, 60.3, 60.49, 60.5, 61.0)}
    assert at[60.3].disparity_px == at[60.0].disparity_px == at[60.49].disparity_px
    assert at[60.5].disparity_px == at[61.0].disparity_px         # half rounds away from zero
    assert at[60.3].x_right_px == pytest.approx(60.3 - at[60.3].disparity_px)
    assert abs(at[60.3].x_right_px - (60.3 - pair.disparity_px)) < 0.03


def test_predicted_disparity_narrows_the_search() -> None:
    pair = _scene_pair(32 * 30)
    near = match_point(pair.left, pair.right, 70, 15, predicted_disparity=29.6, search_radius=3)
    assert near.valid and abs(near.disparity_px - 30) < 0.05
    far = match_point(pair.left, pair.right, 70, 15, predicted_disparity=10, search_radius=3)
    assert not far.valid and "edge of the search range" in far.reason
    with pytest.raises(ValueError):
        match_point(pair.left, pair.right, 70, 15, search_radius=3)


def test_gates_flag_flat_and_periodic_windows() -> None:
    flat = np.full((31, 100), 120, dtype=np.uint8)
    m = match_point(flat, flat, 60, 15)
    assert not m.valid and "texture" in m.reason and m.sigma_px == np.inf
    stripes = np.tile(np.repeat(np.array([40, 200], dtype=np.uint8), 4), (31, 13))[:, :100]
    m = match_point(stripes, np.roll(stripes, -3, axis=1), 60, 15, max_disparity=30)
    assert not m.valid and "ambiguous" in m.reason


def test_sigma_predicts_the_random_error() -> None:
    errors, sigmas = [], []
    scene = make_scene(np.random.default_rng(11), 40, 80, "hull")
    rng = np.random.default_rng(12)
    for _ in range(40):
        pair = render_pair(scene, rng, 32 * 5 + 16, height_px=31, width_px=60, noise_dn=4.0)
        m = match_point(pair.left, pair.right, 40, 15, max_disparity=12, noise_dn=4.0)
        errors.append(m.disparity_px)
        sigmas.append(m.sigma_px)
    assert 0.5 < float(np.std(errors)) / float(np.mean(sigmas)) < 2.0


@pytest.mark.parametrize("left,right,x,y,reason", [
    (np.zeros((31, 60)), np.zeros((31, 60)), 30, 15, "uint8"),
    (np.zeros((31, 60, 3), np.uint8), np.zeros((31, 60, 3), np.uint8), 30, 15, "2-D"),
    (np.zeros((31, 60), np.uint8), np.zeros((31, 61), np.uint8), 30, 15, "shapes differ"),
    ([[1, 2]], [[1, 2]], 0, 0, "numpy array"),
    (None, None, 0, 0, "numpy array"),
])
def test_bad_images_are_invalid_not_exceptions(left, right, x, y, reason) -> None:
    m = match_point(left, right, x, y)
    assert isinstance(m, Match) and not m.valid and reason in m.reason


def test_bad_points_and_ranges_are_invalid() -> None:
    pair = _scene_pair(32 * 10)
    cases = {
        (3.0, 15.0, 0, 128): "border", (70.0, 2.0, 0, 128): "border", (98.0, 15.0, 0, 128): "border",
        (float("nan"), 15.0, 0, 128): "finite", (70.0, 15.0, 20, 10): "empty search range",
        (10.0, 15.0, 5, 128): "empty search range",
    }
    for (x, y, lo, hi), reason in cases.items():
        m = match_point(pair.left, pair.right, x, y, min_disparity=lo, max_disparity=hi)
        assert not m.valid and reason in m.reason, (x, y, m.reason)
    assert "numeric" in match_point(pair.left, pair.right, "a", 3).reason
    with pytest.raises(ValueError):
        match_point(pair.left, pair.right, 70, 15, cost="sad")
    with pytest.raises(ValueError):
        match_point(pair.left, pair.right, 70, 15, window=14)


def test_real_imagery_no_worse_than_stereobm() -> None:
    """Middlebury 2014 motorcycle (bundled with scikit-image, a test-only dependency): with the
    clipped x-Sobel prefilter our ZSSD+cancellation is at least as good as OpenCV StereoBM at the
    same textured points (RMS and median against ground truth, gross errors no more)."""
    pytest.importorskip("skimage")
    from lab.bench import real
    pair = real.load_motorcycle()
    pts = real.textured_points(pair, 9)
    errors = real.evaluate(pair, pts)
    rows = {r[0]: r for r in real.summary(errors, np.ones(len(pts), dtype=bool))}
    bm = rows["OpenCV StereoBM (1/16 px)"]
    for ours in (rows["xsobel15 + ZSSD+cancel"], rows["xsobel15 + ZSSD+cancel6-gauss"]):
        assert int(ours[2]) > 1000
        assert float(ours[3]) <= float(bm[3]) + 0.002          # gross-error rate
        assert float(ours[4]) <= float(bm[4])                   # RMS
        assert float(ours[5]) <= float(bm[5])                   # median |error|
        assert float(ours[1]) >= float(bm[1]) - 0.03           # valid share (rejects, not errors)




def test_the_appliance_has_no_research_subpixel_method() -> None:
    """"refit" lives in the lab (lab.subpix registers it); the appliance alone refuses it by name."""
    import subprocess
    import sys

    code = ("import numpy as np\nfrom edge.core.match import match_point, subpixel_methods\n"
            "assert 'refit' not in subpixel_methods(), subpixel_methods()\n"
            "img = np.zeros((40, 80), np.uint8)\n"
            "try:\n    match_point(img, img, 40, 20, subpixel='refit')\nexcept ValueError as e:\n"
            "    assert 'subpixel' in str(e)\nelse:\n    raise SystemExit('refit accepted')\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
