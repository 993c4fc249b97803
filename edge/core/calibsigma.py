"""Calibration uncertainty at a point of the rectified image: row, column and disparity sigmas (issue 16).

The calibration's rotations and focal lengths are fitted (edge.core.calibfit) and carry standard
errors; the mast the rig stands on may lean by up to a tilt bound. Both move where a world
direction lands in the rectified image (the frame of edge.core.rectify: normalised
(x, y) = ((u - cx) / f, (v - cy) / f), looking along world +Z), and so the point's height above
the sea (its row), its bearing (its column) and its range (its disparity).

**Rotations.** A camera's rotation is R = Rz Ry Rx (camera to world). An error d(theta) in one
angle turns every direction the camera reports by the world-frame rotation vector
w = (dR/d theta) R^T (the "vee" of that skew matrix): Rz Ry e_x for rx, Rz e_y for ry, e_z for
rz. A direction d = (x, y, 1) turned by a small w becomes d + w x d; projected back to z = 1
its normalised coordinates move by

    dx = -x y w_x + (1 + x^2) w_y - y w_z
    dy = -(1 + y^2) w_x + x y w_y + x w_z                                           (eq. C.1)

The left camera's move is the point's row and column error; the disparity's is
f (dx_left - dx_right), the right camera evaluated at its own x_r = x - d / f. A mast tilt turns
both cameras together by a horizontal w (about X, pitch; and about Z, roll) of tilt_sigma per
component: it moves rows and columns and almost cancels in the disparity.

**Focal lengths.** A camera whose focal length is off by df reports its own (camera-frame)
normalised coordinates scaled by f / (f + df): (dx_c, dy_c) = -(x_c, y_c) df / f, turned into the
world frame by its rotation R and projected back to z = 1 (eq. C.2; for a camera looking along
+Z simply -(x, y) df / f). In the disparity that is the range scale (both cameras alike:
f (x_l - x_r) df / f = d df / f) plus, where the two differ, an offset growing with the column.

The sources are independent (the per-camera fits are; with tie points the joint fit correlates
them, which this ignores), so the variances add. Float only: this runs once per fix, outside
the integer matching path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from edge.core.camera import rotation_matrix


@dataclass(frozen=True)
class CameraSigma:
    """Standard errors of one camera's fitted pose and scale."""

    rotation_sigma_deg: tuple[float, float, float]  # of rx, ry, rz
    focal_sigma_px: float  # of the focal length (pinhole fx; poly10 1 / a0)


@dataclass(frozen=True)
class RigSigma:
    """The calibration's standard errors, both cameras."""

    left: CameraSigma
    right: CameraSigma


def rotation_axes(rotation_deg: tuple[float, float, float] | np.ndarray) -> np.ndarray:
    """(3, 3): row k is the world-frame rotation vector per radian of angle k (rx, ry, rz) of
    R = Rz Ry Rx: Rz Ry e_x, Rz e_y, e_z."""
    rx, ry, rz = (float(a) for a in rotation_deg)
    r_z = rotation_matrix((0.0, 0.0, rz))
    r_zy = rotation_matrix((0.0, ry, rz))
    return np.stack([r_zy[:, 0], r_z[:, 1], np.array([0.0, 0.0, 1.0])])


def direction_shift(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eq. C.1: the move of normalised (x, y) under a small world rotation w (..., 3), radians."""
    wx, wy, wz = w[..., 0], w[..., 1], w[..., 2]
    return -x * y * wx + (1.0 + x * x) * wy - y * wz, -(1.0 + y * y) * wx + x * y * wy + x * wz


def focal_shift(x: np.ndarray, y: np.ndarray, rotation_deg: tuple[float, float, float],
                rel: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. C.2: the move of world-normalised (x, y) when the camera's focal length is off by the
    relative amount rel (df / f)."""
    r = rotation_matrix(rotation_deg)
    d = np.stack([x, y, np.ones_like(x)], -1)
    c = d @ r  # R^T d: the camera-frame direction (rows)
    c = c / c[..., 2:3]
    dc = np.stack([-c[..., 0] * rel, -c[..., 1] * rel, np.zeros_like(x)], -1)
    rc, drc = c @ r.T, dc @ r.T
    z = rc[..., 2]
    return ((drc[..., 0] - x * drc[..., 2]) / z, (drc[..., 1] - y * drc[..., 2]) / z)


@dataclass(frozen=True)
class Pointing:
    """What the calibration's standard errors and the mast tilt bound do at image points.

    `sigmas(x, y, d)` gives the 1-sigma (row px, column px, disparity px) at rectified normalised
    (x, y) of the left image with disparity d px (arrays broadcast)."""

    f_px: float
    left_deg: tuple[float, float, float]  # the cameras' calibrated rotations
    right_deg: tuple[float, float, float]
    sigma: RigSigma | None  # None: the calibration gave no standard errors
    tilt_sigma_deg: float = 0.0

    def sigmas(self, x: np.ndarray, y: np.ndarray, d_px: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                               np.ndarray]:
        x, y, d_px = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (x, y, d_px)))
        f = self.f_px
        x_r = x - d_px / f
        var_row, var_col, var_disp = np.zeros_like(x), np.zeros_like(x), np.zeros_like(x)

        def add(dxl: np.ndarray, dyl: np.ndarray, dxr: np.ndarray) -> None:
            nonlocal var_row, var_col, var_disp
            var_row = var_row + (f * dyl) ** 2
            var_col = var_col + (f * dxl) ** 2
            var_disp = var_disp + (f * (dxl - dxr)) ** 2

        zero = np.zeros_like(x)
        if self.sigma is not None:
            for side, cam, rot in (("left", self.sigma.left, self.left_deg),
                                   ("right", self.sigma.right, self.right_deg)):
                axes = rotation_axes(rot)
                xs = x if side == "left" else x_r
                for k in range(3):
                    w = axes[k] * math.radians(cam.rotation_sigma_deg[k])
                    dx, dy = direction_shift(xs, y, w)
                    add(dx, dy, zero) if side == "left" else add(zero, zero, dx)
                dx, dy = focal_shift(xs, y, rot, cam.focal_sigma_px / f)  # eq. C.2
                add(dx, dy, zero) if side == "left" else add(zero, zero, dx)
        if self.tilt_sigma_deg > 0.0:
            for axis in (np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])):  # pitch, roll of the mast
                w = axis * math.radians(self.tilt_sigma_deg)
                dxl, dyl = direction_shift(x, y, w)
                dxr, _ = direction_shift(x_r, y, w)
                add(dxl, dyl, dxr)
        return np.sqrt(var_row), np.sqrt(var_col), np.sqrt(var_disp)

    @property
    def known(self) -> bool:
        """Whether the calibration gave standard errors (else the row sigma stays a fixed figure)."""
        return self.sigma is not None
