"""edge.core.calibsigma and calibfit.rig_sigma: calibration standard errors at image points (issue 16).

- the standard errors `rig_sigma` takes from the fit match a Monte Carlo of the fit on synthetic
  landmarks (angles and focal length, pinhole and poly10);
- eq. C.1's shift of a direction under a small angle error matches a finite difference through
  the real camera models (random rotations and pixels);
- `Pointing.sigmas` (row, column, disparity) matches the finite-difference propagation of every
  source through the cameras, the mast tilt included.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from calib_rigs import BASELINE, CENTRE, RIGS, H, W, fit, landmarks
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.calibfit import rig_sigma
from edge.core.calibmodel import angles_from_matrix
from edge.core.calibsigma import CameraSigma, Pointing, RigSigma, direction_shift, rotation_axes
from edge.core.camera import PinholeCamera, StereoRig, rotation_matrix

F = 914.0
C = CENTRE


@pytest.mark.parametrize("model", sorted(RIGS))
def test_standard_errors_match_a_monte_carlo_of_the_fit(model: str) -> None:
    truth = RIGS[model]()
    rng = np.random.default_rng(16)
    errors, reported = [], []
    for _ in range(20):
        pts, ul, ur = landmarks(truth, 14, rng, z_range=(150.0, 3000.0))
        got = fit(model, pts, ul + rng.normal(0, 0.3, ul.shape), ur + rng.normal(0, 0.3, ur.shape))
        sig = rig_sigma(got)
        row_e, row_s = [], []
        for side in ("left", "right"):
            cam, ref, s = getattr(got.rig, side), getattr(truth, side), getattr(sig, side)
            row_e += [*np.subtract(cam.rotation_deg, ref.rotation_deg), cam.focal_px() - ref.focal_px()]
            row_s += [*s.rotation_sigma_deg, s.focal_sigma_px]
        errors.append(row_e)
        reported.append(row_s)
    spread = np.sqrt(np.mean(np.square(errors), axis=0))  # per parameter, over the seeds
    claimed = np.sqrt(np.mean(np.square(reported), axis=0))
    ratio = spread / claimed
    assert np.all((ratio > 0.6) & (ratio < 1.6)), ratio  # 20 seeds: the RMS itself scatters by ~16 %
    assert 0.8 < math.sqrt(np.mean(ratio**2)) < 1.25, ratio


def _pinhole(rot: tuple[float, float, float], f: float = F) -> PinholeCamera:
    """A calibrated camera; `f` the focal length (both axes: the file's focal_sigma_px is one scale).
    No distortion: eq. C.2 is the focal length's effect on normalised coordinates, and a lens's
    distortion would scale it by a few per cent at the corners (1 + 3 k1 r^2)."""
    return PinholeCamera(f, f, *C, (0.0, 0.0, 0.0, 0.0, 0.0), rot)


@settings(max_examples=25, deadline=None)
@given(angles=st.lists(st.floats(-3, 3), min_size=3, max_size=3), k=st.integers(0, 2),
       u=st.floats(0, W - 1), v=st.floats(0, H - 1))
def test_direction_shift_matches_a_finite_difference(angles: list, k: int, u: float, v: float) -> None:
    rot = (angles[0], angles[1], angles[2])
    cam = _pinhole(rot)
    h_deg = 1e-4
    bumped = list(rot)
    bumped[k] += h_deg
    xy0 = cam.pixel_to_normalised(np.array([[u, v]]))[0]
    xy1 = _pinhole((bumped[0], bumped[1], bumped[2])).pixel_to_normalised(np.array([[u, v]]))[0]
    dx, dy = direction_shift(xy0[0], xy0[1], rotation_axes(rot)[k] * math.radians(h_deg))
    scale = math.radians(h_deg)
    assert (xy1[0] - xy0[0]) / scale == pytest.approx(dx / scale, abs=2e-3)
    assert (xy1[1] - xy0[1]) / scale == pytest.approx(dy / scale, abs=2e-3)


ROT_L, ROT_R = (-1.5, -0.15, 0.1), (-1.45, 0.1, -0.05)
SIGMA = RigSigma(CameraSigma((0.004, 0.006, 0.02), 0.8), CameraSigma((0.005, 0.003, 0.015), 0.6))
TILT_DEG = 0.01
TRUE_RIG = StereoRig(BASELINE, W, H, _pinhole(ROT_L), _pinhole(ROT_R))


def _rectified(left: PinholeCamera, right: PinholeCamera, point: np.ndarray) -> np.ndarray:
    """(row, column, disparity) px of a world point as the *calibrated* cameras (these) see the raw
    pixels the true cameras (ROT_L/ROT_R, F) recorded."""
    ul, ur = TRUE_RIG.project(point[None])
    xl = left.pixel_to_normalised(ul)[0]
    xr = right.pixel_to_normalised(ur)[0]
    return np.array([F * xl[1], F * xl[0], F * (xl[0] - xr[0])])


def _tilted(rot: tuple[float, float, float], w: np.ndarray) -> tuple[float, float, float]:
    r = rotation_matrix(w) @ rotation_matrix(rot)
    a = angles_from_matrix(r)
    return (float(a[0]), float(a[1]), float(a[2]))


@settings(max_examples=6, deadline=None)
@given(u=st.floats(20, W - 20), v=st.floats(20, H - 20), z=st.floats(300.0, 5000.0))
def test_pointing_sigmas_match_finite_difference_propagation(u: float, v: float, z: float) -> None:
    rig = StereoRig(BASELINE, W, H, _pinhole(ROT_L), _pinhole(ROT_R))
    xy = rig.left.pixel_to_normalised(np.array([[u, v]]))[0]
    point = np.array([xy[0] * z - BASELINE / 2, xy[1] * z, z])
    base = _rectified(_pinhole(ROT_L), _pinhole(ROT_R), point)
    var = np.zeros(3)
    h = 1e-4  # deg (and px for the focal length): small enough for first order
    for side, cam in (("left", SIGMA.left), ("right", SIGMA.right)):
        for k in range(3):
            rot = list(ROT_L if side == "left" else ROT_R)
            rot[k] += h
            cams = (_pinhole((rot[0], rot[1], rot[2])), _pinhole(ROT_R)) if side == "left" else \
                (_pinhole(ROT_L), _pinhole((rot[0], rot[1], rot[2])))
            var += ((_rectified(*cams, point) - base) / h * cam.rotation_sigma_deg[k]) ** 2
        cams = (_pinhole(ROT_L, F + h), _pinhole(ROT_R)) if side == "left" else \
            (_pinhole(ROT_L), _pinhole(ROT_R, F + h))
        var += ((_rectified(*cams, point) - base) / h * cam.focal_sigma_px) ** 2
    for axis in ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)):  # the mast leaning about X and about Z
        w = np.array(axis) * h
        cams = (_pinhole(_tilted(ROT_L, w)), _pinhole(_tilted(ROT_R, w)))
        var += ((_rectified(*cams, point) - base) / h * TILT_DEG) ** 2
    expected = np.sqrt(var)
    pointing = Pointing(F, ROT_L, ROT_R, SIGMA, TILT_DEG)
    d_px = base[2]
    got = np.array([float(a) for a in pointing.sigmas(np.array(xy[0]), np.array(xy[1]), np.array(d_px))])
    # row, column, disparity
    assert got == pytest.approx(expected, rel=0.02, abs=2e-4)


def test_no_standard_errors_and_no_tilt_give_zero_and_the_pitch_dominates_the_row() -> None:
    none = Pointing(F, ROT_L, ROT_R, None)
    assert not none.known
    assert [float(a) for a in none.sigmas(np.array(0.1), np.array(0.05), np.array(4.0))] == [0.0, 0.0, 0.0]
    pitch_only = RigSigma(CameraSigma((0.005, 0.0, 0.0), 0.0), CameraSigma((0.0, 0.0, 0.0), 0.0))
    row, col, disp = Pointing(F, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), pitch_only).sigmas(
        np.array(0.0), np.array(0.0), np.array(4.0))
    assert float(row) == pytest.approx(F * math.radians(0.005))  # eq. C.1 at the centre: f w_x
    assert float(col) == pytest.approx(0.0, abs=1e-12)
    assert float(disp) == pytest.approx(0.0, abs=1e-12)  # the right camera's pitch was exact
