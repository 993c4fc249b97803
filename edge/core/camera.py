"""Camera models and the stereo rig: pixels <-> rotation-compensated normalised coordinates.

Every camera maps a pixel (u, v) — (0, 0) at the centre of the top-left pixel,
u right, v down — to *camera-frame* normalised coordinates (x, y) on the plane
z = 1 (`pixel_to_camera`), then rotates that ray into the world frame with its
rotation R and re-normalises so the third component is 1 again
(`pixel_to_normalised`, eq. 3.9/3.10). In those coordinates both cameras look
along +Z with rows as epipolar lines, and eq. 4.1 triangulates.

Two models, both vectorised over arrays of shape (..., 2):

- `PinholeCamera`: OpenCV's pinhole with radial/tangential distortion
  (k1, k2, p1, p2, k3). normalised -> pixel is the closed-form distortion;
  pixel -> normalised inverts it by Newton's method with the analytic 2x2
  Jacobian until the residual is below `INVERSE_TOL` (1e-12 in normalised
  units, i.e. < 1e-8 px for any focal length below 10^4 px).
- `Poly10Camera`: the thesis's polynomial (eq. 3.5), pixel -> camera-frame
  normalised directly; the inverse by the same Newton iteration, to the same
  residual tolerance on the normalised side.

Points that cannot be mapped (a ray behind the camera, or a distortion that
folds over outside the image so Newton does not converge) come back as NaN
rather than as a wrong number.

`StereoRig` (left camera at (-L_B/2, 0, 0), right at (+L_B/2, 0, 0)) projects
world points and triangulates pixel pairs with eq. 4.1.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from edge.core.triangulation import triangulate_normalised

INVERSE_TOL = 1e-12  # Newton residual bound, normalised units (relative above |value| = 1)
MAX_NEWTON_ITER = 50

ArrayLike = np.ndarray | Sequence[float] | Sequence[Sequence[float]]


def rotation_matrix(rotation_deg: Sequence[float]) -> np.ndarray:
    """R = Rz @ Ry @ Rx for angles (rx, ry, rz) in degrees; maps camera-frame directions to world.

    eq. 3.3: a point on pixel ray k is P = k R [f_x, f_y, 1]^T + T0.
    """
    rx, ry, rz = (math.radians(float(a)) for a in rotation_deg)
    cx, sx = math.cos(rx), math.sin(rx)
    cy, sy = math.cos(ry), math.sin(ry)
    cz, sz = math.cos(rz), math.sin(rz)
    r_x = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    r_y = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    r_z = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    return r_z @ r_y @ r_x


def _points(a: ArrayLike) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.shape[-1:] != (2,):
        raise ValueError(f"expected points of shape (..., 2), got {arr.shape}")
    return arr


def _rotate_plane(xy: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """Rotate rays (x, y, 1) by `rot` and re-normalise to z = 1 (eq. 3.9/3.10); NaN behind the camera."""
    ray = np.concatenate([xy, np.ones(xy.shape[:-1] + (1,))], axis=-1) @ rot.T
    z = ray[..., 2:3]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(z > 0.0, ray[..., :2] / z, np.nan)


def _newton_inverse(
    forward: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], target: np.ndarray, start: np.ndarray
) -> np.ndarray:
    """Solve forward(p) = target for p by vectorised Newton; NaN where it does not reach INVERSE_TOL.

    `forward` returns the value (..., 2) and its Jacobian (..., 2, 2) (d value_i / d p_j).
    """
    p = start.copy()
    tol = INVERSE_TOL * np.maximum(1.0, np.abs(target).max(axis=-1))
    for _ in range(MAX_NEWTON_ITER):
        value, jac = forward(p)
        resid = value - target
        if not np.any(np.abs(resid).max(axis=-1) > tol):  # converged, or NaN input (stays NaN)
            return p
        det = jac[..., 0, 0] * jac[..., 1, 1] - jac[..., 0, 1] * jac[..., 1, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            step0 = (jac[..., 1, 1] * resid[..., 0] - jac[..., 0, 1] * resid[..., 1]) / det
            step1 = (jac[..., 0, 0] * resid[..., 1] - jac[..., 1, 0] * resid[..., 0]) / det
        p = p - np.stack([step0, step1], axis=-1)
    value, _ = forward(p)
    ok = np.abs(value - target).max(axis=-1) <= tol  # False for NaN: non-converged points become NaN
    return np.where(ok[..., None], p, np.nan)


def _finite_tuple(name: str, values: Sequence[float], length: int) -> tuple[float, ...]:
    out = tuple(float(v) for v in values)
    if len(out) != length or not all(math.isfinite(v) for v in out):
        raise ValueError(f"{name} must be {length} finite numbers, got {values!r}")
    return out


class CameraModel(ABC):
    """A calibrated camera: pixel <-> camera-frame normalised, plus its rotation into the world frame."""

    rotation_deg: tuple[float, float, float]

    @abstractmethod
    def pixel_to_camera(self, uv: ArrayLike) -> np.ndarray:
        """(..., 2) pixels -> (..., 2) undistorted camera-frame normalised coordinates."""

    @abstractmethod
    def camera_to_pixel(self, xy: ArrayLike) -> np.ndarray:
        """(..., 2) camera-frame normalised coordinates -> (..., 2) pixels."""

    @abstractmethod
    def focal_px(self) -> float:
        """Effective horizontal focal length in pixels at the principal point."""

    @abstractmethod
    def to_dict(self) -> dict:
        """This camera's entry of the calibration YAML mapping (docs/calibration.md)."""

    def rotation(self) -> np.ndarray:
        """The 3x3 camera-to-world rotation."""
        return rotation_matrix(self.rotation_deg)

    def pixel_to_normalised(self, uv: ArrayLike) -> np.ndarray:
        """(..., 2) pixels -> rotation-compensated normalised world-frame coordinates (eq. 3.9/3.10)."""
        return _rotate_plane(self.pixel_to_camera(uv), self.rotation())

    def normalised_to_pixel(self, xy: ArrayLike) -> np.ndarray:
        """Inverse of `pixel_to_normalised`."""
        return self.camera_to_pixel(_rotate_plane(_points(xy), self.rotation().T))


@dataclass(frozen=True, slots=True)
class PinholeCamera(CameraModel):
    """OpenCV pinhole camera: K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], dist = (k1, k2, p1, p2, k3)."""

    fx: float
    fy: float
    cx: float
    cy: float
    dist: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)
    rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        fx, fy, cx, cy = _finite_tuple("fx, fy, cx, cy", (self.fx, self.fy, self.cx, self.cy), 4)
        if fx <= 0.0 or fy <= 0.0:
            raise ValueError(f"focal lengths must be positive, got fx={fx}, fy={fy}")
        for name, value in (("fx", fx), ("fy", fy), ("cx", cx), ("cy", cy)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "dist", _finite_tuple("dist (k1, k2, p1, p2, k3)", self.dist, 5))
        object.__setattr__(self, "rotation_deg", _finite_tuple("rotation_deg", self.rotation_deg, 3))

    def _distort(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """OpenCV distortion of normalised coordinates and its Jacobian d(xd, yd)/d(x, y)."""
        k1, k2, p1, p2, k3 = self.dist
        x, y = xy[..., 0], xy[..., 1]
        r2 = x * x + y * y
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        dradial = 2.0 * (k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2))  # d radial / d(r2) * 2
        xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
        yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
        jac = np.empty(xy.shape[:-1] + (2, 2))
        jac[..., 0, 0] = radial + x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x
        jac[..., 0, 1] = x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y
        jac[..., 1, 0] = x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y
        jac[..., 1, 1] = radial + y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x
        return np.stack([xd, yd], axis=-1), jac

    def camera_to_pixel(self, xy: ArrayLike) -> np.ndarray:
        distorted, _ = self._distort(_points(xy))
        return distorted * (self.fx, self.fy) + (self.cx, self.cy)

    def pixel_to_camera(self, uv: ArrayLike) -> np.ndarray:
        distorted = (_points(uv) - (self.cx, self.cy)) / (self.fx, self.fy)
        return _newton_inverse(self._distort, distorted, distorted)

    def focal_px(self) -> float:
        return self.fx

    def to_dict(self) -> dict:
        return {
            "model": "pinhole",
            "fx": self.fx,
            "fy": self.fy,
            "cx": self.cx,
            "cy": self.cy,
            "dist": list(self.dist),
            "rotation_deg": list(self.rotation_deg),
        }


@dataclass(frozen=True, slots=True)
class Poly10Camera(CameraModel):
    """The thesis's polynomial camera (eq. 3.5), (u, v) measured from (cx, cy), coeffs = a0..a9."""

    cx: float
    cy: float
    coeffs: tuple[float, ...]
    rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        cx, cy = _finite_tuple("cx, cy", (self.cx, self.cy), 2)
        object.__setattr__(self, "cx", cx)
        object.__setattr__(self, "cy", cy)
        coeffs = _finite_tuple("coeffs (a0..a9)", self.coeffs, 10)
        if coeffs[0] <= 0.0 or coeffs[5] <= 0.0:
            raise ValueError(f"a0 and a5 (1/focal length) must be positive, got {coeffs[0]}, {coeffs[5]}")
        object.__setattr__(self, "coeffs", coeffs)
        object.__setattr__(self, "rotation_deg", _finite_tuple("rotation_deg", self.rotation_deg, 3))

    def _poly(self, uv_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """eq. 3.5 at centred pixels, and its Jacobian d(f_x, f_y)/d(u, v)."""
        a0, a1, a2, a3, a4, a5, a6, a7, a8, a9 = self.coeffs
        u, v = uv_c[..., 0], uv_c[..., 1]
        fx = a0 * u + a1 * v + a2 * u * v + a3 * u**3 + a4 * u * v * v  # eq. 3.5
        fy = a5 * v + a6 * u + a7 * v * u + a8 * v**3 + a9 * v * u * u  # eq. 3.5
        jac = np.empty(uv_c.shape[:-1] + (2, 2))
        jac[..., 0, 0] = a0 + a2 * v + 3.0 * a3 * u * u + a4 * v * v
        jac[..., 0, 1] = a1 + a2 * u + 2.0 * a4 * u * v
        jac[..., 1, 0] = a6 + a7 * v + 2.0 * a9 * u * v
        jac[..., 1, 1] = a5 + a7 * u + 3.0 * a8 * v * v + a9 * u * u
        return np.stack([fx, fy], axis=-1), jac

    def pixel_to_camera(self, uv: ArrayLike) -> np.ndarray:
        value, _ = self._poly(_points(uv) - (self.cx, self.cy))
        return value

    def camera_to_pixel(self, xy: ArrayLike) -> np.ndarray:
        target = _points(xy)
        a0, a1, _, _, _, a5, a6, *_ = self.coeffs
        det = a0 * a5 - a1 * a6
        x, y = target[..., 0], target[..., 1]
        start = np.stack([a5 * x - a1 * y, a0 * y - a6 * x], axis=-1) / det  # inverse of the linear part
        return _newton_inverse(self._poly, target, start) + (self.cx, self.cy)

    def focal_px(self) -> float:
        return 1.0 / self.coeffs[0]

    def to_dict(self) -> dict:
        return {
            "model": "poly10",
            "cx": self.cx,
            "cy": self.cy,
            "coeffs": list(self.coeffs),
            "rotation_deg": list(self.rotation_deg),
        }


@dataclass(frozen=True, slots=True)
class StereoRig:
    """Two cameras on a baseline along world X: left centre (-L_B/2, 0, 0), right (+L_B/2, 0, 0)."""

    baseline_m: float
    width: int
    height: int
    left: CameraModel
    right: CameraModel

    def __post_init__(self) -> None:
        if not (math.isfinite(self.baseline_m) and self.baseline_m > 0.0):
            raise ValueError(f"baseline_m must be a positive finite number, got {self.baseline_m!r}")
        for name in ("width", "height"):
            value = getattr(self, name)
            if isinstance(value, bool) or int(value) != value or value <= 0:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
            object.__setattr__(self, name, int(value))
        object.__setattr__(self, "baseline_m", float(self.baseline_m))

    def project(self, points_m: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(..., 3) world points -> (uv_left, uv_right), each (..., 2); NaN for points behind a camera."""
        pts = np.asarray(points_m, dtype=np.float64)
        if pts.shape[-1:] != (3,):
            raise ValueError(f"expected points of shape (..., 3), got {pts.shape}")
        out = []
        for camera, centre_x in ((self.left, -0.5 * self.baseline_m), (self.right, 0.5 * self.baseline_m)):
            rel_x = pts[..., 0] - centre_x
            z = pts[..., 2]
            with np.errstate(divide="ignore", invalid="ignore"):
                xy = np.stack([rel_x, pts[..., 1]], axis=-1) / z[..., None]
            xy = np.where((z > 0.0)[..., None], xy, np.nan)
            out.append(camera.normalised_to_pixel(xy))
        return out[0], out[1]

    def triangulate(self, uv_left: ArrayLike, uv_right: ArrayLike) -> np.ndarray:
        """Pixel pairs -> (..., 3) world points, eq. 4.1 (Y from the mean of y_l, y_r: see triangulation)."""
        return triangulate_normalised(
            self.left.pixel_to_normalised(uv_left), self.right.pixel_to_normalised(uv_right), self.baseline_m
        )

    def focal_px(self) -> float:
        """Mean of the two cameras' horizontal focal lengths, in pixels."""
        return 0.5 * (self.left.focal_px() + self.right.focal_px())
