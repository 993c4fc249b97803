"""ASTERIX data items as bytes: bit layouts, LSBs, rounding and saturation, one function each.

Every value is rounded to the nearest LSB (half away from zero is not needed: Python's round to
even is within half an LSB too). Where a field cannot hold a value it saturates at its largest
code, never wraps, and the caller documents what that means (docs/asterix-icd.md): I010/270
length at 127 m, I010/500 sigmas at 63.75 m and the covariance at +-8191.75 m^2. Angles wrap
(360 deg is 0). Positions that do not fit (I010/042 beyond +-32,767 m) return None: the caller
leaves the item out rather than send a wrong position.

LSBs (CAT 010 ed. 1.1, CAT 034 ed. 1.27):
- time of day 1/128 s; WGS-84 lat/lon 180/2^31 deg (I010/041), 180/2^23 deg (I034/120);
- Cartesian position 1 m; ground speed 2^-14 NM/s; track angle and orientation 360/2^16 and
  360/2^7 deg; Cartesian velocity 0.25 m/s (the specification; some decoders read 2^-4);
- sigma 0.25 m, covariance 0.25 m^2; length 1 m.
"""

from __future__ import annotations

import enum
import math
import struct

NS_PER_DAY = 86_400 * 1_000_000_000
TOD_PER_DAY = 86_400 * 128  # 1/128 s counts in a day (fits 24 bits)
LATLON_LSB_DEG = 180.0 / 2**31  # I010/041
LATLON_LSB_034_DEG = 180.0 / 2**23  # I034/120
SPEED_LSB_KN = 3600.0 / 2**14  # 2^-14 NM/s in knots (0.2197 kn)
ANGLE_LSB_DEG = 360.0 / 2**16  # I010/200 track angle
ORIENTATION_LSB_DEG = 360.0 / 2**7  # I010/270 (2.8125 deg)
VELOCITY_LSB_MPS = 0.25  # I010/202
SIGMA_LSB_M = 0.25  # I010/500 sigmas
COVARIANCE_LSB_M2 = 0.25  # I010/500 covariance
MAX_LENGTH_M = 127  # I010/270: 7 bits
MAX_SIGMA_M = 255 * SIGMA_LSB_M  # 63.75 m
KN_PER_MPS = 3600.0 / 1852.0


class MessageType(enum.IntEnum):
    """I010/000."""

    TARGET_REPORT = 1
    START_OF_UPDATE = 2
    PERIODIC_STATUS = 3
    EVENT_STATUS = 4


class TargetType(enum.IntEnum):
    """I010/020 TYP (3 bits)."""

    PSR = 3
    OTHER = 7


class Nogo(enum.IntEnum):
    """I010/550 NOGO (2 bits)."""

    OPERATIONAL = 0
    DEGRADED = 1
    NOGO = 2


class Coasting(enum.IntEnum):
    """I010/170 CST (2 bits)."""

    NONE = 0
    UNPREDICTABLE = 3  # extrapolation due to unpredictable absence of detection


def _clamp(value: int, lo: int, hi: int) -> int:
    return lo if value < lo else hi if value > hi else value


def data_source(sac: int, sic: int) -> bytes:
    """I010/010, I034/010: SAC and SIC, one octet each."""
    if not (0 <= sac <= 255 and 0 <= sic <= 255):
        raise ValueError(f"SAC and SIC must be 0..255, got {sac}, {sic}")
    return bytes((sac, sic))


def message_type(kind: int) -> bytes:
    """I010/000, I034/000: one octet."""
    return bytes((kind,))


def time_of_day_count(utc_ns: int) -> int:
    """UTC seconds since midnight in 1/128 s, rounded; 24:00:00 wraps to 0."""
    ns_of_day = utc_ns % NS_PER_DAY
    return ((ns_of_day * 128 + 500_000_000) // 1_000_000_000) % TOD_PER_DAY


def time_of_day(utc_ns: int) -> bytes:
    """I010/140, I034/030: 24 bits, LSB 1/128 s."""
    return time_of_day_count(utc_ns).to_bytes(3, "big")


def target_descriptor(typ: TargetType) -> bytes:
    """I010/020 first octet: TYP, DCR = CHN = GBS = CRT = 0, no extension."""
    return bytes((int(typ) << 5,))


def wgs84(lat_deg: float, lon_deg: float) -> bytes:
    """I010/041: latitude and longitude, signed 32 bits each, LSB 180/2^31 deg. Longitude 180
    is sent as -180 (the same meridian); latitude is clamped to the code range."""
    lat = _clamp(round(lat_deg / LATLON_LSB_DEG), -(2**31), 2**31 - 1)
    lon = round(lon_deg / LATLON_LSB_DEG)
    lon = (lon + 2**31) % 2**32 - 2**31
    return struct.pack(">ii", lat, lon)


def cartesian(x_m: float, y_m: float) -> bytes | None:
    """I010/042: x east, y north of the sensor, signed 16 bits each at 1 m; None beyond +-32,767 m."""
    x, y = round(x_m), round(y_m)
    if not (-32768 <= x <= 32767 and -32768 <= y <= 32767):
        return None
    return struct.pack(">hh", x, y)


def polar_velocity(sog_kn: float, cog_deg: float) -> bytes:
    """I010/200: ground speed 16 bits at 2^-14 NM/s (saturates at 14,400 kn), track angle 16 bits
    at 360/2^16 deg, clockwise from true north."""
    speed = _clamp(round(sog_kn / SPEED_LSB_KN), 0, 0xFFFF)
    angle = round(cog_deg / ANGLE_LSB_DEG) % 0x10000
    return struct.pack(">HH", speed, angle)


def cartesian_velocity(vx_mps: float, vy_mps: float) -> bytes:
    """I010/202: vx east, vy north, signed 16 bits each at 0.25 m/s (saturate at +-8,192 m/s)."""
    vx = _clamp(round(vx_mps / VELOCITY_LSB_MPS), -32768, 32767)
    vy = _clamp(round(vy_mps / VELOCITY_LSB_MPS), -32768, 32767)
    return struct.pack(">hh", vx, vy)


def track_number(number: int) -> bytes:
    """I010/161: 4 spare bits, 12-bit track number."""
    if not 0 <= number <= 0xFFF:
        raise ValueError(f"track number must be 0..4095, got {number}")
    return number.to_bytes(2, "big")


def track_status(*, tentative: bool, last: bool, coasting: Coasting, projected: bool = True,
                 smoothed: bool = True) -> bytes:
    """I010/170 first octet: CNF, TRE, CST, MAH = 0, TCC, STH, no extension."""
    return bytes((tentative << 7 | last << 6 | int(coasting) << 4 | projected << 2 | smoothed << 1,))


def size_orientation(length_m: float, orientation_deg: float | None) -> bytes:
    """I010/270: length 7 bits at 1 m (saturates at 127 m) and, when given, orientation 7 bits at
    360/128 deg; no width."""
    length = _clamp(round(length_m), 0, MAX_LENGTH_M)
    if orientation_deg is None:
        return bytes((length << 1,))
    orientation = round(orientation_deg / ORIENTATION_LSB_DEG) % 128
    return bytes((length << 1 | 1, orientation << 1))


def _sigma_code(sigma_m: float) -> int:
    return 255 if not math.isfinite(sigma_m) else _clamp(round(sigma_m / SIGMA_LSB_M), 0, 255)


def position_sigma(sigma_x_m: float, sigma_y_m: float, cov_xy_m2: float) -> bytes:
    """I010/500: sigma x and y, 8 bits each at 0.25 m, covariance signed 16 bits at 0.25 m^2.

    A sigma above 63.75 m (or not finite) is sent as 63.75 m, and the covariance is then the true
    correlation coefficient times the two sigmas sent; otherwise it is the true covariance,
    bounded by the product of the sigmas sent. Either way it is rounded toward zero, so the
    matrix sent is a valid one (positive semi-definite) whatever the rounding of the sigmas."""
    qx, qy = _sigma_code(sigma_x_m), _sigma_code(sigma_y_m)
    ok = all(math.isfinite(v) for v in (sigma_x_m, sigma_y_m, cov_xy_m2)) and sigma_x_m > 0 and sigma_y_m > 0
    limit = (qx * SIGMA_LSB_M) * (qy * SIGMA_LSB_M)  # |cov| <= sx * sy with the sigmas sent
    if not ok:
        cov = 0.0
    elif qx == 255 or qy == 255:
        cov = max(-1.0, min(1.0, cov_xy_m2 / (sigma_x_m * sigma_y_m))) * limit
    else:
        cov = max(-limit, min(limit, cov_xy_m2))
    qxy = _clamp(math.trunc(cov / COVARIANCE_LSB_M2), -32768, 32767)
    return struct.pack(">BBh", qx, qy, qxy)


def system_status(nogo: Nogo, overload: bool, time_invalid: bool) -> bytes:
    """I010/550: NOGO (2 bits), OVL, TSV, DIV = TTF = 0, 2 spare bits."""
    return bytes((int(nogo) << 6 | overload << 5 | time_invalid << 4,))


def sensor_position(lat_deg: float, lon_deg: float, height_m: float) -> bytes:
    """I034/120: height signed 16 bits at 1 m, latitude and longitude signed 24 bits each at
    180/2^23 deg."""
    height = _clamp(round(height_m), -32768, 32767)
    lat = _clamp(round(lat_deg / LATLON_LSB_034_DEG), -(2**23), 2**23 - 1)
    lon = (round(lon_deg / LATLON_LSB_034_DEG) + 2**23) % 2**24 - 2**23
    return struct.pack(">h", height) + lat.to_bytes(3, "big", signed=True) + \
        lon.to_bytes(3, "big", signed=True)


def service_status(*, nogo: bool, overload: bool, time_invalid: bool) -> bytes:
    """I034/050: primary subfield with COM only, then COM: NOGO, RDPC = RDPR = 0, OVL RDP,
    OVL XMT = MSC = 0, TSV, spare."""
    return bytes((0x80, nogo << 7 | overload << 4 | time_invalid << 1))
