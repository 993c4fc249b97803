"""Triangulation (eq. 4.1) and its error model (eq. 4.5, 4.6, 4.9), vectorised over numpy arrays.

All functions work on rotation-compensated normalised coordinates (focal
length 1, both optical axes along world +Z), the output of
`CameraModel.pixel_to_normalised`. Rig frame of docs/method.md: origin at the
baseline midpoint, X right, Y down, Z forward; cameras at (-+L_B/2, 0, 0).

Y choice: eq. 4.1 as printed takes y from the right camera. We use the mean
of y_l and y_r instead: identical for consistent data (after rotation
compensation y_l = y_r), symmetric in the two cameras like X, and it halves
the variance of independent row noise. The error model is unaffected, since
eq. 4.5 perturbs x_r only.

Sign convention of the error model: epsilon is the error added to x_r
(normalised units). A positive epsilon shrinks the disparity and pushes the
estimate away (Z' > Z); a negative one pulls it in. The two are not
symmetric (the error grows like Z^2 / (L_B - eps Z)), which is why the
range-error bounds come as a (near, far) pair.
"""

from __future__ import annotations

import math

import numpy as np


def triangulate_normalised(xy_left: np.ndarray, xy_right: np.ndarray, baseline_m: float) -> np.ndarray:
    """(..., 2) left and right normalised points -> (..., 3) world points, eq. 4.1 / 3.11.

    [X, Y, Z] = L_B / (x_l - x_r) * [(x_l + x_r) / 2, (y_l + y_r) / 2, 1]. A pair
    with no positive disparity has no intersection in front of the rig: NaN.
    """
    left = np.asarray(xy_left, dtype=np.float64)
    right = np.asarray(xy_right, dtype=np.float64)
    disparity = left[..., 0] - right[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(disparity > 0.0, baseline_m / disparity, np.nan)  # eq. 4.1
    mid = 0.5 * (left + right)
    return np.stack([scale * mid[..., 0], scale * mid[..., 1], scale], axis=-1)


def pixel_angle(width_px: float, fov_deg: float) -> float:
    """Size of one pixel in normalised units at the image centre: 2 tan(theta/2) / N."""
    _check_positive(width_px=width_px, fov_deg=fov_deg)
    if fov_deg >= 180.0:
        raise ValueError(f"fov_deg must be below 180, got {fov_deg}")
    return 2.0 * math.tan(math.radians(fov_deg) / 2.0) / width_px


def epsilon(delta_px: float | np.ndarray, width_px: float, fov_deg: float) -> float | np.ndarray:
    """Matching error of delta pixels in normalised units: eps = (2 delta / N) tan(theta / 2), eq. 4.6."""
    return np.asarray(delta_px, dtype=np.float64) * pixel_angle(width_px, fov_deg)  # eq. 4.6


def position_error(points_m: np.ndarray, eps: float | np.ndarray, baseline_m: float) -> np.ndarray:
    """[X'-X, Y'-Y, Z'-Z] when x_r is off by eps, eq. 4.5; inf where eps Z >= L_B (disparity gone)."""
    pts = np.asarray(points_m, dtype=np.float64)
    gain = _gain(pts[..., 2], eps, baseline_m)
    offset = np.stack([0.5 * baseline_m + pts[..., 0], pts[..., 1], pts[..., 2]], axis=-1)
    return gain[..., None] * offset  # eq. 4.5


def range_error(z_m: float | np.ndarray, eps: float | np.ndarray, baseline_m: float) -> np.ndarray:
    """Z' - Z = eps Z^2 / (L_B - eps Z), the range component of eq. 4.5; inf where eps Z >= L_B."""
    z = np.asarray(z_m, dtype=np.float64)
    return _gain(z, eps, baseline_m) * z  # eq. 4.5


def relative_range_error_k(k: float | np.ndarray, eps: float | np.ndarray) -> np.ndarray:
    """(Z' - Z) / Z against k = Z / L_B: eps k / (1 - eps k) (eq. 4.5 over Z; docs/method.md eq. 7.1)."""
    ek = np.asarray(eps, dtype=np.float64) * np.asarray(k, dtype=np.float64)
    with np.errstate(divide="ignore"):
        return np.where(ek < 1.0, ek / (1.0 - ek), np.inf)


def viewing_angle_range_error(k: float | np.ndarray, delta_alpha_rad: float | np.ndarray) -> np.ndarray:
    """Delta_D / D for a target straight ahead at D = k L_B, eq. 4.9.

    (1 + 4k^2) tan(da) / (2k (1 - 2k tan(da))). This is exact for both cameras'
    viewing angles off by da in opposite senses (each ray turned da towards the
    other's, the disparity shrinking by twice a single camera's share); inf where
    the rays no longer meet in front.
    """
    k = np.asarray(k, dtype=np.float64)
    t = np.tan(np.asarray(delta_alpha_rad, dtype=np.float64))
    denom = 2.0 * k * (1.0 - 2.0 * k * t)
    with np.errstate(divide="ignore"):
        return np.where(denom > 0.0, (1.0 + 4.0 * k * k) * t / denom, np.inf)  # eq. 4.9


def range_sigma(
    z_m: float | np.ndarray, sigma_d_px: float | np.ndarray, focal_px: float, baseline_m: float
) -> np.ndarray:
    """First-order 1-sigma range error from a disparity sigma: sigma_Z = Z^2 sigma_d / (f B) (eq. 2.12)."""
    z = np.asarray(z_m, dtype=np.float64)
    return z * z * np.asarray(sigma_d_px, dtype=np.float64) / (focal_px * baseline_m)


def range_sigma_bounds(
    z_m: float | np.ndarray, sigma_d_px: float | np.ndarray, focal_px: float, baseline_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Exact asymmetric 1-sigma range interval (near, far) via eq. 4.5 with eps = -+sigma_d / f.

    near = Z' - Z <= 0 for a disparity sigma_d larger, far = Z' - Z >= 0 (inf
    when sigma_d exceeds the disparity itself) for a disparity sigma_d smaller.
    """
    eps = np.asarray(sigma_d_px, dtype=np.float64) / focal_px
    return range_error(z_m, -eps, baseline_m), range_error(z_m, eps, baseline_m)


def _gain(z: np.ndarray, eps: float | np.ndarray, baseline_m: float) -> np.ndarray:
    """eps Z / (L_B - eps Z), the common factor of eq. 4.5; inf where eps Z >= L_B."""
    ez = np.asarray(eps, dtype=np.float64) * z
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(ez < baseline_m, ez / (baseline_m - ez), np.inf)


def _check_positive(**values: float) -> None:
    for name, value in values.items():
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{name} must be a positive finite number, got {value!r}")
