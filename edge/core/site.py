"""The site: where the stereo rig stands and which way it looks.

The world frame's origin is the baseline midpoint; `heading_deg` is the true
azimuth of +Z (the optical axis direction), `height_m` the midpoint's height
above mean sea level (it sets the horizon dip and the sea plane at Y = +height).
`geoid_separation_m` is the geoid's height above the WGS-84 ellipsoid there (N, as a GNSS
receiver reports it in GGA), when the survey gives it: the site's ellipsoidal height is then
height_m + N (`edge.core.geodesy.ellipsoidal_height_m`). The measurement itself never needs it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Site:
    lat_deg: float  # WGS-84 latitude of the baseline midpoint
    lon_deg: float  # WGS-84 longitude
    height_m: float  # above mean sea level
    heading_deg: float  # true azimuth of the world +Z axis
    tilt_sigma_deg: float | None = None  # 1-sigma bound on the mast's lean per horizontal axis (None: none)
    geoid_separation_m: float | None = None  # N: the geoid above the WGS-84 ellipsoid here (None: not given)
