"""Camera models: round trips over the whole image, and OpenCV as an independent implementation."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from edge.core.camera import PinholeCamera, Poly10Camera, StereoRig, rotation_matrix

SIZES = [(720, 480), (2048, 1536)]
small_angle = st.floats(-4.0, 4.0)
rotations = st.tuples(small_angle, small_angle, small_angle)
PLAIN = PinholeCamera(900.0, 900.0, 360.0, 240.0)


def _grid(width: int, height: int, n: int = 33) -> np.ndarray:
    """Points covering the whole image, corners and edges included."""
    u, v = np.meshgrid(np.linspace(0.0, width - 1.0, n), np.linspace(0.0, height - 1.0, n))
    return np.stack([u, v], axis=-1)


def _focal(width: int, fov_deg: float) -> float:
    return width / (2.0 * math.tan(math.radians(fov_deg) / 2.0))


@st.composite
def pinholes(draw, width: int, height: int) -> PinholeCamera:
    f = _focal(width, draw(st.floats(30.0, 60.0)))
    return PinholeCamera(
        fx=f,
        fy=f * draw(st.floats(0.99, 1.01)),
        cx=(width - 1) / 2 + draw(st.floats(-20.0, 20.0)),
        cy=(height - 1) / 2 + draw(st.floats(-20.0, 20.0)),
        dist=(
            draw(st.floats(-0.25, 0.1)),
            draw(st.floats(0.0, 0.08)),
            draw(st.floats(-2e-3, 2e-3)),
            draw(st.floats(-2e-3, 2e-3)),
            draw(st.floats(-0.01, 0.01)),
        ),
        rotation_deg=draw(rotations),
    )


@st.composite
def poly10s(draw, width: int, height: int) -> Poly10Camera:
    a0 = 1.0 / _focal(width, draw(st.floats(30.0, 60.0)))
    cubic = st.floats(-0.05, 0.3).map(lambda c: c * a0**3)  # barrel undistortion, as a camera's k1 < 0
    cross = st.floats(-1e-3, 1e-3).map(lambda c: c * a0 * a0)
    skew = st.floats(-1e-3, 1e-3).map(lambda c: c * a0)
    coeffs = (
        a0, draw(skew), draw(cross), draw(cubic), draw(cubic),
        a0 * draw(st.floats(0.99, 1.01)), draw(skew), draw(cross), draw(cubic), draw(cubic),
    )  # fmt: skip
    return Poly10Camera(
        cx=(width - 1) / 2 + draw(st.floats(-20.0, 20.0)),
        cy=(height - 1) / 2 + draw(st.floats(-20.0, 20.0)),
        coeffs=coeffs,
        rotation_deg=draw(rotations),
    )


def _cameras(width: int, height: int) -> st.SearchStrategy:
    return st.one_of(pinholes(width, height), poly10s(width, height))


@pytest.mark.parametrize("width,height", SIZES)
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_pixel_normalised_pixel_round_trip_over_whole_image(width: int, height: int, data) -> None:
    camera = data.draw(_cameras(width, height))
    uv = _grid(width, height)
    back = camera.normalised_to_pixel(camera.pixel_to_normalised(uv))
    assert np.all(np.isfinite(back))
    assert np.abs(back - uv).max() < 1e-6


@pytest.mark.parametrize("width,height", SIZES)
@settings(max_examples=30, deadline=None)
@given(data=st.data())
def test_random_pixel_round_trip(width: int, height: int, data) -> None:
    camera = data.draw(_cameras(width, height))
    u = data.draw(st.floats(0.0, width - 1.0))
    v = data.draw(st.floats(0.0, height - 1.0))
    back = camera.normalised_to_pixel(camera.pixel_to_normalised([u, v]))
    assert back.shape == (2,)
    assert np.abs(back - (u, v)).max() < 1e-6


@settings(max_examples=40, deadline=None)
@given(angles=st.tuples(*(st.floats(-30.0, 30.0),) * 3))
def test_rotation_matrix_is_rz_ry_rx(angles: tuple[float, float, float]) -> None:
    expected = Rotation.from_euler("xyz", angles, degrees=True).as_matrix()  # extrinsic x, then y, then z
    assert np.allclose(rotation_matrix(angles), expected, atol=1e-14)


@settings(max_examples=30, deadline=None)
@given(camera=pinholes(2048, 1536))
def test_pinhole_matches_opencv(camera: PinholeCamera) -> None:
    """Our closed-form distortion equals cv2.projectPoints; Newton undistortion cv2.undistortPoints."""
    k = np.array([[camera.fx, 0.0, camera.cx], [0.0, camera.fy, camera.cy], [0.0, 0.0, 1.0]])
    dist = np.array(camera.dist)
    xy = np.random.default_rng(1).uniform(-0.6, 0.6, (200, 2))
    rays = np.concatenate([xy, np.ones((200, 1))], axis=1)
    cv_uv, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), k, dist)
    assert np.abs(camera.camera_to_pixel(xy) - cv_uv.reshape(-1, 2)).max() < 1e-9

    uv = _grid(2048, 1536, 9).reshape(-1, 2)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-15)
    cv_xy = cv2.undistortPoints(uv.reshape(-1, 1, 2), k, dist, R=None, P=None, criteria=criteria).reshape(
        -1, 2
    )
    assert np.abs(camera.pixel_to_camera(uv) - cv_xy).max() < 1e-7


@settings(max_examples=30, deadline=None)
@given(left=pinholes(720, 480), right=pinholes(720, 480), baseline_m=st.floats(1.0, 20.0))
def test_rig_projection_matches_opencv(left: PinholeCamera, right: PinholeCamera, baseline_m: float) -> None:
    """World -> pixel through rotation and distortion agrees with cv2.projectPoints given rvec/tvec."""
    rig = StereoRig(baseline_m, 720, 480, left, right)
    rng = np.random.default_rng(2)
    pts = np.stack([rng.uniform(-0.3, 0.3, 100), rng.uniform(-0.2, 0.2, 100), np.ones(100)], axis=1)
    pts *= rng.uniform(30.0, 6000.0, (100, 1))
    for camera, uv, centre_x in (
        (left, rig.project(pts)[0], -baseline_m / 2),
        (right, rig.project(pts)[1], baseline_m / 2),
    ):
        r_wc = camera.rotation().T  # world -> camera
        # cv2.Rodrigues(matrix) returns a zero vector whenever sin(angle) < 1e-5, so take the
        # rotation vector from scipy's exact conversion; projectPoints stays the independent part.
        rvec = Rotation.from_matrix(r_wc).as_rotvec()
        tvec = -r_wc @ np.array([centre_x, 0.0, 0.0])
        k = np.array([[camera.fx, 0.0, camera.cx], [0.0, camera.fy, camera.cy], [0.0, 0.0, 1.0]])
        cv_uv, _ = cv2.projectPoints(pts, rvec, tvec, k, np.array(camera.dist))
        assert np.abs(uv - cv_uv.reshape(-1, 2)).max() < 1e-8


@pytest.mark.parametrize("kind", ["pinhole", "poly10"])
def test_rig_project_then_triangulate_recovers_points(kind: str) -> None:
    cams = {
        "pinhole": PinholeCamera(
            912.0, 910.0, 361.0, 238.0, (-0.2, 0.05, 1e-3, -1e-3, 0.0), (1.0, -2.0, 0.5)
        ),
        "poly10": Poly10Camera(
            360.0, 240.0, (1 / 912, 1e-7, 1e-10, 2.6e-10, 2.6e-10, 1 / 910, -1e-7, 1e-10, 2.6e-10, 2.6e-10)
        ),
    }
    rig = StereoRig(
        8.14, 720, 480, cams[kind], PinholeCamera(905.0, 905.0, 359.5, 239.5, rotation_deg=(-1, 1, 0))
    )
    rng = np.random.default_rng(3)
    z = rng.uniform(50.0, 6000.0, 500)
    pts = np.stack([rng.uniform(-0.3, 0.3, 500) * z, rng.uniform(-0.2, 0.2, 500) * z, z], axis=1)
    est = rig.triangulate(*rig.project(pts))
    assert np.abs(est - pts).max(axis=-1).max() / z.min() < 1e-9
    assert np.all(np.abs(est - pts).max(axis=-1) / z < 1e-9)


def test_unmappable_points_are_nan_not_wrong() -> None:
    rig = StereoRig(8.0, 720, 480, PLAIN, PLAIN)
    uv_l, uv_r = rig.project([[0.0, 0.0, -100.0], [0.0, 0.0, 100.0]])
    assert np.all(np.isnan(uv_l[0])) and np.all(np.isnan(uv_r[0]))
    assert np.all(np.isfinite(uv_l[1]))
    # a strong pincushion folds over far outside the image: Newton cannot invert there -> NaN
    folded = PinholeCamera(900, 900, 360, 240, dist=(-0.5, 0.0, 0.0, 0.0, 0.0))
    assert np.all(np.isnan(folded.pixel_to_camera([[360.0 + 900 * 1.0, 240.0]])))


def test_focal_and_to_dict() -> None:
    pin = PinholeCamera(912, 910, 359.5, 239.5, (-0.2, 0.05, 1e-3, -1e-3, 0.0), (0.5, -1, 2))
    poly = Poly10Camera(360, 240, (1 / 800, 0, 0, 0, 0, 1 / 800, 0, 0, 0, 0), (0, 0, 1))
    assert pin.focal_px() == 912.0 and poly.focal_px() == pytest.approx(800.0)
    assert StereoRig(8.14, 720, 480, pin, poly).focal_px() == pytest.approx(856.0)
    assert pin.to_dict() == {
        "model": "pinhole", "fx": 912.0, "fy": 910.0, "cx": 359.5, "cy": 239.5,
        "dist": [-0.2, 0.05, 1e-3, -1e-3, 0.0], "rotation_deg": [0.5, -1.0, 2.0],
    }  # fmt: skip
    assert poly.to_dict()["model"] == "poly10" and len(poly.to_dict()["coeffs"]) == 10
    assert PinholeCamera(**{k: v for k, v in pin.to_dict().items() if k != "model"}) == pin


@pytest.mark.parametrize(
    "build",
    [
        lambda: PinholeCamera(0.0, 900, 360, 240),
        lambda: PinholeCamera(900, -1.0, 360, 240),
        lambda: PinholeCamera(900, 900, float("nan"), 240),
        lambda: PinholeCamera(900, 900, 360, 240, dist=(0.1, 0.0)),
        lambda: PinholeCamera(900, 900, 360, 240, rotation_deg=(0.0, float("inf"), 0.0)),
        lambda: Poly10Camera(360, 240, (1e-3,) * 9),
        lambda: Poly10Camera(360, 240, (-1e-3,) + (0.0,) * 4 + (1e-3,) + (0.0,) * 4),
        lambda: StereoRig(0.0, 720, 480, PLAIN, PLAIN),
        lambda: StereoRig(8.0, 720.5, 480, PLAIN, PLAIN),
    ],
)
def test_obviously_wrong_values_are_refused(build) -> None:
    with pytest.raises(ValueError):
        build()
