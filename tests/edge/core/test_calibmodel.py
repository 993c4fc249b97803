"""edge.core.calibmodel: parameter vectors <-> camera models, rotations from directions, starting value."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.calibmodel import (
    CameraParams,
    angles_from_matrix,
    directions,
    initial_guess,
    kabsch,
    reprojection,
)
from edge.core.camera import PinholeCamera, Poly10Camera, rotation_matrix

angle = st.floats(min_value=-80, max_value=80)


@settings(max_examples=50, deadline=None)
@given(st.tuples(angle, angle, angle))
def test_angles_from_matrix_inverts_rotation_matrix(angles: tuple) -> None:
    assert angles_from_matrix(rotation_matrix(angles)) == pytest.approx(angles, abs=1e-9)


@settings(max_examples=30, deadline=None)
@given(st.tuples(angle, angle, angle), st.integers(0, 2**31))
def test_kabsch_recovers_a_rotation_from_noise_free_directions(angles: tuple, seed: int) -> None:
    r = rotation_matrix(angles)
    cam = np.random.default_rng(seed).normal(size=(10, 3))
    cam /= np.linalg.norm(cam, axis=1, keepdims=True)
    got = kabsch(cam, cam @ r.T)
    assert got == pytest.approx(r, abs=1e-12) and np.linalg.det(got) == pytest.approx(1.0)


def test_parameter_vectors_map_to_the_camera_models() -> None:
    pin = CameraParams("pinhole", 359.5, 239.5, 360.0, fit_k3=True)
    cam = pin.camera(np.array([900.0, 901.0, -0.1, 0.02, 1e-4, -1e-4, 0.003, 1.0, -2.0, 0.5]))
    assert cam == PinholeCamera(
        900.0, 901.0, 359.5, 239.5, (-0.1, 0.02, 1e-4, -1e-4, 0.003), (1.0, -2.0, 0.5)
    )
    assert CameraParams("pinhole", 0, 0, 1).names[-4:] == ("p2", "rx_deg", "ry_deg", "rz_deg")  # k3 off
    poly = CameraParams("poly10", 359.5, 239.5, 360.0)
    x = poly.initial(900.0, 910.0, np.array([0.1, 0.2, 0.3]))
    assert x[0] == pytest.approx(0.4) and np.abs(x).max() < 1.0  # order-1 internal values
    cam = poly.camera(x)
    assert isinstance(cam, Poly10Camera) and cam.coeffs[0] == pytest.approx(1 / 900) and cam.coeffs[6] == 0.0
    assert cam.coeffs[5] == pytest.approx(1 / 910) and cam.rotation_deg == (0.1, 0.2, 0.3)
    with pytest.raises(ValueError, match="unknown camera model"):
        CameraParams("fisheye", 0, 0, 1)


def test_initial_guess_lands_next_to_an_undistorted_camera() -> None:
    truth = PinholeCamera(914.0, 920.0, 359.5, 239.5, rotation_deg=(-1.5, 0.7, 0.3))
    rng = np.random.default_rng(0)
    uv = rng.uniform((0, 0), (720, 480), size=(20, 2))
    z = rng.uniform(50, 3000, 20)
    world = np.column_stack([truth.pixel_to_normalised(uv) * z[:, None], z]) + (4.07, 0, 0)
    xy = directions(world, 4.07)
    params = CameraParams("pinhole", 359.5, 239.5, 360.0)
    x0 = initial_guess(params, xy, uv)
    assert x0[:2] == pytest.approx([914.0, 920.0], rel=1e-5)
    assert x0[-3:] == pytest.approx([-1.5, 0.7, 0.3], abs=1e-4)
    assert np.abs(reprojection(params, x0, xy, uv)).max() < 0.01  # px: least squares starts at the answer
    bad = x0.copy()
    bad[0] = -1.0  # the camera class refuses it: a large finite residual, not an exception
    assert (reprojection(params, bad, xy, uv) == 1e4).all()
