"""WGS-84 latitude/longitude/height <-> the rig's world frame (X right, Y down, Z forward).

The rig frame (docs/method.md) has its origin at the baseline midpoint, the site
(lat, lon, height above mean sea level); +Z points horizontally along the
site heading (true azimuth), +X horizontally 90 deg to the right of it, +Y
straight down. It is the local tangent plane at the site, so the Earth's
curvature shows up where it physically does: a sea-level point D metres away
lies about D^2 / (2 R) below the plane (Y grows), 0.7 m at 3 km.

Closed form, no iteration one way: geodetic -> ECEF (WGS-84 ellipsoid) ->
local East-North-Up at the site -> world. The other way, ECEF -> geodetic uses
Bowring's formula with a few fixed-point refinements (sub-millimetre, far below
anything a camera measures). Heights are taken as given for site and points
(both above mean sea level): over a few kilometres the geoid undulation is the
same at both ends to well within a centimetre, so it cancels.

Where a height must be the ellipsoid's (ASTERIX I034/120 states the sensor's position on WGS-84),
`ellipsoidal_height_m` adds the site's geoid separation N when the survey gives it; the project
has no geoid model, and without N a height above mean sea level is off by N, whose magnitude is
at most `GEOID_SEPARATION_BOUND_M` anywhere (EGM2008 spans about -107 m to +86 m).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from edge.core.site import Site

WGS84_A_M = 6378137.0  # semi-major axis
WGS84_F = 1.0 / 298.257223563  # flattening
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)  # first eccentricity squared
GEOID_SEPARATION_BOUND_M = 107.0  # |N| anywhere on Earth (EGM2008: about -107 m to +86 m)


def geodetic_to_ecef(
    lat_deg: np.ndarray | float, lon_deg: np.ndarray | float, height_m: np.ndarray | float
) -> np.ndarray:
    """WGS-84 geodetic -> Earth-centred Earth-fixed (..., 3) metres."""
    lat = np.radians(np.asarray(lat_deg, dtype=np.float64))
    lon = np.radians(np.asarray(lon_deg, dtype=np.float64))
    h = np.asarray(height_m, dtype=np.float64)
    n = WGS84_A_M / np.sqrt(1.0 - WGS84_E2 * np.sin(lat) ** 2)  # prime vertical radius
    return np.stack([(n + h) * np.cos(lat) * np.cos(lon), (n + h) * np.cos(lat) * np.sin(lon),
                     (n * (1.0 - WGS84_E2) + h) * np.sin(lat)], axis=-1)


def ecef_to_geodetic(xyz_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ECEF (..., 3) -> (lat_deg, lon_deg, height_m); Bowring's start plus three refinements."""
    xyz = np.asarray(xyz_m, dtype=np.float64)
    x, y, z = xyz[..., 0], xyz[..., 1], xyz[..., 2]
    p = np.hypot(x, y)
    b = WGS84_A_M * (1.0 - WGS84_F)
    ep2 = WGS84_E2 / (1.0 - WGS84_E2)
    theta = np.arctan2(z * WGS84_A_M, p * b)
    lat = np.arctan2(z + ep2 * b * np.sin(theta) ** 3, p - WGS84_E2 * WGS84_A_M * np.cos(theta) ** 3)
    for _ in range(3):
        n = WGS84_A_M / np.sqrt(1.0 - WGS84_E2 * np.sin(lat) ** 2)
        h = p / np.cos(lat) - n
        lat = np.arctan2(z, p * (1.0 - WGS84_E2 * n / (n + h)))
    n = WGS84_A_M / np.sqrt(1.0 - WGS84_E2 * np.sin(lat) ** 2)
    h = p / np.cos(lat) - n
    return np.degrees(lat), np.degrees(np.arctan2(y, x)), h


@functools.lru_cache(maxsize=8)
def ellipsoidal_height_m(site: Site) -> float | None:
    """The site's height above the WGS-84 ellipsoid, h = H + N (H its height above mean sea level,
    N the geoid's separation from the ellipsoid there); None when the site gives no N."""
    if site.geoid_separation_m is None:
        return None
    return site.height_m + site.geoid_separation_m


def world_axes(site: Site) -> np.ndarray:
    """3x3 matrix whose rows are the world X (right), Y (down), Z (forward) axes in ECEF.
    Computed once per site (the pipeline converts every pair's fixes with it): read-only."""
    lat, lon = math.radians(site.lat_deg), math.radians(site.lon_deg)
    east = np.array([-math.sin(lon), math.cos(lon), 0.0])
    north = np.array([-math.sin(lat) * math.cos(lon), -math.sin(lat) * math.sin(lon), math.cos(lat)])
    up = np.array([math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon), math.sin(lat)])
    heading = math.radians(site.heading_deg)
    forward = north * math.cos(heading) + east * math.sin(heading)
    right = east * math.cos(heading) - north * math.sin(heading)
    axes = np.stack([right, -up, forward])
    axes.setflags(write=False)
    return axes


@functools.lru_cache(maxsize=8)
def _site_ecef(site: Site) -> np.ndarray:
    """The site's own ECEF position, once per site (read-only)."""
    origin = geodetic_to_ecef(site.lat_deg, site.lon_deg, site.height_m)
    origin.setflags(write=False)
    return origin


def geodetic_to_world(
    lat_deg: np.ndarray, lon_deg: np.ndarray, height_m: np.ndarray, site: Site
) -> np.ndarray:
    """WGS-84 points -> (..., 3) world-frame metres of the rig at `site`."""
    return (geodetic_to_ecef(lat_deg, lon_deg, height_m) - _site_ecef(site)) @ world_axes(site).T


def world_to_geodetic(points_m: np.ndarray, site: Site) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(..., 3) world-frame metres -> (lat_deg, lon_deg, height_m) on WGS-84."""
    return ecef_to_geodetic(np.asarray(points_m, dtype=np.float64) @ world_axes(site) + _site_ecef(site))
