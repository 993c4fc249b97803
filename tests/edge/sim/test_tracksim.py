"""Track scenarios obey their limits; the measurement model injects what it says."""

from __future__ import annotations

import numpy as np
import pytest

from edge.sim import tracksim as ts


@pytest.mark.parametrize("sc", [ts.SHIP, ts.FAST_BOAT], ids=lambda s: s.name)
def test_profile_respects_speed_and_acceleration(sc: ts.Scenario) -> None:
    fs = 10.0
    t, z, t_closest = ts.range_profile(sc, fs)
    v = np.diff(z) * fs
    a = np.diff(v) * fs
    assert z[0] == pytest.approx(sc.far_m) and z[-1] == pytest.approx(sc.far_m, abs=1e-6)
    assert z.min() == pytest.approx(sc.near_m, abs=1e-6)
    assert np.abs(v).max() <= sc.speed_mps + 1e-9
    assert np.abs(a).max() <= sc.accel_mps2 * 1.01
    k = int(round(t_closest * fs))
    assert z[k] == pytest.approx(sc.near_m, abs=0.01) and z[k - 50] > sc.near_m


def test_measurement_model_counts() -> None:
    t = np.arange(20000) / 10.0
    d = np.full_like(t, 10.0)
    dist = ts.Disturbances(sigma_px=0.0, outlier_rate=0.02, burst_s=2.0, gap_s=1.0)
    z = ts.measurements(d, t, dist, np.random.default_rng(1), burst_at_s=100.0, gap_at_s=200.0)
    assert np.isnan(z).sum() == 10
    assert np.all(z[(t >= 100) & (t < 102)] == 13.0)
    jumps = np.abs(z - 10) >= 1.0
    assert 0.015 < (jumps.sum() - 20) / len(t) < 0.025


def test_lag_and_range_error_of_a_perfect_filter_are_zero() -> None:
    def make():
        return lambda z: (np.nan, np.nan)
    run = ts.run_track(ts.SHIP, 10.0, ts.Disturbances(sigma_px=0.0), 1, make)
    perfect = ts.TrackRun(run.t_s, run.z_m, run.d_true, run.z_meas, run.d_true.copy(),
                          np.full_like(run.t_s, 0.01), run.t_closest_s)
    assert ts.lag_px(perfect) == 0.0
    assert np.nanmax(np.abs(ts.range_errors(perfect))) < 1e-12
