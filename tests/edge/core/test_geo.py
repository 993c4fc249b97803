"""geo: world frame -> ENU / range / bearing / WGS-84 / SOG-COG, checked against PROJ (pyproj) as an
independent implementation (test-only dependency) and against known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.geo import KNOT_MPS, enu_to_world, range_bearing, speed_course, world_to_enu, world_to_latlon
from edge.core.site import Site

pyproj = pytest.importorskip("pyproj")


def _topocentric(site: Site):
    """PROJ pipeline: WGS-84 (lon, lat deg, h) -> local east/north/up at the site."""
    return pyproj.Transformer.from_pipeline(
        "+proj=pipeline +step +proj=unitconvert +xy_in=deg +xy_out=rad +step +proj=cart +ellps=WGS84 "
        f"+step +proj=topocentric +ellps=WGS84 +lat_0={site.lat_deg!r} +lon_0={site.lon_deg!r} "
        f"+h_0={site.height_m!r}"
    )


sites = st.builds(
    Site, st.floats(-80.0, 80.0), st.floats(-180.0, 180.0), st.floats(0.0, 300.0), st.floats(0.0, 360.0)
)


@settings(max_examples=60, deadline=None)
@given(site=sites, range_m=st.floats(10.0, 10_000.0), az=st.floats(-180.0, 180.0),
       y=st.floats(-200.0, 300.0))
def test_latlon_agrees_with_proj_to_a_millimetre_at_10_km(site: Site, range_m: float, az: float,
                                                          y: float) -> None:
    a = math.radians(az)
    world = np.array([range_m * math.sin(a), y, range_m * math.cos(a)])
    lat, lon, h = world_to_latlon(world, site)
    proj = _topocentric(site)
    east, north, up = proj.transform(float(lon), float(lat), float(h))
    # our lat/lon/h put back through PROJ must land on the world point (ENU of our own rotation)
    err = np.array([east, north, up]) - world_to_enu(world, site.heading_deg)
    assert np.linalg.norm(err) < 1e-3
    # and PROJ's inverse from that ENU gives the same latitude/longitude (1 mm ~ 9e-9 deg)
    lon_p, lat_p, h_p = proj.transform(*world_to_enu(world, site.heading_deg), direction="INVERSE")
    assert abs(lat_p - lat) * 111_000 < 1e-3
    assert abs(lon_p - lon) * 111_000 * math.cos(math.radians(lat)) < 1e-3
    assert abs(h_p - h) < 1e-3


def test_known_directions() -> None:
    # heading 90 (looking east): ahead is east, right is south, down is -up
    enu = world_to_enu(np.array([[0.0, 0.0, 1000.0], [1000.0, 0.0, 0.0], [0.0, 5.0, 0.0]]), 90.0)
    np.testing.assert_allclose(enu, [[1000, 0, 0], [0, -1000, 0], [0, 0, -5]], atol=1e-9)
    r, b = range_bearing(np.array([[0.0, 3.0, 1000.0], [1000.0, 0.0, 0.0], [-3.0, 0.0, 4.0]]), 90.0)
    np.testing.assert_allclose(r, [1000.0, 1000.0, 5.0])
    np.testing.assert_allclose(b, [90.0, 180.0, 90.0 - math.degrees(math.atan2(3.0, 4.0))])


def test_bearing_wraps_into_0_360_never_360() -> None:
    _, b = range_bearing(np.array([[math.tan(math.radians(20.0)), 0.0, 1.0]]), 350.0)
    assert b[0] == pytest.approx(10.0)
    _, b = range_bearing(np.array([[-1e-17, 0.0, 1.0]]), 0.0)  # a hair left of north
    assert 0.0 <= b[0] < 360.0
    _, cog = speed_course(np.array([-1e-17, 0.0, 1.0]), 0.0, 0.0, Site(0.0, 0.0, 0.0, 0.0))
    assert 0.0 <= float(cog) < 360.0


@settings(max_examples=50, deadline=None)
@given(heading=st.floats(0.0, 360.0), xyz=st.tuples(*[st.floats(-1e4, 1e4)] * 3))
def test_enu_round_trip_and_range_invariant(heading: float, xyz: tuple[float, float, float]) -> None:
    p = np.array(xyz)
    enu = world_to_enu(p, heading)
    np.testing.assert_allclose(enu_to_world(enu, heading), p, atol=1e-8)
    r, b = range_bearing(p, heading)
    assert float(r) == pytest.approx(math.hypot(enu[0], enu[1]), abs=1e-8)
    if r > 1e-3:  # bearing is the compass angle of (east, north)
        expected = math.degrees(math.atan2(enu[0], enu[1])) % 360.0
        assert min(abs(float(b) - expected), 360 - abs(float(b) - expected)) < 1e-7


@pytest.mark.parametrize(("heading", "vx", "vz", "sog", "cog"), [
    (0.0, 0.0, KNOT_MPS, 1.0, 0.0),         # moving along +Z = north
    (0.0, 10 * KNOT_MPS, 0.0, 10.0, 90.0),  # moving right = east
    (45.0, 0.0, -2 * KNOT_MPS, 2.0, 225.0),  # towards the rig looking north-east
    (300.0, 3 * KNOT_MPS, 4 * KNOT_MPS, 5.0, (300.0 + math.degrees(math.atan2(3, 4))) % 360),
])
def test_speed_course_known_answers_at_the_site(heading: float, vx: float, vz: float, sog: float,
                                                cog: float) -> None:
    site = Site(34.6, 135.0, 40.0, heading)
    s, c = speed_course(np.array([vx, 0.3, vz]), site.lat_deg, site.lon_deg, site)  # vertical ignored
    assert float(s) == pytest.approx(sog)
    assert float(c) == pytest.approx(cog)


@settings(max_examples=30, deadline=None)
@given(site=sites, range_m=st.floats(100.0, 10_000.0), az=st.floats(-180.0, 180.0),
       vel=st.tuples(st.floats(-15.0, 15.0), st.floats(-15.0, 15.0)).filter(lambda v: math.hypot(*v) > 0.5))
def test_course_bearing_and_speed_agree_with_proj_geodesics(site: Site, range_m: float, az: float,
                                                            vel: tuple[float, float]) -> None:
    """Bearing = geodesic azimuth from the site; SOG/COG = geodesic distance/azimuth between the fixes
    one second apart (so COG is true north at the target, meridian convergence included)."""
    a = math.radians(az)
    p0 = np.array([range_m * math.sin(a), site.height_m, range_m * math.cos(a)])  # near sea level
    v = np.array([vel[0], 0.0, vel[1]])
    (lat0, lon0, _), (lat1, lon1, _) = world_to_latlon(p0, site), world_to_latlon(p0 + v, site)
    geod = pyproj.Geod(ellps="WGS84")
    az_site, _, _ = geod.inv(site.lon_deg, site.lat_deg, float(lon0), float(lat0))
    _, b = range_bearing(p0, site.heading_deg)
    assert abs((float(b) - az_site + 180.0) % 360.0 - 180.0) < 1e-3
    az_ship, _, dist = geod.inv(float(lon0), float(lat0), float(lon1), float(lat1))
    sog, cog = speed_course(v, lat0, lon0, site)
    assert float(sog) * KNOT_MPS == pytest.approx(dist, rel=1e-3)
    assert abs((float(cog) - az_ship + 180.0) % 360.0 - 180.0) < 1e-3


def test_horizon_dip_known_answer_and_sea_range() -> None:
    from edge.core.geo import horizon_dip_rad, sea_range_m

    # 25 m above the sea with standard refraction: 2.613 mrad (the simulator's akashi note), and the
    # refraction-free dip is larger by 1/sqrt(1 - k)
    assert horizon_dip_rad(25.0) == pytest.approx(2.613e-3, abs=1e-6)
    assert horizon_dip_rad(25.0, 0.0) / horizon_dip_rad(25.0) == pytest.approx(1 / math.sqrt(0.87), rel=1e-4)
    dip = horizon_dip_rad(25.0)
    r_e = 6_371_000.0 / 0.87
    assert float(sea_range_m(dip * (1 + 1e-9), 25.0)) == pytest.approx(math.sqrt(2 * r_e * 25.0), rel=1e-3)
    assert math.isinf(float(sea_range_m(0.9 * dip, 25.0)))
    assert math.isinf(float(sea_range_m(-0.01, 25.0)))
    # steep rays: the flat-sea answer h / tan(a), less the curvature drop (range^2 / 2R_e) over the slope
    a = 0.05
    flat = 25.0 / math.tan(a)
    assert float(sea_range_m(a, 25.0)) == pytest.approx(flat * (1 + flat / (2 * r_e) / math.tan(a)), rel=1e-4)
