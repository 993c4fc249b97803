"""One camera's calibration unknowns as a parameter vector, its starting value and its residuals.

`CameraParams` maps a vector x of order-1 numbers to a `CameraModel` and back
(what `edge.core.calibfit` hands to scipy's least squares):

- pinhole: fx, fy, k1, k2, p1, p2 (k3 optional), rx, ry, rz; the principal
  point is held fixed.
- poly10: a0..a5, a7..a9 (a6 = 0, the gauge against roll: see calibfit) and
  rx, ry, rz; each a_k is stored as b_k = a_k s^deg (s = half the image width,
  deg = the total degree of its term in eq. 3.5), so a cubic coefficient of
  ~1e-10 becomes ~0.01 and finite-difference steps stay meaningful.

The starting value is an undistorted pinhole: the focal length from an
affine fit of pixels to landmark directions, then the rotation (Kabsch /
Wahba, a proper rotation by SVD) and per-axis focal lengths refined in turn.
Residuals are reprojection errors in pixels (eq. 3.3/3.4 with the depths
eliminated; calibfit says why pixels).
"""

from __future__ import annotations

import math

import numpy as np

from edge.core.camera import CameraModel, PinholeCamera, Poly10Camera

BAD_RESIDUAL_PX = 1e4  # stands in for a point a trial model cannot map (keeps least_squares finite)
POLY_DEGREES = (1, 1, 2, 3, 3, 1, 1, 2, 3, 3)  # total degree of the term each a_k multiplies (eq. 3.5)
POLY_FREE = (0, 1, 2, 3, 4, 5, 7, 8, 9)  # a6 fixed at 0
ANGLES = ("rx_deg", "ry_deg", "rz_deg")


class CameraParams:
    """One camera's parameter vector x <-> CameraModel (internal scaling keeps every x of order 1)."""

    def __init__(self, kind: str, cx: float, cy: float, scale_px: float, fit_k3: bool = False) -> None:
        self.kind, self.cx, self.cy, self.scale = kind, cx, cy, scale_px
        if kind == "pinhole":
            self.names = ("fx", "fy", "k1", "k2", "p1", "p2", *(("k3",) if fit_k3 else ()), *ANGLES)
            self.factor = np.ones(len(self.names))
        elif kind == "poly10":
            self.names = (*(f"a{k}" for k in POLY_FREE), *ANGLES)
            degrees = [POLY_DEGREES[k] for k in POLY_FREE]
            self.factor = np.array([scale_px**-d for d in degrees] + [1.0, 1.0, 1.0])  # a_k = b_k / s^deg
        else:
            raise ValueError(f"unknown camera model {kind!r}: pinhole or poly10")

    def initial(self, fx: float, fy: float, angles_deg: np.ndarray) -> np.ndarray:
        if self.kind == "pinhole":
            return np.array([fx, fy, *[0.0] * (len(self.names) - 5), *angles_deg])
        b = np.zeros(len(POLY_FREE))
        b[POLY_FREE.index(0)], b[POLY_FREE.index(5)] = self.scale / fx, self.scale / fy
        return np.concatenate([b, angles_deg])

    def camera(self, x: np.ndarray) -> CameraModel:
        """Raises ValueError for parameters the camera classes refuse (e.g. a negative focal length)."""
        values = x * self.factor
        angles = tuple(float(a) for a in values[-3:])
        if self.kind == "pinhole":
            fx, fy, *dist = (float(v) for v in values[:-3])
            # tuple lengths (5, 3) are checked by the camera's __post_init__
            return PinholeCamera(fx, fy, self.cx, self.cy, (*dist, 0.0)[:5], angles)  # type: ignore[arg-type]
        coeffs = [0.0] * 10
        for k, value in zip(POLY_FREE, values[:-3], strict=True):
            coeffs[k] = float(value)
        return Poly10Camera(self.cx, self.cy, tuple(coeffs), angles)  # type: ignore[arg-type]  # 3 angles


def directions(world_m: np.ndarray, centre_x: float) -> np.ndarray:
    """World-frame normalised coordinates (x/z, y/z) of landmarks seen from a camera at (centre_x, 0, 0)."""
    d = world_m - (centre_x, 0.0, 0.0)
    return d[:, :2] / d[:, 2:3]


def reprojection(model: CameraParams, x: np.ndarray, xy: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Flattened (predicted - observed) pixels of landmarks at world-normalised xy; large where unmappable."""
    try:
        predicted = model.camera(x).normalised_to_pixel(xy)
    except ValueError:
        return np.full(uv.size, BAD_RESIDUAL_PX)
    return np.nan_to_num((predicted - uv).ravel(), nan=BAD_RESIDUAL_PX)


def kabsch(cam_dirs: np.ndarray, world_dirs: np.ndarray) -> np.ndarray:
    """Rotation R minimising sum |w_i - R c_i|^2 (unit vectors), proper (det +1)."""
    u, _, vt = np.linalg.svd(world_dirs.T @ cam_dirs)
    d = np.sign(np.linalg.det(u @ vt))
    return u @ np.diag([1.0, 1.0, d]) @ vt


def angles_from_matrix(r: np.ndarray) -> np.ndarray:
    """(rx, ry, rz) of R = Rz Ry Rx (inverse of camera.rotation_matrix)."""
    return np.degrees(
        [math.atan2(r[2, 1], r[2, 2]), -math.asin(max(-1.0, min(1.0, r[2, 0]))), math.atan2(r[1, 0], r[0, 0])]
    )


def initial_guess(model: CameraParams, xy: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Undistorted pinhole start: focal from an affine fit, then rotation (Kabsch) and focals in turn."""
    centred = uv - (model.cx, model.cy)
    design = np.column_stack([xy, np.ones(len(xy))])
    affine, *_ = np.linalg.lstsq(design, centred, rcond=None)
    fx = fy = math.sqrt(abs(np.linalg.det(affine[:2])))
    world = np.column_stack([xy, np.ones(len(xy))])
    world /= np.linalg.norm(world, axis=1, keepdims=True)
    for _ in range(4):
        cam = np.column_stack([centred / (fx, fy), np.ones(len(xy))])
        rot = kabsch(cam / np.linalg.norm(cam, axis=1, keepdims=True), world)
        q = world @ rot  # camera-frame directions (R^T w)
        q_xy = q[:, :2] / q[:, 2:3]
        fx = float(q_xy[:, 0] @ centred[:, 0] / (q_xy[:, 0] @ q_xy[:, 0]))
        fy = float(q_xy[:, 1] @ centred[:, 1] / (q_xy[:, 1] @ q_xy[:, 1]))
    return model.initial(fx, fy, angles_from_matrix(rot))
