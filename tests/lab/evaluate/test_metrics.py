"""lab.evaluate.metrics: the IMO share against the bridge and against the hull outline."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import lab.evaluate.metrics as em
from edge.fix import ShipFix, TrackStatus


def _ship(range_m: float) -> em.Ship:
    """A 120 m ship heading straight at the rig (bow-on), bridge 24 m forward of its centre."""
    t = np.arange(10, dtype=np.int64) * 10**9
    z = range_m + 10.0 * (9 - np.arange(10))  # 10 m/s towards the rig, at range_m in the last sample
    return em.Ship(1, 120.0, 20.0, 24.0, t, np.stack([np.zeros(10), np.zeros(10), z], -1))


def _fix(x_m: float, z_m: float) -> ShipFix:
    return ShipFix(t_ns=9 * 10**9, track_id=1, status=TrackStatus.TRACKING, x_m=x_m, y_m=0.0, z_m=z_m,
                   range_m=math.hypot(x_m, z_m), bearing_deg=0.0, lat_deg=0.0, lon_deg=0.0, sog_kn=None,
                   cog_deg=None, sigma_m=10.0, disparity_px=1.0, age_s=1.0, length_m=100.0)


@settings(max_examples=40, deadline=None)
@given(st.floats(1000.0, 5000.0), st.floats(-150.0, 150.0))
def test_imo_against_bridge_and_hull(range_m: float, along_m: float) -> None:
    """A fix on the hull's centreline `along_m` behind the bridge: the bridge share needs it within
    the tolerance of the bridge, the hull share within the tolerance of the outline (the hull
    reaches 84 m behind the bridge and 36 m ahead of it)."""
    ship = _ship(range_m)
    ev = em.evaluate({9 * 10**9: [_fix(0.0, range_m + along_m)]}, [ship], 2600.0, 2048)
    (m,) = ev.matched
    tol = max(50.0, 0.01 * range_m)
    assert em.imo_ok(m) == (abs(along_m) <= tol + 1e-6)
    outside = max(0.0, along_m - 84.0, -36.0 - along_m)
    assert m.outside_hull_m == pytest.approx(outside, abs=1e-6)
    assert em.imo_hull_ok(m) == (outside <= tol)
    assert em.imo_ok(m) <= em.imo_hull_ok(m)  # a fix near the bridge is near the hull


def test_truth_speed_and_the_speed_error_of_matched_fixes() -> None:
    ship = _ship(2000.0)                                   # 10 m/s = 19.44 kn, bow-on
    assert ship.speed_kn_at(5) == pytest.approx(10.0 * 3600 / 1852)
    fixes = {9 * 10**9: [dataclasses.replace(_fix(0.0, 2000.0), sog_kn=21.0)]}
    rows = em.speed_rows(em.evaluate(fixes, [ship], 2600.0, 2048))
    assert rows[1]["with_speed"] == 1 and rows[1]["rms_kn"] == pytest.approx(21.0 - 10.0 * 3600 / 1852)
