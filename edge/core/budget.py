"""The error budget of a stereo rig (docs/method.md "Error model"): what range it can measure, how well.

For a rig of image width N pixels, horizontal angle of view theta, baseline
L_B and matching error delta pixels this computes:

- epsilon, the matching error in normalised units (eq. 4.6);
- Z_near = L_B / tan(theta/2), from where a point straight ahead of either
  camera is seen by both;
- for each tolerated range error E_z the maximum range Z_max: the exact root
  of eq. 4.5 solved for Z, eps Z^2 + E_z eps Z - E_z L_B = 0, i.e.
  Z_max = (E_z / 2) (sqrt(1 + 4 L_B / (E_z eps)) - 1), and the first-order
  value sqrt(E_z L_B / eps) the thesis quotes;
- for each range Z the range error of eq. 4.5 for a matching error of +delta
  (disparity too small: the estimate lands too far, `error_far_m` > 0) and
  -delta (too near, `error_near_m` < 0), also as a percentage of Z and
  against k = Z / L_B (eq. 7.1); infinite where eps Z >= L_B (the error
  swallows the whole disparity);
- the detectable distance of a ship of length L_s that must cover at least
  w_s pixels: D = L_s w / (2 w_s tan(theta/2)) (eq. 3.12).

`error_budget` returns a frozen `Budget`; `Budget.to_dict()` is the JSON form
of `mast-stereo budget --json` (infinite values become None).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from edge.core.triangulation import epsilon, pixel_angle, range_error

DEFAULT_TOLERANCES_M = (35.0, 50.0, 150.0)
DEFAULT_RANGES_M = tuple(float(z) for z in range(500, 6001, 500))
DEFAULT_SHIP_LENGTH_M = 50.0
DEFAULT_MIN_PIXELS = 20.0


@dataclass(frozen=True, slots=True)
class MaxRange:
    """Farthest range whose range error stays within `tolerance_m` (eq. 4.5 solved for Z)."""

    tolerance_m: float
    z_max_m: float  # exact root
    z_max_first_order_m: float  # sqrt(E_z L_B / eps)


@dataclass(frozen=True, slots=True)
class RangeError:
    """Range error at one range for a matching error of -+delta (eq. 4.5)."""

    range_m: float
    k: float  # Z / L_B
    disparity_px: float  # f L_B / Z (eq. 2.12)
    error_near_m: float  # x_r off by -eps: estimate too near (<= 0)
    error_far_m: float  # x_r off by +eps: estimate too far (>= 0, inf when unmeasurable)
    error_near_pct: float
    error_far_pct: float


@dataclass(frozen=True, slots=True)
class Budget:
    """All figures of the error budget for one rig and matching error."""

    width_px: int
    fov_deg: float
    baseline_m: float
    delta_px: float
    epsilon: float  # eq. 4.6
    focal_px: float  # N / (2 tan(theta/2))
    z_near_m: float
    ship_length_m: float
    min_pixels: float
    detectable_range_m: float  # eq. 3.12
    max_ranges: tuple[MaxRange, ...]
    range_errors: tuple[RangeError, ...]

    def to_dict(self) -> dict:
        """Plain JSON-ready mapping with the field names above; infinities become None."""
        plain = _finite_or_none(asdict(self))
        assert isinstance(plain, dict)  # a dict maps to a dict
        return plain


def near_range(baseline_m: float, fov_deg: float) -> float:
    """Z_near = L_B / tan(theta/2): beyond it a point straight ahead of either camera is in both views."""
    return baseline_m / math.tan(math.radians(fov_deg) / 2.0)


def max_range(tolerance_m: float | np.ndarray, eps: float, baseline_m: float | np.ndarray) -> np.ndarray:
    """Exact Z with eps Z^2 / (L_B - eps Z) = E_z (eq. 4.5), the positive root of the quadratic."""
    e = np.asarray(tolerance_m, dtype=np.float64)
    # (E/2)(sqrt(1 + 4 L_B/(E eps)) - 1) written without the cancellation of the "- 1"
    return 2.0 * baseline_m / (eps * (1.0 + np.sqrt(1.0 + 4.0 * baseline_m / (e * eps))))


def max_range_first_order(tolerance_m: float | np.ndarray, eps: float, baseline_m: float) -> np.ndarray:
    """sqrt(E_z L_B / eps): eq. 4.5 with the eps Z in the denominator dropped (the thesis's figure)."""
    return np.sqrt(np.asarray(tolerance_m, dtype=np.float64) * baseline_m / eps)


def detectable_distance(ship_length_m: float, width_px: float, min_pixels: float, fov_deg: float) -> float:
    """Farthest distance at which a ship of length L_s covers w_s pixels, eq. 3.12.

    D = L_s w / (2 w_s tan(theta/2)).
    """
    return ship_length_m * width_px / (2.0 * min_pixels * math.tan(math.radians(fov_deg) / 2.0))


def error_budget(
    width_px: int,
    fov_deg: float,
    baseline_m: float,
    delta_px: float,
    tolerances_m: Sequence[float] = DEFAULT_TOLERANCES_M,
    ranges_m: Sequence[float] = DEFAULT_RANGES_M,
    ship_length_m: float = DEFAULT_SHIP_LENGTH_M,
    min_pixels: float = DEFAULT_MIN_PIXELS,
) -> Budget:
    """The whole budget; ValueError names the first argument that is not positive and finite."""
    if isinstance(width_px, bool) or int(width_px) != width_px:
        raise ValueError(f"width_px must be a whole number of pixels, got {width_px!r}")
    _require_positive("width_px", [width_px])
    _require_positive("fov_deg", [fov_deg])
    if fov_deg >= 180.0:
        raise ValueError(f"fov_deg must be below 180, got {fov_deg!r}")
    for name, values in (
        ("baseline_m", [baseline_m]),
        ("delta_px", [delta_px]),
        ("tolerances_m", tolerances_m),
        ("ranges_m", ranges_m),
        ("ship_length_m", [ship_length_m]),
        ("min_pixels", [min_pixels]),
    ):
        _require_positive(name, values)

    eps = float(epsilon(delta_px, width_px, fov_deg))  # eq. 4.6
    focal_px = 1.0 / pixel_angle(width_px, fov_deg)
    tol = np.asarray(tolerances_m, dtype=np.float64)
    z = np.asarray(ranges_m, dtype=np.float64)
    near = range_error(z, -eps, baseline_m)  # eq. 4.5
    far = range_error(z, eps, baseline_m)
    max_ranges = tuple(
        MaxRange(float(e), float(exact), float(first))
        for e, exact, first in zip(
            tol, max_range(tol, eps, baseline_m), max_range_first_order(tol, eps, baseline_m), strict=True
        )
    )
    range_errors = tuple(
        RangeError(
            range_m=float(zi),
            k=float(zi / baseline_m),
            disparity_px=float(focal_px * baseline_m / zi),  # eq. 2.12
            error_near_m=float(n),
            error_far_m=float(f),
            error_near_pct=float(100.0 * n / zi),
            error_far_pct=float(100.0 * f / zi),
        )
        for zi, n, f in zip(z, near, far, strict=True)
    )
    return Budget(
        width_px=int(width_px),
        fov_deg=float(fov_deg),
        baseline_m=float(baseline_m),
        delta_px=float(delta_px),
        epsilon=eps,
        focal_px=focal_px,
        z_near_m=near_range(baseline_m, fov_deg),
        ship_length_m=float(ship_length_m),
        min_pixels=float(min_pixels),
        detectable_range_m=detectable_distance(ship_length_m, width_px, min_pixels, fov_deg),
        max_ranges=max_ranges,
        range_errors=range_errors,
    )


def _require_positive(name: str, values: Sequence[float]) -> None:
    for value in values:
        if isinstance(value, bool) or not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{name} must be positive and finite, got {value!r}")


def _finite_or_none(value: object) -> object:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite_or_none(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_or_none(v) for v in value]
    return value
