"""The site: where the stereo rig stands and which way it looks.

The world frame's origin is the baseline midpoint; `heading_deg` is the true
azimuth of +Z (the optical axis direction), `height_m` the midpoint's height
above mean sea level (it sets the horizon dip and the sea plane at Y = +height).
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
