"""Rectifier: epipolar rows and d = f B / Z for a rotated, distorted rig; patches equal the scene
sampled on the rectified grid; the identity rig is a plain (bit-exact) slice."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.camera import PinholeCamera, Poly10Camera, StereoRig
from edge.core.rectify import Rectifier

W, H = 320, 240


def _rig(kind: str) -> StereoRig:
    if kind == "pinhole":
        left = PinholeCamera(400.0, 401.0, 159.5, 119.5, (-0.08, 0.05, 2e-4, -1e-4, 0.0), (-1.5, -0.15, 0.1))
        right = PinholeCamera(401.5, 402.0, 160.5, 118.5, (-0.07, 0.04, -1e-4, 2e-4, 0.0),
                              (-1.45, 0.1, -0.05))
    else:
        coeffs = (1 / 400, 1e-6, 2e-9, 3e-9, 1e-9, 1 / 401, -1e-6, 1e-9, 2e-9, 3e-9)
        left = Poly10Camera(159.5, 119.5, coeffs, (-1.0, 0.2, 0.3))
        right = Poly10Camera(160.0, 120.0, coeffs, (-1.1, -0.1, 0.2))
    return StereoRig(8.14, W, H, left, right)


@pytest.fixture(scope="module", params=["pinhole", "poly10"])
def rectifier(request) -> Rectifier:
    return Rectifier(_rig(request.param))


@settings(max_examples=40, deadline=None)
@given(x=st.floats(-300.0, 300.0), y=st.floats(-20.0, 30.0), z=st.floats(200.0, 5000.0))
def test_rows_are_epipolar_and_disparity_is_fb_over_z(rectifier: Rectifier, x: float, y: float,
                                                      z: float) -> None:
    uv_l, uv_r = rectifier.rig.project(np.array([x, y, z]))
    rl, rr = rectifier.raw_to_rect(uv_l, 0), rectifier.raw_to_rect(uv_r, 1)
    assert rl[1] == pytest.approx(rr[1], abs=1e-6)
    assert rl[0] - rr[0] == pytest.approx(rectifier.f_px * 8.14 / z, rel=1e-9, abs=1e-7)
    np.testing.assert_allclose(rectifier.rect_to_raw(rl, 0), uv_l, atol=1e-6)
    assert rectifier.disparity_to_range(rl[0] - rr[0]) == pytest.approx(z, rel=1e-6)


def _scene(xy: np.ndarray) -> np.ndarray:
    """A smooth radiance pattern fixed to the normalised (world-direction) plane."""
    return 128.0 + 60.0 * np.sin(40.0 * xy[..., 0] + 1.0) * np.cos(30.0 * xy[..., 1] - 0.5)


@pytest.mark.parametrize("side", [0, 1])
def test_patch_samples_the_scene_on_the_rectified_grid(rectifier: Rectifier, side: int) -> None:
    camera = rectifier.rig.left if side == 0 else rectifier.rig.right
    vv, uu = np.mgrid[0:H, 0:W].astype(np.float64)
    raw = _scene(camera.pixel_to_normalised(np.stack([uu, vv], -1)))
    image = np.clip(np.round(raw), 0, 255).astype(np.uint8)
    x0, y0, w, h = 100, 90, 60, 25
    patch = rectifier.patch(image, side, x0, y0, w, h).astype(np.float64)
    gv, gu = np.mgrid[y0:y0 + h, x0:x0 + w].astype(np.float64)
    expected = _scene(rectifier.rect_to_normalised(np.stack([gu, gv], -1)))
    # 8-bit rounding (0.5 DN) + bilinear interpolation of a < 3 DN/px, gently curved pattern
    assert np.abs(patch - expected).max() < 1.2


def test_identity_rig_patch_is_a_slice_with_clamped_borders() -> None:
    cam = PinholeCamera(400.0, 400.0, 159.5, 119.5)
    rect = Rectifier(StereoRig(5.0, W, H, cam, cam))
    assert rect.identity
    image = np.random.default_rng(1).integers(0, 256, (H, W), dtype=np.uint8)
    np.testing.assert_array_equal(rect.patch(image, 1, 10, 20, 30, 15), image[20:35, 10:40])
    corner = rect.patch(image, 0, -3, -2, 6, 5)
    np.testing.assert_array_equal(corner[2:, 3:], image[:3, :3])
    np.testing.assert_array_equal(corner[0], corner[2])  # rows above the image repeat row 0
    np.testing.assert_array_equal(rect.raw_to_rect(np.array([12.25, 7.5])), [12.25, 7.5])


def test_non_identity_when_anything_differs() -> None:
    cam = PinholeCamera(400.0, 400.0, 159.5, 119.5)
    assert not Rectifier(StereoRig(5.0, W, H, cam, PinholeCamera(400.0, 400.0, 160.5, 119.5))).identity
    assert not Rectifier(StereoRig(5.0, W, H, cam, PinholeCamera(400.0, 400.0, 159.5, 119.5,
                                                                 rotation_deg=(0.0, 0.0, 0.01)))).identity
