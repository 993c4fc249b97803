"""ShipFix -> NMEA 0183 (IEC 61162-1) sentences: TTM, TLL and the proprietary TXY.

Pure string functions, no I/O, so the same text goes to serial, UDP, files and
tests. The conventions are those of docs/nmea.md (worked examples there):

- ``$`` + address + fields + ``*hh`` + CR LF, at most 82 characters in all;
  the checksum is the XOR of every character between ``$`` and ``*``.
- Fields never contain the reserved characters ``$ * , ! \\ ^ ~`` or anything
  outside printable ASCII; a violation raises `NmeaError` instead of sending
  a line that a receiver would mis-split. Target names given from outside are
  sanitised first (`sanitise_name`); our own are ``TRK`` + the track id.
- Unknown values (``None`` or non-finite) are empty fields, never 0: OpenCPN
  reads a TTM distance of 0 as a lost target, so a live target whose distance
  rounds to ``0.000`` NM is sent as ``0.001`` (the smallest printable value).
- Angles are ``%.1f`` in [0, 360): 359.96 is sent as ``0.0``, never ``360.0``.
- Latitude ``ddmm.mmmm``, longitude ``dddmm.mmmm``; rounding is done on whole
  1e-4 arc-minutes, so minutes that round to 60 carry into the degrees.
- UTC is the time of the measurement (``ShipFix.t_ns``), ``hhmmss.ss``,
  truncated to the hundredth (never rounded into the next second).

IEC 61162-450 framing (``UdPbC\\0`` + tag block) is here too; it is meant for
UDP only and never for the serial line.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence
from typing import TypeGuard

from edge.fix import ShipFix, TrackStatus

MAX_SENTENCE_CHARS = 82  # including "$" and CR LF (IEC 61162-1)
MAX_TAG_BLOCK_CHARS = 80  # IEC 61162-450, including both backslashes
RESERVED_CHARS = frozenset("$*,!\\^~")
METRES_PER_NM = 1852.0
MPS_PER_KNOT = METRES_PER_NM / 3600.0
NAME_CHARS = 8  # Furuno IPS shows 8 characters of the target name
AIS_NAME_CHARS = 20  # an AIS name has 20 characters (ITU-R M.1371 type 5); a TTM/TXY with it stays <= 82
DARK_PREFIX = "DARK"  # name prefix of a T track with no AIS association (ais.dark_prefix)
KINDS = ("TTM", "TLL", "TXY")  # sentence kinds a port may choose, in sending order
UDPBC = b"UdPbC\x00"  # IEC 61162-450 token for sentence datagrams

_TALKER = re.compile(r"[A-Z0-9]{2}")
_ADDRESS = re.compile(r"(?!P)[A-Z0-9]{2}[A-Z]{3}|P[A-Z0-9]{3}[A-Z0-9]{1,6}")
_MANUFACTURER = re.compile(r"[A-Z0-9]{3}")
_SOURCE = re.compile(r"[A-Z0-9]{2}\d{4}")


class NmeaError(ValueError):
    """A sentence would break IEC 61162-1 framing; it is refused, not sent."""


def checksum(body: str) -> str:
    """Two upper-case hex digits: XOR of the characters between ``$`` and ``*``."""
    value = 0
    for char in body.encode("ascii"):
        value ^= char
    return f"{value:02X}"


def check_talker(talker: str) -> str:
    """Return `talker` if it is a valid 2-character talker id (``RA``, ``II``, ``U0``...)."""
    if not _TALKER.fullmatch(talker) or talker.startswith("P"):
        raise NmeaError(f"talker must be 2 characters A-Z/0-9 not starting with P, got {talker!r}")
    return talker


def check_manufacturer(code: str) -> str:
    """Return `code` if it is a valid 3-character NMEA manufacturer code."""
    if not _MANUFACTURER.fullmatch(code):
        raise NmeaError(f"manufacturer code must be 3 characters A-Z/0-9, got {code!r}")
    return code


def check_field(text: str) -> str:
    """Return `text` if it may stand inside a field (printable ASCII, no reserved character)."""
    for char in text:
        if not " " <= char <= "~" or char in RESERVED_CHARS:
            raise NmeaError(f"field {text!r} contains reserved or non-printable character {char!r}")
    return text


def sentence(address: str, fields: Sequence[str]) -> str:
    """Frame one sentence: ``$address,f1,...,fn*hh\\r\\n``; refuse what breaks the rules.

    Trailing empty fields are kept (strict parsers such as marnav count them).
    """
    if not _ADDRESS.fullmatch(address):
        raise NmeaError(f"bad sentence address {address!r}")
    body = ",".join([address, *(check_field(f) for f in fields)])
    line = f"${body}*{checksum(body)}\r\n"
    if len(line) > MAX_SENTENCE_CHARS:
        raise NmeaError(f"sentence has {len(line)} characters, more than {MAX_SENTENCE_CHARS}: {line!r}")
    return line


def _known(value: float | None) -> TypeGuard[float]:
    return value is not None and math.isfinite(value)


def fmt_number(value: float | None, decimals: int) -> str:
    """``%.{decimals}f``, empty for unknown values, without a ``-0.0``."""
    if not _known(value):
        return ""
    text = f"{value:.{decimals}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


def fmt_angle(deg: float | None) -> str:
    """True bearing/course as ``%.1f`` in [0, 360): 359.96 -> ``0.0``, -0.04 -> ``0.0``."""
    if not _known(deg):
        return ""
    text = f"{deg % 360.0:.1f}"
    return "0.0" if text == "360.0" else text


def fmt_distance_nm(range_m: float | None, live: bool) -> str:
    """Distance ``%.3f`` NM; a live target is never sent as 0 (OpenCPN: 0 = lost)."""
    if not _known(range_m) or range_m < 0:
        return ""
    text = f"{range_m / METRES_PER_NM:.3f}"
    return "0.001" if live and float(text) == 0.0 else text


def _fmt_degrees_minutes(value_deg: float | None, deg_digits: int, hemispheres: str) -> tuple[str, str]:
    if not _known(value_deg):
        return "", ""
    total = round(abs(value_deg) * 600_000)  # whole 1e-4 arc-minutes: minutes == 60 carry into degrees
    degrees, rest = divmod(total, 600_000)
    minutes, fraction = divmod(rest, 10_000)
    hemisphere = hemispheres[1] if value_deg < 0 and total > 0 else hemispheres[0]
    return f"{degrees:0{deg_digits}d}{minutes:02d}.{fraction:04d}", hemisphere


def fmt_lat(lat_deg: float | None) -> tuple[str, str]:
    """Latitude as (``ddmm.mmmm``, ``N``/``S``); empty pair when unknown."""
    return _fmt_degrees_minutes(lat_deg, 2, "NS")


def fmt_lon(lon_deg: float | None) -> tuple[str, str]:
    """Longitude as (``dddmm.mmmm``, ``E``/``W``); empty pair when unknown."""
    return _fmt_degrees_minutes(lon_deg, 3, "EW")


def fmt_utc(t_ns: int) -> str:
    """UTC time of day ``hhmmss.ss`` of a Unix time in ns, truncated to 0.01 s."""
    centis = (t_ns // 10_000_000) % 8_640_000
    seconds, hundredths = divmod(centis, 100)
    return f"{seconds // 3600:02d}{seconds // 60 % 60:02d}{seconds % 60:02d}.{hundredths:02d}"


def target_name(track_id: int) -> str:
    """``TRK`` + track id in at most 8 characters.

    Ids above 99999 shorten the prefix (``TR123456``, ``T1234567``, ``12345678``)
    so the id stays readable; above 8 digits only the last 8 are shown.
    """
    digits = str(track_id % 10**NAME_CHARS)
    return "TRK"[: max(0, NAME_CHARS - len(digits))] + digits


def sanitise_name(text: str, track_id: int) -> str:
    """A target name from outside (an AIS name, an operator's label) made safe for any field.

    Only printable ASCII stays, without the reserved ``$ * , ! \\ ^ ~`` (IEC 61162-1: they
    would split or end the sentence, and a control character could end the line); runs of
    spaces collapse, and at most `NAME_CHARS` remain so every sentence keeps within 82
    characters. Nothing left: the track's own ``TRK`` name.
    """
    kept = "".join(c for c in text if " " <= c <= "~" and c not in RESERVED_CHARS)
    return " ".join(kept.split())[:NAME_CHARS].strip() or target_name(track_id)


def _fitted(address: str, fields: list[str], name_at: int) -> str:
    """`sentence`, with a long target name (an AIS name: up to 20 characters) cut just enough that
    the line keeps within 82 characters; our own names are short enough never to be cut."""
    body = len(address) + sum(len(f) + 1 for f in fields) + 6  # "$", "*hh", CR LF
    over = body - MAX_SENTENCE_CHARS
    if over > 0 and len(fields[name_at]) > NAME_CHARS:
        fields = list(fields)
        fields[name_at] = fields[name_at][:max(NAME_CHARS, len(fields[name_at]) - over)].rstrip() or "?"
    return sentence(address, fields)


def fix_name(fix: ShipFix, dark_prefix: str = DARK_PREFIX) -> str:
    """The target name a fix carries on NMEA (issue 17): its AIS name (sanitised, up to 20
    characters), else its MMSI (9 digits) when associated; a dark track the prefix before its
    ``TRK`` name (``DARK123``, cut to 20 characters); otherwise ``TRK`` + the track id."""
    if fix.ais_mmsi is not None:
        if fix.ais_name:
            kept = "".join(c for c in fix.ais_name if " " <= c <= "~" and c not in RESERVED_CHARS)
            name = " ".join(kept.split())[:AIS_NAME_CHARS].strip()
            if name:
                return name
        return str(fix.ais_mmsi)[:AIS_NAME_CHARS]
    if fix.dark and dark_prefix:
        prefix = "".join(c for c in dark_prefix if c.isalnum() and c.isascii())[:6]
        return (prefix + str(fix.track_id))[:AIS_NAME_CHARS]
    return target_name(fix.track_id)


def _name(fix: ShipFix, name: str | None, dark_prefix: str = DARK_PREFIX) -> str:
    return fix_name(fix, dark_prefix) if name is None else sanitise_name(name, fix.track_id)


def fmt_target_number(number: int, digits: int = 2) -> str:
    """Target number zero-padded to `digits` (2: 01-99, 3 only by configuration)."""
    if not 0 <= number < 10**digits:
        raise NmeaError(f"target number {number} does not fit {digits} digits")
    return f"{number:0{digits}d}"


def ttm(fix: ShipFix, number: int, *, talker: str = "RA", digits: int = 2, name: str | None = None,
        dark_prefix: str = DARK_PREFIX) -> str:
    """TTM (tracked target message), polar from the site; CPA and TCPA empty."""
    live = fix.status is not TrackStatus.LOST
    fields = [
        fmt_target_number(number, digits),
        fmt_distance_nm(fix.range_m, live),
        fmt_angle(fix.bearing_deg),
        "T",
        fmt_number(fix.sog_kn, 1),
        fmt_angle(fix.cog_deg),
        "T",
        "",  # distance of CPA: meaningless for a fixed station
        "",  # time to CPA
        "N",
        _name(fix, name, dark_prefix),
        fix.status.value,
        "",  # reference target: never
        fmt_utc(fix.t_ns),
        "A",  # automatic acquisition
    ]
    return _fitted(check_talker(talker) + "TTM", fields, 10)


def tll(fix: ShipFix, number: int, *, talker: str = "RA", digits: int = 2, name: str | None = None,
        dark_prefix: str = DARK_PREFIX) -> str:
    """TLL (target latitude and longitude)."""
    lat, lat_hemisphere = fmt_lat(fix.lat_deg)
    lon, lon_hemisphere = fmt_lon(fix.lon_deg)
    fields = [
        fmt_target_number(number, digits),
        lat,
        lat_hemisphere,
        lon,
        lon_hemisphere,
        _name(fix, name, dark_prefix),
        fmt_utc(fix.t_ns),
        fix.status.value,
        "",  # reference target
    ]
    return _fitted(check_talker(talker) + "TLL", fields, 5)


def east_north_m(fix: ShipFix) -> tuple[float, float]:
    """Local (x east, y north) metres of the target from the site, from range and true bearing."""
    bearing_rad = math.radians(fix.bearing_deg)
    return fix.range_m * math.sin(bearing_rad), fix.range_m * math.cos(bearing_rad)


def txy(
    fix: ShipFix, number: int, *, manufacturer: str = "XXX", digits: int = 2, name: str | None = None,
    dark_prefix: str = DARK_PREFIX,
) -> str:
    """Proprietary ``$P<mfr>TXY``: x east, y north (m), vx, vy (m/s), 1-sigma (m), name, UTC, status.

    `manufacturer` must be an NMEA-assigned code before this ships (docs/nmea.md);
    ``XXX`` is the documented placeholder.
    """
    x_m, y_m = east_north_m(fix)
    vx_mps: float | None
    vy_mps: float | None
    if _known(fix.sog_kn) and _known(fix.cog_deg):
        course_rad = math.radians(fix.cog_deg)
        vx_mps = fix.sog_kn * MPS_PER_KNOT * math.sin(course_rad)
        vy_mps = fix.sog_kn * MPS_PER_KNOT * math.cos(course_rad)
    else:
        vx_mps = vy_mps = None
    fields = [
        fmt_target_number(number, digits),
        fmt_number(x_m, 1),
        fmt_number(y_m, 1),
        fmt_number(vx_mps, 2),
        fmt_number(vy_mps, 2),
        fmt_number(fix.sigma_m, 1),
        _name(fix, name, dark_prefix),
        fmt_utc(fix.t_ns),
        fix.status.value,
    ]
    return _fitted("P" + check_manufacturer(manufacturer) + "TXY", fields, 6)


def track_sentences(
    fix: ShipFix,
    number: int,
    kinds: Iterable[str] = ("TTM", "TLL"),
    *,
    talker: str = "RA",
    manufacturer: str = "XXX",
    digits: int = 2,
    dark_prefix: str = DARK_PREFIX,
) -> list[str]:
    """The sentences of one track update, in the order TTM, TLL, TXY (those in `kinds`)."""
    wanted = set(kinds)
    unknown = wanted - set(KINDS)
    if unknown:
        raise NmeaError(f"unknown sentence kinds {sorted(unknown)}; choose from {KINDS}")
    out = []
    if "TTM" in wanted:
        out.append(ttm(fix, number, talker=talker, digits=digits, dark_prefix=dark_prefix))
    if "TLL" in wanted:
        out.append(tll(fix, number, talker=talker, digits=digits, dark_prefix=dark_prefix))
    if "TXY" in wanted:
        out.append(txy(fix, number, manufacturer=manufacturer, digits=digits, dark_prefix=dark_prefix))
    return out


def tag_block(source: str, line_count: int) -> str:
    """IEC 61162-450 tag block ``\\s:RA0001,n:17*hh\\`` (checksum over the text between the backslashes)."""
    if not _SOURCE.fullmatch(source):
        raise NmeaError(f"IEC 61162-450 source must be talker + 4 digits (e.g. RA0001), got {source!r}")
    if not 1 <= line_count <= 999:
        raise NmeaError(f"IEC 61162-450 line count must be 1..999, got {line_count}")
    body = f"s:{source},n:{line_count}"
    block = f"\\{body}*{checksum(body)}\\"
    if len(block) > MAX_TAG_BLOCK_CHARS:
        raise NmeaError(f"tag block longer than {MAX_TAG_BLOCK_CHARS} characters: {block!r}")
    return block


def udpbc_datagram(line: str, source: str, line_count: int) -> bytes:
    """One IEC 61162-450 datagram: ``UdPbC\\0`` + tag block + sentence (with its CR LF)."""
    if not (line.startswith("$") and line.endswith("\r\n")):
        raise NmeaError(f"not a framed sentence: {line!r}")
    return UDPBC + (tag_block(source, line_count) + line).encode("ascii")


def next_line_count(line_count: int) -> int:
    """The IEC 61162-450 ``n:`` counter after `line_count`: 1..999, then 1 again."""
    return line_count % 999 + 1
