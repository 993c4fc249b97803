"""Triangulation (eq. 4.1) against OpenCV, and the error model (eq. 4.5, 4.6, 4.9) against triangulation."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.camera import PinholeCamera, StereoRig
from edge.core.triangulation import (
    epsilon,
    pixel_angle,
    position_error,
    range_error,
    range_sigma,
    range_sigma_bounds,
    relative_range_error_k,
    triangulate_normalised,
    viewing_angle_range_error,
)

angle = st.floats(-5.0, 5.0)


@st.composite
def rigs(draw) -> StereoRig:
    def camera() -> PinholeCamera:
        f = draw(st.floats(500.0, 4000.0))
        return PinholeCamera(
            f, f * draw(st.floats(0.98, 1.02)), draw(st.floats(300, 1700)), draw(st.floats(200, 1300)),
            rotation_deg=(draw(angle), draw(angle), draw(angle)),
        )  # fmt: skip

    return StereoRig(draw(st.floats(0.5, 30.0)), 2048, 1536, camera(), camera())


def _projection_matrix(camera: PinholeCamera, centre_x: float) -> np.ndarray:
    """P = K [R^T | -R^T C]: built from the rig's parameters, independent of our projection code."""
    k = np.array([[camera.fx, 0.0, camera.cx], [0.0, camera.fy, camera.cy], [0.0, 0.0, 1.0]])
    r_wc = camera.rotation().T
    return k @ np.hstack([r_wc, (-r_wc @ np.array([centre_x, 0.0, 0.0]))[:, None]])


def _random_points(
    rng: np.random.Generator, n: int, z_min: float = 20.0, z_max: float = 6000.0
) -> np.ndarray:
    z = rng.uniform(z_min, z_max, n)
    return np.stack([rng.uniform(-0.3, 0.3, n) * z, rng.uniform(-0.2, 0.2, n) * z, z], axis=1)


@settings(max_examples=50, deadline=None)
@given(rig=rigs(), seed=st.integers(0, 2**32 - 1))
def test_triangulation_agrees_with_opencv(rig: StereoRig, seed: int) -> None:
    pts = _random_points(np.random.default_rng(seed), 200)
    p_l = _projection_matrix(rig.left, -rig.baseline_m / 2)
    p_r = _projection_matrix(rig.right, rig.baseline_m / 2)
    hom = np.hstack([pts, np.ones((len(pts), 1))])
    uv_l = (hom @ p_l.T)[:, :2] / (hom @ p_l.T)[:, 2:]
    uv_r = (hom @ p_r.T)[:, :2] / (hom @ p_r.T)[:, 2:]
    cv_h = cv2.triangulatePoints(p_l, p_r, uv_l.T.copy(), uv_r.T.copy())
    cv_pts = (cv_h[:3] / cv_h[3]).T
    ours = rig.triangulate(uv_l, uv_r)
    rel = np.linalg.norm(ours - cv_pts, axis=1) / np.linalg.norm(cv_pts, axis=1)
    assert rel.max() < 1e-9, rel.max()


def test_perturbing_x_right_moves_the_estimate_by_eq_4_5() -> None:
    rng = np.random.default_rng(5)
    baseline_m = 8.14
    pts = _random_points(rng, 2000)
    xy_l = np.stack([(pts[:, 0] + baseline_m / 2) / pts[:, 2], pts[:, 1] / pts[:, 2]], axis=1)
    xy_r = np.stack([(pts[:, 0] - baseline_m / 2) / pts[:, 2], pts[:, 1] / pts[:, 2]], axis=1)
    base = triangulate_normalised(xy_l, xy_r, baseline_m)
    for eps in (epsilon(0.5, 720, 43.0), epsilon(0.11, 2048, 43.0), -epsilon(0.15, 720, 43.0)):
        moved = triangulate_normalised(xy_l, xy_r + (eps, 0.0), baseline_m)
        predicted = position_error(base, eps, baseline_m)
        # float precision: the shift is a difference of ~Z-sized numbers, so its error is a few ulp of Z
        assert np.all(np.abs((moved - base) - predicted) <= 1e-12 * base[:, 2:3] + 1e-12 * np.abs(predicted))
        assert np.allclose(range_error(base[:, 2], eps, baseline_m), predicted[:, 2], rtol=1e-14, atol=0.0)


def test_epsilon_is_delta_pixels_through_a_camera() -> None:
    """eq. 4.6 against a camera whose 720 px span 43 deg: delta px off-centre is eps normalised."""
    f = 720 / (2 * math.tan(math.radians(43.0) / 2))
    cam = PinholeCamera(f, f, 359.5, 239.5)
    for delta in (0.5, 0.15, 0.11):
        shift = cam.pixel_to_normalised([359.5 + delta, 239.5])[0]
        assert shift == pytest.approx(epsilon(delta, 720, 43.0), rel=1e-12)
    assert pixel_angle(720, 43.0) == pytest.approx(2 * math.tan(math.radians(21.5)) / 720, rel=1e-15)
    assert np.allclose(
        epsilon(np.array([1.0, 2.0]), 720, 43.0), [pixel_angle(720, 43.0), 2 * pixel_angle(720, 43.0)]
    )
    with pytest.raises(ValueError):
        epsilon(0.5, 0, 43.0)
    with pytest.raises(ValueError):
        epsilon(0.5, 720, 180.0)


@settings(max_examples=50, deadline=None)
@given(k=st.floats(2.0, 1000.0), delta_alpha_deg=st.floats(-0.05, 0.05))
def test_eq_4_9_is_both_viewing_angles_turned_towards_each_other(k: float, delta_alpha_deg: float) -> None:
    baseline_m = 8.14
    d = k * baseline_m
    da = math.radians(delta_alpha_deg)
    alpha = math.atan(baseline_m / 2 / d)  # each camera sees the target alpha off its axis, inwards
    xy_l = np.array([math.tan(alpha - da), 0.0])
    xy_r = np.array([-math.tan(alpha - da), 0.0])
    z = triangulate_normalised(xy_l, xy_r, baseline_m)[2]
    expected = viewing_angle_range_error(k, da)
    if not np.isfinite(expected):
        assert np.isnan(z)
    else:
        assert (z - d) / d == pytest.approx(float(expected), rel=1e-7, abs=1e-13)


def test_relative_error_against_k() -> None:
    eps = epsilon(0.5, 720, 43.0)
    z = np.array([100.0, 1500.0, 5000.0])
    assert np.allclose(relative_range_error_k(z / 8.14, eps), range_error(z, eps, 8.14) / z, rtol=1e-13)
    assert relative_range_error_k(2.0 / eps, eps) == np.inf  # disparity gone: unmeasurable
    assert range_error(8.14 / eps, eps, 8.14) == np.inf


def test_range_sigma_first_order_and_exact_bounds() -> None:
    """sigma_Z = Z^2 sigma_d / (f B); the exact (near, far) pair brackets it and is the 1-sigma quantiles."""
    f_px, baseline_m, sigma_d = 912.0, 8.14, 0.15
    z = np.array([500.0, 1500.0, 3000.0, 5000.0])
    first = range_sigma(z, sigma_d, f_px, baseline_m)
    assert np.allclose(first, z**2 * sigma_d / (f_px * baseline_m))
    near, far = range_sigma_bounds(z, sigma_d, f_px, baseline_m)
    assert np.all(near < 0) and np.all(-near < first) and np.all(far > first)
    assert np.allclose(near, -(first / (1 + first / z)), rtol=1e-12)
    # Monte Carlo: the range is a monotone function of the disparity, so the 15.87 % / 84.13 % quantiles
    # of Z' - Z are exactly the bounds; sampling error of a quantile with 4e5 draws is ~0.4 % of sigma.
    rng = np.random.default_rng(7)
    for zi, lo, hi in zip(z, near, far, strict=True):
        d_px = f_px * baseline_m / zi + rng.normal(0.0, sigma_d, 400_000)
        dz = f_px * baseline_m / d_px - zi  # eq. 2.12
        q_lo, q_hi = np.quantile(dz, [0.158655, 0.841345])
        assert q_lo == pytest.approx(lo, rel=0.02) and q_hi == pytest.approx(hi, rel=0.02)


def test_no_positive_disparity_is_nan() -> None:
    out = triangulate_normalised([[0.01, 0.0], [0.0, 0.0]], [[0.02, 0.0], [0.0, 0.0]], 8.0)
    assert np.all(np.isnan(out))
