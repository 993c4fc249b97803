"""Coasting fixes (edge.measure.coast): the last measured fix carried to a later pair moves by its
ground-plane velocity exactly (checked back through the independent east/north/up and geodesy
conversions), is held without one, and its 1-sigma grows by the velocity's sigma or the fastest
ship's speed times the time; a tentative track stays Q, a confirmed one is L, and it is marked."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.geo import range_bearing, world_to_enu, world_to_latlon
from edge.core.shipmotion import MAX_SHIP_SPEED_MPS
from edge.core.site import Site
from edge.fix import ShipFix, TrackStatus
from edge.measure.coast import coast

SITE = Site(34.63, 135.02, 25.0, 180.0)


def measured(x_m: float, z_m: float, *, velocity: tuple[float, float, float] | None = None,
             across_m: float | None = 3.0) -> ShipFix:
    """A measured fix at world (x, 20 m down, z); `velocity` = (v east, v north, their 1-sigma)."""
    world = np.array([x_m, 20.0, z_m])
    range_m, bearing = range_bearing(world, SITE.heading_deg)
    lat, lon, _ = world_to_latlon(world, SITE)
    en_state = en_cov = None
    if velocity is not None:
        ve, vn, sv = velocity
        east, north, _ = world_to_enu(world, SITE.heading_deg)
        en_state = (float(east), float(north), ve, vn)
        cov = np.diag([4.0, 4.0, sv * sv, sv * sv])
        en_cov = tuple(cov.ravel().tolist())
    return ShipFix(5_000_000_000, 7, TrackStatus.TRACKING, x_m, 20.0, z_m, float(range_m), float(bearing),
                   float(lat), float(lon), 9.0 if velocity else None, 45.0 if velocity else None, 12.0, 3.1,
                   length_m=60.0, en_state=en_state, en_cov=en_cov, sigma_across_m=across_m)


@settings(max_examples=60, deadline=None)
@given(st.floats(-3000, 3000), st.floats(200, 5000), st.floats(-12, 12), st.floats(-12, 12),
       st.floats(0.01, 2.0), st.floats(0.0, 10.0))
def test_a_known_velocity_moves_the_fix_by_velocity_times_time(x_m: float, z_m: float, ve: float, vn: float,
                                                                sv: float, dt_s: float) -> None:
    last = measured(x_m, z_m, velocity=(ve, vn, sv))
    t_ns = last.t_ns + round(dt_s * 1e9)
    fix = coast(last, t_ns, TrackStatus.LOST, SITE, age_s=3.0, confidence=0.5)
    dt = (t_ns - last.t_ns) / 1e9
    moved = world_to_enu(np.array([fix.x_m - last.x_m, fix.y_m - last.y_m, fix.z_m - last.z_m]),
                         SITE.heading_deg)
    assert moved == pytest.approx([ve * dt, vn * dt, 0.0], abs=1e-6)
    range_m, bearing = range_bearing(np.array([fix.x_m, fix.y_m, fix.z_m]), SITE.heading_deg)
    lat, lon, _ = world_to_latlon(np.array([fix.x_m, fix.y_m, fix.z_m]), SITE)
    assert (fix.range_m, fix.bearing_deg, fix.lat_deg, fix.lon_deg) == pytest.approx(
        (float(range_m), float(bearing), float(lat), float(lon)), abs=1e-9)
    g = sv * dt  # the velocity's 1-sigma per axis, times the time
    assert fix.sigma_m == pytest.approx(math.sqrt(last.sigma_m ** 2 + 2 * g * g), rel=1e-12)
    assert fix.sigma_across_m == pytest.approx(math.hypot(3.0, g), rel=1e-12)
    assert fix.t_ns == t_ns and fix.coasted and fix.en_state is None and fix.en_cov is None
    assert (fix.sog_kn, fix.cog_deg, fix.length_m, fix.track_id) == (9.0, 45.0, 60.0, 7)


def test_without_a_velocity_the_fix_is_held_and_grows_by_the_fastest_ship() -> None:
    last = measured(300.0, 1500.0, across_m=None)
    fix = coast(last, last.t_ns + 2_000_000_000, TrackStatus.LOST, SITE, age_s=9.0, confidence=0.4)
    assert (fix.x_m, fix.y_m, fix.z_m) == (last.x_m, last.y_m, last.z_m)
    held = (last.lat_deg, last.lon_deg, last.range_m)
    assert (fix.lat_deg, fix.lon_deg, fix.range_m) == pytest.approx(held, abs=1e-12)
    g = MAX_SHIP_SPEED_MPS * 2.0  # 50 m per axis after 2 s
    assert fix.sigma_m == pytest.approx(math.sqrt(12.0 ** 2 + 2 * g * g))
    assert fix.sigma_across_m is None and (fix.age_s, fix.confidence) == (9.0, 0.4)


@pytest.mark.parametrize(("now", "sent"), [(TrackStatus.ACQUIRING, TrackStatus.ACQUIRING),
                                           (TrackStatus.TRACKING, TrackStatus.LOST),
                                           (TrackStatus.LOST, TrackStatus.LOST)])
def test_a_tentative_track_coasts_as_q_a_confirmed_one_as_l(now: TrackStatus, sent: TrackStatus) -> None:
    last = measured(0.0, 1000.0)
    assert coast(last, last.t_ns + 100_000_000, now, SITE, age_s=1.0, confidence=None).status is sent
