"""Track test for the disparity filters (research note §6.8): scripted range profiles and a
measurement model, used by tools/bench-core and the filter tests. Pure numpy, no I/O.

A target holds at its far range, accelerates (limited acceleration) to its speed towards the
mast, decelerates to a stop at the closest range, holds, and recedes the same way. Its
disparity is d = fB / Z. Measurements are z = d + white noise + b(frac(d)) + single-frame
outliers + a glint burst (+ an optional gap of missing frames), where b is a sub-pixel bias
curve (e.g. the matcher's measured b(f)). `lag` is the mean filtered error over the last 20 s
before the closest point is reached, the phase where the thesis's Butterworth lags most.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from edge.core.kalman import DisparityKalman, design_kalman

FB_PX_M = 15000.0          # f * B of the research note's examples (f = 3000 px, B = 5 m)


@dataclass(frozen=True)
class Scenario:
    """Approach / hold / recede profile."""

    name: str
    far_m: float
    near_m: float
    speed_mps: float
    accel_mps2: float
    hold_far_s: float = 20.0
    hold_near_s: float = 30.0


SHIP = Scenario("ship", 4000.0, 600.0, 8.0, 0.15)
FAST_BOAT = Scenario("fast boat", 2500.0, 300.0, 15.0, 0.5)


def range_profile(sc: Scenario, fs_hz: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(t_s, Z_m, t_closest_s): range sampled at fs_hz and the time the target stops at near_m."""
    dist = sc.far_m - sc.near_m
    t_acc = sc.speed_mps / sc.accel_mps2
    d_acc = 0.5 * sc.accel_mps2 * t_acc**2
    if 2 * d_acc > dist:
        raise ValueError("scenario cannot reach its speed")
    t_cruise = (dist - 2 * d_acc) / sc.speed_mps
    leg = 2 * t_acc + t_cruise

    def travelled(t: np.ndarray) -> np.ndarray:          # distance covered t seconds into a leg
        t = np.clip(t, 0.0, leg)
        a = sc.accel_mps2
        s1 = 0.5 * a * np.minimum(t, t_acc) ** 2
        s2 = sc.speed_mps * np.clip(t - t_acc, 0.0, t_cruise)
        td = np.clip(t - t_acc - t_cruise, 0.0, t_acc)
        s3 = sc.speed_mps * td - 0.5 * a * td**2
        return s1 + s2 + s3

    total = sc.hold_far_s + 2 * leg + sc.hold_near_s + sc.hold_far_s
    t = np.arange(int(total * fs_hz)) / fs_hz
    t_closest = sc.hold_far_s + leg
    z = sc.far_m - travelled(t - sc.hold_far_s) + travelled(t - t_closest - sc.hold_near_s)
    return t, z, t_closest


@dataclass(frozen=True)
class Disturbances:
    """Measurement model parameters (note §2.4)."""

    sigma_px: float = 0.10
    outlier_rate: float = 0.0
    outlier_px: tuple[float, float] = (1.0, 8.0)
    burst_s: float = 0.0                 # glint burst length (+burst_px), placed in the approach
    burst_px: float = 3.0
    gap_s: float = 0.0                   # missing measurements (occlusion), placed after the burst
    bias_curve: np.ndarray | None = None  # b(f) sampled at f = k / len, px


def measurements(d_true: np.ndarray, t_s: np.ndarray, dist: Disturbances, rng: np.random.Generator,
                 burst_at_s: float, gap_at_s: float) -> np.ndarray:
    """Noisy disparity samples; NaN marks frames without a measurement."""
    z = d_true + dist.sigma_px * rng.standard_normal(d_true.shape)
    if dist.bias_curve is not None:
        curve = np.asarray(dist.bias_curve, dtype=float)
        z += curve[(np.floor((d_true % 1.0) * len(curve))).astype(int) % len(curve)]
    out = rng.random(d_true.shape) < dist.outlier_rate
    z[out] += rng.choice([-1.0, 1.0], out.sum()) * rng.uniform(*dist.outlier_px, out.sum())
    z[(t_s >= burst_at_s) & (t_s < burst_at_s + dist.burst_s)] = (
        d_true[(t_s >= burst_at_s) & (t_s < burst_at_s + dist.burst_s)] + dist.burst_px)
    z[(t_s >= gap_at_s) & (t_s < gap_at_s + dist.gap_s)] = np.nan
    return z


@dataclass(frozen=True)
class TrackRun:
    """One filtered run: truth, measurements, estimates and the filter's predicted sigma."""

    t_s: np.ndarray
    z_m: np.ndarray
    d_true: np.ndarray
    z_meas: np.ndarray
    d_est: np.ndarray          # NaN before the filter has an estimate
    sigma_est: np.ndarray      # NaN where the filter reports none (Butterworth)
    t_closest_s: float


def kalman_filter_maker(fs_hz: float, sigma_meas_px: float, sigma_a: float, **design_kw: Any
                        ) -> Callable[[], Callable[[float | None], tuple[float, float]]]:
    """`make_filter` for `run_track`: a fresh fixed-point Kalman per run, NaN until it has an estimate.
    design_kw go to `design_kalman` (sigma_floor_px, bound_s, ...)."""
    design = design_kalman(fs_hz, sigma_meas_px, sigma_a, **design_kw)

    def make() -> Callable[[float | None], tuple[float, float]]:
        f = DisparityKalman(design)

        def step(z: float | None) -> tuple[float, float]:
            e = f.update(z)
            return (e.disparity_px, e.sigma_px) if e.valid else (np.nan, np.nan)
        return step
    return make


def run_track(sc: Scenario, fs_hz: float, dist: Disturbances, seed: int,
              make_filter: Callable[[], Callable[[float | None], tuple[float, float]]],
              fb_px_m: float = FB_PX_M) -> TrackRun:
    """Simulate one pass and filter it; `make_filter()` returns step(z or None) -> (d, sigma)."""
    t, z_m, t_closest = range_profile(sc, fs_hz)
    d_true = fb_px_m / z_m
    rng = np.random.default_rng(seed)
    approach_mid = sc.hold_far_s + 0.5 * (t_closest - sc.hold_far_s)
    z = measurements(d_true, t, dist, rng, burst_at_s=approach_mid, gap_at_s=approach_mid + 30.0)
    step = make_filter()
    est = np.full(len(t), np.nan)
    sig = np.full(len(t), np.nan)
    for i, zi in enumerate(z):
        est[i], sig[i] = step(None if np.isnan(zi) else float(zi))
    return TrackRun(t, z_m, d_true, z, est, sig, t_closest)


def lag_px(run: TrackRun, window_s: float = 20.0) -> float:
    """Mean error (estimate - truth) over the last window_s before the closest point."""
    sel = (run.t_s >= run.t_closest_s - window_s) & (run.t_s < run.t_closest_s)
    return float(np.nanmean(run.d_est[sel] - run.d_true[sel]))


RANGE_BINS_M = ((0.0, 1000.0), (1000.0, 2000.0), (2000.0, np.inf))


def range_errors(run: TrackRun, fb_px_m: float = FB_PX_M) -> np.ndarray:
    """Relative range error (Z_est - Z) / Z per frame; NaN where there is no estimate."""
    with np.errstate(divide="ignore", invalid="ignore"):
        z_est = np.where(run.d_est > 0, fb_px_m / run.d_est, np.nan)
    return (z_est - run.z_m) / run.z_m
