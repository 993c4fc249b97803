"""`ShipFix`: one measured ship position, the unit every output consumes.

The pipeline emits one `ShipFix` per live track and pair; NMEA, Modbus and the
tracks CSV are all written from it. Times are UTC nanoseconds of the
measurement (not of sending); positions are in the rig frame of docs/method.md ("Frames and units")
(origin at the baseline midpoint, X right, Y down, Z forward) and on WGS-84.
Unknown values are ``None`` so that outputs can leave them empty, never 0.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass


class TrackStatus(enum.StrEnum):
    """Track lifecycle state, with the NMEA TTM/TLL status letters as values."""

    ACQUIRING = "Q"
    TRACKING = "T"
    LOST = "L"


@dataclass(frozen=True, slots=True)
class ShipFix:
    t_ns: int  # UTC of the measurement, ns since the Unix epoch
    track_id: int  # internal track id, never reused
    status: TrackStatus
    x_m: float  # world frame, metres (eq. 4.1)
    y_m: float
    z_m: float
    range_m: float  # horizontal distance from the site (baseline midpoint)
    bearing_deg: float  # true bearing from the site, [0, 360)
    lat_deg: float  # WGS-84
    lon_deg: float
    sog_kn: float | None  # speed over ground, knots; None until the track has motion
    cog_deg: float | None  # course over ground, true, [0, 360)
    sigma_m: float  # 1-sigma range error from the disparity sigma (eq. 4.5)
    disparity_px: float  # filtered disparity used for this fix
    age_s: float = 0.0  # time since the track was born
    confidence: float | None = None  # 0..1: share of the last 10 s of pairs the track was measured in
    length_m: float | None = None  # apparent ship length estimate
    sog_sigma_kn: float | None = None  # 1-sigma of sog_kn (None with it)
    cog_sigma_deg: float | None = None  # 1-sigma of cog_deg (None with it)
    ais_mmsi: int | None = None  # MMSI of the AIS target this track is associated with (issue 17)
    ais_name: str | None = None  # that target's name from AIS static data, when known
    dark: bool = False  # no AIS association for ais.dark_after_s (issue 17)
    # the ground-plane filter's state once its speed is known (SOG shown), for CPA/TCPA (issue 18):
    en_state: tuple[float, float, float, float] | None = None  # east m, north m, v east m/s, v north m/s
    en_cov: tuple[float, ...] | None = None  # its 4x4 covariance, row-major (16 values, m and m/s)
    sigma_across_m: float | None = None  # the share of sigma_m across the line of sight (bearing), m
    coasted: bool = False  # no usable position this pair: the last measured one carried (edge.measure.coast)
