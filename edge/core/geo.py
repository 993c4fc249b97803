"""Where a triangulated point is on the Earth: east/north/up, range, true bearing, WGS-84, SOG/COG.

The rig frame (docs/method.md) is the rig's local tangent plane at the site: origin
at the baseline midpoint, +Z horizontal along the site heading (true azimuth),
+X horizontal 90 deg to its right, +Y straight down. East/north/up is
therefore one rotation about the vertical by the heading, exactly:

    east  = X cos(h) + Z sin(h)
    north = Z cos(h) - X sin(h)
    up    = -Y

Range is the horizontal distance from the site in that plane (hypot(X, Z),
what the NMEA TTM distance and the Modbus range register carry); bearing is
true, atan2(east, north), in [0, 360).

Latitude/longitude use the closed form of `edge.core.geodesy` (WGS-84
geodetic -> ECEF -> local tangent plane and back; Bowring with refinements,
sub-millimetre at these ranges), rather than a runtime geodesy dependency:
the conversion is a few lines of exact algebra and is tested against PROJ
(pyproj) as an independent implementation. Speed and course come from the
track's filtered world-frame velocity, resolved on east/north at the target.
"""

from __future__ import annotations

import math

import numpy as np

from edge.core.geodesy import world_axes, world_to_geodetic
from edge.core.site import Site

KNOT_MPS = 1852.0 / 3600.0  # one knot in m/s (international nautical mile)
EARTH_RADIUS_M = 6_371_000.0  # mean radius, for the horizon dip
REFRACTION_K = 0.13  # standard optical refraction coefficient (surveying): Earth looks R / (1 - k)


def _wrap_deg(angle_deg: np.ndarray) -> np.ndarray:
    """Angles into [0, 360): never 360.0 itself (np.mod(-1e-15, 360) is 360.0 in floats)."""
    a = np.mod(angle_deg, 360.0)
    return np.where(a >= 360.0, 0.0, a)


def world_to_enu(points_m: np.ndarray, heading_deg: float) -> np.ndarray:
    """(..., 3) world X/Y/Z metres -> (..., 3) east/north/up metres of the site's tangent plane."""
    p = np.asarray(points_m, dtype=np.float64)
    h = math.radians(heading_deg)
    c, s = math.cos(h), math.sin(h)
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    return np.stack([x * c + z * s, z * c - x * s, -y], axis=-1)


def enu_to_world(enu_m: np.ndarray, heading_deg: float) -> np.ndarray:
    """Inverse of `world_to_enu`."""
    e = np.asarray(enu_m, dtype=np.float64)
    h = math.radians(heading_deg)
    c, s = math.cos(h), math.sin(h)
    east, north, up = e[..., 0], e[..., 1], e[..., 2]
    return np.stack([east * c - north * s, -up, east * s + north * c], axis=-1)


def range_bearing(points_m: np.ndarray, heading_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """(..., 3) world points -> (horizontal range m, true bearing deg in [0, 360)) from the site."""
    p = np.asarray(points_m, dtype=np.float64)
    range_m = np.hypot(p[..., 0], p[..., 2])
    # bearing = heading + the angle of the point right of +Z
    bearing = _wrap_deg(heading_deg + np.degrees(np.arctan2(p[..., 0], p[..., 2])))
    return range_m, bearing


def horizon_dip_rad(height_m: float, refraction_k: float = REFRACTION_K) -> float:
    """Angle of the sea horizon below the horizontal for an eye `height_m` above the sea.

    Straight rays over the effective Earth R_e = R / (1 - k) (standard refraction):
    dip = arccos(R_e / (R_e + h)), about 0.19 deg at 40 m."""
    r_e = EARTH_RADIUS_M / (1.0 - refraction_k)
    return math.acos(r_e / (r_e + max(0.0, height_m)))


def sea_range_m(depression_rad: np.ndarray | float, height_m: float,
                refraction_k: float = REFRACTION_K) -> np.ndarray:
    """Horizontal distance to where a ray `depression_rad` below the horizontal meets the sea.

    Ray against the effective-Earth sphere (as `horizon_dip_rad`); inf at or above
    the horizon. Used to check that a ship's waterline and its stereo range agree."""
    r_e = EARTH_RADIUS_M / (1.0 - refraction_k)
    a = np.asarray(depression_rad, dtype=np.float64)
    r0 = r_e + max(0.0, height_m)
    disc = r_e * r_e - (r0 * np.cos(a)) ** 2
    with np.errstate(invalid="ignore"):
        slant = r0 * np.sin(a) - np.sqrt(disc)
    return np.where((disc >= 0.0) & (a > 0.0), slant * np.cos(a), np.inf)


def height_above_sea_m(points_m: np.ndarray, site_height_m: float,
                       refraction_k: float = REFRACTION_K) -> np.ndarray:
    """Height of (..., 3) world points above the sea surface below them (effective-Earth sphere).

    The sea at horizontal distance D lies D^2 / (2 R_e) below the site's tangent plane,
    which sits `site_height_m` above it: height = h + D^2 / (2 R_e) - Y (Y is down)."""
    p = np.asarray(points_m, dtype=np.float64)
    r_e = EARTH_RADIUS_M / (1.0 - refraction_k)
    d2 = p[..., 0] ** 2 + p[..., 2] ** 2
    return site_height_m + d2 / (2.0 * r_e) - p[..., 1]


def world_to_latlon(points_m: np.ndarray, site: Site) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(..., 3) world points -> (lat_deg, lon_deg, height above the site's datum m) on WGS-84."""
    return world_to_geodetic(points_m, site)


def speed_course(velocity_mps: np.ndarray, lat_deg: float | np.ndarray, lon_deg: float | np.ndarray,
                 site: Site) -> tuple[np.ndarray, np.ndarray]:
    """World-frame velocity (..., 3) m/s of a target at (lat, lon) -> (SOG knots, COG true deg [0, 360)).

    The course is measured against true north *at the target*: the velocity is
    taken to ECEF and projected on the target's own east/north, so the meridian
    convergence between site and target (0.01 deg at 2 km east at 35 deg N) is
    not mistaken for a course change. The vertical part is ignored. COG of a
    stationary target is undefined; it comes back as 0.0 with SOG 0.0, and
    callers that must report "unknown" decide by SOG themselves.
    """
    v_ecef = np.asarray(velocity_mps, dtype=np.float64) @ world_axes(site)
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    east = -np.sin(lon) * v_ecef[..., 0] + np.cos(lon) * v_ecef[..., 1]
    north = (-np.sin(lat) * np.cos(lon) * v_ecef[..., 0] - np.sin(lat) * np.sin(lon) * v_ecef[..., 1]
             + np.cos(lat) * v_ecef[..., 2])
    return np.hypot(east, north) / KNOT_MPS, _wrap_deg(np.degrees(np.arctan2(east, north)))
