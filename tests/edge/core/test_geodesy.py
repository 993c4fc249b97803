"""edge.core.geodesy: WGS-84 <-> the rig's world frame, by known answers, invariants and round trips."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.geodesy import (
    WGS84_A_M,
    ecef_to_geodetic,
    geodetic_to_ecef,
    geodetic_to_world,
    world_axes,
    world_to_geodetic,
)
from edge.core.site import Site

AKASHI = Site(34.63, 135.02, 25.0, 180.0)


def test_equator_known_answer() -> None:
    """On the equator at sea level a point dlon east is at a (sin dlon, cos dlon - 1) from the origin."""
    dlon = math.radians(0.02)
    world = geodetic_to_world(0.0, 0.02, 0.0, Site(0.0, 0.0, 0.0, 90.0))  # looking east
    assert world == pytest.approx(
        [0.0, WGS84_A_M * (1 - math.cos(dlon)), WGS84_A_M * math.sin(dlon)], abs=1e-6
    )
    world = geodetic_to_world(0.0, 0.02, 0.0, Site(0.0, 0.0, 0.0, 0.0))  # looking north: east is to the right
    assert world[0] == pytest.approx(WGS84_A_M * math.sin(dlon), abs=1e-6)


def test_axes_are_orthonormal_and_y_is_down() -> None:
    axes = world_axes(AKASHI)
    assert axes @ axes.T == pytest.approx(np.eye(3), abs=1e-15)
    assert np.linalg.det(axes) == pytest.approx(1.0)  # right-handed: X right, Y down, Z forward
    above = geodetic_to_world(AKASHI.lat_deg, AKASHI.lon_deg, AKASHI.height_m + 10.0, AKASHI)
    assert above == pytest.approx([0.0, -10.0, 0.0], abs=1e-6)


def test_heading_rotates_about_the_vertical() -> None:
    point = (34.60, 135.05, 3.0)
    south = geodetic_to_world(*point, AKASHI)
    east = geodetic_to_world(*point, Site(34.63, 135.02, 25.0, 90.0))
    # facing east, "forward" is what was "left" facing south and "right" is what was "forward"; Y unchanged
    assert east == pytest.approx([south[2], south[1], -south[0]], abs=1e-6)


def test_sea_level_drops_below_the_tangent_plane() -> None:
    """A sea-level point 3 km ahead lies (height + D^2 / 2R) below the site (to 1 % of the curvature term)."""
    lat = AKASHI.lat_deg - 3000.0 / 111_000.0
    world = geodetic_to_world(lat, AKASHI.lon_deg, 0.0, AKASHI)
    d = math.hypot(world[0], world[2])
    assert world[1] - AKASHI.height_m == pytest.approx(d * d / (2 * 6_371_000.0), rel=0.01)


@settings(max_examples=80, deadline=None)
@given(
    st.floats(min_value=-80, max_value=80),
    st.floats(min_value=-180, max_value=180),
    st.floats(min_value=0, max_value=360),
    st.tuples(*[st.floats(min_value=-20_000, max_value=20_000)] * 3),
)
def test_round_trip_and_distance_invariance(lat: float, lon: float, heading: float, point: tuple) -> None:
    site = Site(lat, lon, 30.0, heading)
    p = np.array(point)
    back = geodetic_to_world(*world_to_geodetic(p, site), site)
    assert back == pytest.approx(p, abs=1e-6)
    origin = geodetic_to_ecef(lat, lon, 30.0)
    chord = np.linalg.norm(geodetic_to_ecef(*world_to_geodetic(p, site)) - origin)
    assert chord == pytest.approx(np.linalg.norm(p), abs=1e-6)


def test_ecef_round_trip_far_from_the_surface() -> None:
    lat, lon, h = (
        np.array([89.9, -45.0, 10.0]),
        np.array([0.0, 170.0, -60.0]),
        np.array([9000.0, -400.0, 1e5]),
    )
    got = ecef_to_geodetic(geodetic_to_ecef(lat, lon, h))
    for a, b, tol in zip(got, (lat, lon, h), (1e-10, 1e-10, 1e-6), strict=True):
        assert a == pytest.approx(b, abs=tol)


def test_agrees_with_proj() -> None:
    """PROJ's topocentric conversion (an independent implementation) gives the same east/north/up."""
    pyproj = pytest.importorskip("pyproj")
    lat = np.array([34.60, 34.65, 34.58])
    lon = np.array([135.00, 135.06, 135.03])
    h = np.array([0.0, 120.0, 5.0])
    pipe = pyproj.Transformer.from_pipeline(
        "+proj=pipeline +step +proj=cart +ellps=WGS84 +step +proj=topocentric +ellps=WGS84 "
        f"+lat_0={AKASHI.lat_deg} +lon_0={AKASHI.lon_deg} +h_0={AKASHI.height_m}"
    )
    east, north, up = pipe.transform(lon, lat, h)
    world = geodetic_to_world(lat, lon, h, AKASHI)  # heading 180: X = -east, Z = -north
    assert world == pytest.approx(np.stack([-east, -up, -north], axis=-1), abs=1e-6)


def test_ellipsoidal_height_adds_the_geoid_separation() -> None:
    """h = H + N where the site gives N (ASTERIX I034/120); without it there is no ellipsoidal height
    to give, and the bound on what taking H for h can cost is the geoid's largest |N|."""
    from edge.core.geodesy import GEOID_SEPARATION_BOUND_M, ellipsoidal_height_m

    above = Site(34.63, 135.02, 25.0, 180.0, geoid_separation_m=37.4)
    below = Site(-8.0, 80.0, 12.0, 0.0, geoid_separation_m=-102.0)
    assert ellipsoidal_height_m(above) == pytest.approx(62.4)
    assert ellipsoidal_height_m(below) == pytest.approx(-90.0)
    assert ellipsoidal_height_m(AKASHI) is None and GEOID_SEPARATION_BOUND_M >= 106.0
