"""CAT 010 edition 1.1 records: a `ShipFix` as a target report, the sensor's health as status.

Target report (message type 1), items in FRN order:
  I010/010 SAC/SIC, /000 type 1, /020 target type (configured; PSR by default), /140 the fix's
  exposure time (UTC), /041 WGS-84 position, /042 x east / y north of the site (left out beyond
  +-32,767 m), /200 and /202 speed and course once both are reported (SOG and COG not None),
  /161 track number, /170 track status, /270 length (and the course as orientation) when the
  length is known, /500 the position's standard deviations and covariance.
I010/170: CNF = 1 (initiation) for a Q track, 0 for T and L; TRE = 1 on the report that ends a
track; CST = 3 (unpredictable absence of detection) while the track is L or its fix is coasted
(no usable position in this pair: `edge.measure.coast`), else 0;
TCC = 1 (tracked on the ground plane) and STH = 1 (smoothed: the filtered disparity).
I010/500 comes from the fix's own 1-sigma: `sigma_across_m` across the line of sight (the
bearing's share), the rest of `sigma_m` along it, rotated to east/north by the bearing; without
`sigma_across_m` the ellipse is a circle of `sigma_m`.

Status (types 3 and 4): I010/010, /000, /140 and /550; start of update cycle (type 2):
I010/010, /000, /140. `sensor_status` maps the appliance health to I010/550.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

from edge.appliance.health import HealthState
from edge.encode.asterix.blocks import fspec, record
from edge.encode.asterix.items import (
    KN_PER_MPS,
    Coasting,
    MessageType,
    Nogo,
    TargetType,
    cartesian,
    cartesian_velocity,
    data_source,
    message_type,
    polar_velocity,
    position_sigma,
    size_orientation,
    system_status,
    target_descriptor,
    time_of_day,
    track_number,
    track_status,
    wgs84,
)
from edge.fix import ShipFix, TrackStatus

CATEGORY = 10
# Field Reference Numbers of the CAT 010 ed. 1.1 UAP (the items this appliance sends)
FRN = {"010": 1, "000": 2, "020": 3, "140": 4, "041": 5, "042": 7, "200": 8, "202": 9, "161": 10,
       "170": 11, "270": 19, "550": 20, "500": 22}


@dataclass(frozen=True, slots=True)
class Source:
    """Who sends: I010/010's SAC and SIC and the I010/020 target type of every report."""

    sac: int
    sic: int
    target_type: TargetType = TargetType.PSR

    def __post_init__(self) -> None:
        data_source(self.sac, self.sic)  # ValueError now, not at the first report


@dataclass(frozen=True, slots=True)
class SensorStatus:
    """I010/550 (and I034/050): the sensor's operational state, overload and time source."""

    nogo: Nogo = Nogo.OPERATIONAL
    overload: bool = False
    time_invalid: bool = False


def sensor_status(state: HealthState, time_synchronised: bool, overloaded: bool) -> SensorStatus:
    """OK -> operational, DEGRADED -> degraded, STALLED (FAULT) -> NOGO; TSV while the clock is not
    synchronised; OVL as the caller judged it (pairs dropped or late)."""
    nogo = {HealthState.OK: Nogo.OPERATIONAL, HealthState.DEGRADED: Nogo.DEGRADED,
            HealthState.STALLED: Nogo.NOGO}[state]
    return SensorStatus(nogo, overloaded, not time_synchronised)


def east_north_m(fix: ShipFix) -> tuple[float, float]:
    """The fix's horizontal offset from the site: east and north, m."""
    b = math.radians(fix.bearing_deg)
    return fix.range_m * math.sin(b), fix.range_m * math.cos(b)


def position_covariance(fix: ShipFix) -> tuple[float, float, float]:
    """(sigma east, sigma north, covariance) of the fix's position, m and m^2."""
    total, across = fix.sigma_m, fix.sigma_across_m
    if not math.isfinite(total):
        return math.inf, math.inf, 0.0
    if across is None or not math.isfinite(across):
        return total, total, 0.0
    across = min(abs(across), total)
    along_sq, across_sq = total * total - across * across, across * across
    b = math.radians(fix.bearing_deg)
    s, c = math.sin(b), math.cos(b)  # line of sight (east, north) = (s, c); across it (c, -s)
    var_e = along_sq * s * s + across_sq * c * c
    var_n = along_sq * c * c + across_sq * s * s
    return math.sqrt(var_e), math.sqrt(var_n), (along_sq - across_sq) * s * c


def velocity_en_mps(sog_kn: float, cog_deg: float) -> tuple[float, float]:
    """Speed and course as east and north velocity, m/s."""
    v, c = sog_kn / KN_PER_MPS, math.radians(cog_deg)
    return v * math.sin(c), v * math.cos(c)


@functools.lru_cache(maxsize=64)
def _head(source: Source) -> bytes:
    """I010/010, /000 (target report) and /020: the same three items in every report of a source."""
    return data_source(source.sac, source.sic) + message_type(MessageType.TARGET_REPORT) + \
        target_descriptor(source.target_type)


_fspec = functools.lru_cache(maxsize=64)(fspec)  # a handful of item sets recur


def target_report(fix: ShipFix, number: int, source: Source, *, last: bool = False) -> bytes:
    """One type 1 record for `fix` under track number `number`; `last` sets TRE (the track ends).
    ValueError for a fix that cannot be coded (a position that is not finite). The items are
    joined in FRN order directly (this runs for every track at every pair)."""
    if not (math.isfinite(fix.lat_deg) and math.isfinite(fix.lon_deg) and math.isfinite(fix.range_m)):
        raise ValueError(f"track {fix.track_id}: position not finite")
    frns = [FRN["010"], FRN["000"], FRN["020"], FRN["140"], FRN["041"]]
    parts = [_head(source), time_of_day(fix.t_ns), wgs84(fix.lat_deg, fix.lon_deg)]
    xy = cartesian(*east_north_m(fix))
    if xy is not None:
        frns.append(FRN["042"])
        parts.append(xy)
    if fix.sog_kn is not None and fix.cog_deg is not None:
        frns += (FRN["200"], FRN["202"])
        parts += (polar_velocity(fix.sog_kn, fix.cog_deg),
                  cartesian_velocity(*velocity_en_mps(fix.sog_kn, fix.cog_deg)))
    coasting = Coasting.UNPREDICTABLE if fix.status is TrackStatus.LOST or fix.coasted else Coasting.NONE
    frns += (FRN["161"], FRN["170"])
    parts += (track_number(number),
              track_status(tentative=fix.status is TrackStatus.ACQUIRING, last=last, coasting=coasting))
    if fix.length_m is not None and math.isfinite(fix.length_m) and fix.length_m > 0:
        frns.append(FRN["270"])
        parts.append(size_orientation(fix.length_m, fix.cog_deg))
    frns.append(FRN["500"])
    parts.append(position_sigma(*position_covariance(fix)))
    return _fspec(tuple(frns)) + b"".join(parts)


def status_report(source: Source, utc_ns: int, status: SensorStatus, *, event: bool = False) -> bytes:
    """A periodic (type 3) or, with `event`, event-triggered (type 4) status record."""
    kind = MessageType.EVENT_STATUS if event else MessageType.PERIODIC_STATUS
    return record({FRN["010"]: data_source(source.sac, source.sic), FRN["000"]: message_type(kind),
                   FRN["140"]: time_of_day(utc_ns),
                   FRN["550"]: system_status(status.nogo, status.overload, status.time_invalid)})


def start_of_update(source: Source, utc_ns: int) -> bytes:
    """A start-of-update-cycle (type 2) record."""
    return record({FRN["010"]: data_source(source.sac, source.sic),
                   FRN["000"]: message_type(MessageType.START_OF_UPDATE), FRN["140"]: time_of_day(utc_ns)})
