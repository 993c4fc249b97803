"""Online calibration check: associated class-A ships whose position is better than 10 m are
moving surveyed landmarks; the rig's disparity and bearing are compared with theirs.

Per AIS report (once: the first pair after the report, within `MAX_REPORT_AGE_S`), for the track
it is associated with:
  expected point  the antenna extrapolated to the exposure time with the report's SOG/COG
                  (`edge.ais.targets`), moved to the centreline ((D - C)/2 to starboard) and toward
                  the camera by NEAR_SHARE (1/2) of the half beam times |sin aspect|: the followed
                  point lies on the superstructure's near face, somewhere between the centreline
                  (a narrow deckhouse) and the hull's side (bridge wings), and half way is the
                  unbiased guess for a point known only to lie between them. The near side itself
                  left -0.029 px with no drift on the 2048-px renders, whose deckhouses are
                  narrower than the beam (docs/accuracy.md, AIS);
  disparity       residual r_d = d_measured - f L_B / Z_expected (eq. 2.12), Z the world depth;
                  a right-camera yaw error of e rad shifts every disparity by f e px, whatever the
                  range, so a constant offset is what drift looks like (0.002 deg at f = 2600 px:
                  0.09 px);
  bearing         residual r_b = bearing_measured - bearing_expected: a heading error shifts every
                  bearing alike.
Each residual carries a sigma: the fix's own (disparity filter, bearing from the fix's sigma) and
the AIS position's (GNSS sigma and half the beam, through d^2 / (f L_B) for the disparity and
1/r for the bearing), so far ships, whose disparity hardly depends on where on the hull the
point is, weigh most.

Estimate: a Huber M-estimate (k = 1.5) of the weighted mean over the last `WINDOW` residuals,
its sigma 1/sqrt(sum w) inflated by the reduced chi-square when above 1 (errors of one ship are
correlated over its passage; the inflation lets the scatter, not the model, speak), and the
number of distinct ships behind it. A fault is raised when |estimate| - k sigma > bound with at
least `min_reports` residuals behind it: the offset is beyond the bound with confidence.

The monitor reports only: it never changes the calibration (a bounded correction is left out).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

MAX_REPORT_AGE_S = 1.5  # a report is compared with the first pair within this of its time
WINDOW = 4000  # residuals kept (10 min of 6 ships at 10 s is 360)
HUBER_K = 1.5
NEAR_SHARE = 0.5  # of the half beam toward the camera: where the point sits (module doc)


@dataclass(frozen=True)
class Estimate:
    value: float | None  # None until two residuals
    sigma: float | None
    reports: int
    ships: int
    fault: bool


def huber_mean(x: np.ndarray, sigma: np.ndarray, k: float = HUBER_K) -> tuple[float, float]:
    """Weighted Huber location of x with per-sample sigma: (estimate, its sigma)."""
    w0 = 1.0 / sigma**2
    mu = float(np.sum(w0 * x) / np.sum(w0))
    w = w0
    for _ in range(10):
        z = np.abs(x - mu) / sigma
        w = w0 * np.where(z <= k, 1.0, k / np.maximum(z, 1e-12))
        mu = float(np.sum(w * x) / np.sum(w))
    n = len(x)
    chi2 = float(np.sum(w0 * (x - mu) ** 2)) / max(n - 1, 1)
    return mu, math.sqrt(max(chi2, 1.0) / float(np.sum(w)))


class OffsetEstimator:
    """A running robust estimate of one offset (disparity px or bearing deg)."""

    def __init__(self, bound: float, confidence_sigmas: float, min_reports: int) -> None:
        self.bound, self.k, self.min_reports = bound, confidence_sigmas, min_reports
        self.samples: deque[tuple[int, float, float]] = deque(maxlen=WINDOW)  # (mmsi, residual, sigma)

    def add(self, mmsi: int, residual: float, sigma: float) -> None:
        if math.isfinite(residual) and math.isfinite(sigma) and sigma > 0.0:
            self.samples.append((mmsi, residual, sigma))

    def estimate(self) -> Estimate:
        n = len(self.samples)
        ships = len({s[0] for s in self.samples})
        if n < 2:
            return Estimate(None, None, n, ships, False)
        arr = np.array([(r, s) for _, r, s in self.samples])
        mu, sd = huber_mean(arr[:, 0], arr[:, 1])
        fault = n >= self.min_reports and abs(mu) - self.k * sd > self.bound
        return Estimate(mu, sd, n, ships, fault)


@dataclass(frozen=True)
class Residual:
    mmsi: int
    disparity_px: float
    disparity_sigma_px: float
    bearing_deg: float
    bearing_sigma_deg: float


def residual(mmsi: int, measured_d_px: float, measured_sigma_d_px: float,
             measured_bearing_deg: float, expected_world_m: np.ndarray, expected_bearing_deg: float,
             expected_range_m: float, position_sigma_m: float, focal_px: float,
             baseline_m: float) -> Residual:
    """The residuals of one fix against one expected point (see the module docstring)."""
    z = float(expected_world_m[2])
    d_exp = focal_px * baseline_m / z  # eq. 2.12
    dd_dr = measured_d_px**2 / (focal_px * baseline_m)
    sigma_d = math.hypot(measured_sigma_d_px, dd_dr * position_sigma_m)
    db = (measured_bearing_deg - expected_bearing_deg + 180.0) % 360.0 - 180.0
    bearing_sigma = math.degrees(position_sigma_m / expected_range_m)
    bearing_sigma = math.hypot(bearing_sigma, math.degrees(0.2 / focal_px))  # the column's floor
    return Residual(mmsi, measured_d_px - d_exp, sigma_d, db, bearing_sigma)
