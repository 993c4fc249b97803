"""edge.encode.nmea: known answers from research/nmea-modbus.md, framing rules, and two independent parsers.

The property test is the acceptance test of docs/nmea.md: for any fix within
10 km of any site away from the poles, every sentence parses with pynmea2
(checksum checked) and pynmeagps (checksum and message id validated) to the
fix's values within the printed precision, is at most 82 characters, and
passes OpenCPN's rules (re-implemented from OpenCPN model/src/ais_decoder.cpp:
valid checksum, at most 128 characters, distance not 0 for a live target).
"""

from __future__ import annotations

import datetime as dt
import math

import pynmea2
import pynmeagps
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pynmeagps import VALCKSUM, VALMSGID, NMEAReader
from pynmeagps.nmeatypes_core import CH, DE, IN, ST, TM

from edge.encode import nmea
from edge.fix import ShipFix, TrackStatus

T_EXAMPLE_NS = int(dt.datetime(2026, 5, 1, 12, 35, 19, 500000, tzinfo=dt.UTC).timestamp()) * 10**9
TXY_USERDEFINED = {
    "XXXTXY": {"targetnum": IN, "x": DE, "y": DE, "vx": DE, "vy": DE, "sigma": DE, "name": ST, "time": TM,
               "status": CH},
}  # fmt: skip


def make_fix(**kw: object) -> ShipFix:
    """The worked example of research/nmea-modbus.md §3 (track 4711, 0.854 NM at 123.4°)."""
    base = dict(
        t_ns=T_EXAMPLE_NS + 500_000_000, track_id=4711, status=TrackStatus.TRACKING, x_m=0.0, y_m=0.0,
        z_m=0.0, range_m=0.854 * 1852, bearing_deg=123.4, lat_deg=53 + 32.0305 / 60,
        lon_deg=9 + 59.1948 / 60, sog_kn=8.6, cog_deg=271.3, sigma_m=3.5, disparity_px=1.0,
    )  # fmt: skip
    base.update(kw)
    return ShipFix(**base)  # type: ignore[arg-type]


# -- known answers -------------------------------------------------------------------------


def test_worked_examples_match_research_note_byte_for_byte() -> None:
    fix = make_fix()
    assert nmea.ttm(fix, 7) == "$RATTM,07,0.854,123.4,T,8.6,271.3,T,,,N,TRK4711,T,,123519.50,A*42\r\n"
    assert nmea.tll(fix, 7) == "$RATLL,07,5332.0305,N,00959.1948,E,TRK4711,123519.50,T,*6B\r\n"
    assert nmea.txy(fix, 7) == "$PXXXTXY,07,1320.4,-870.6,-4.42,0.10,3.5,TRK4711,123519.50,T*5C\r\n"
    lost = make_fix(t_ns=T_EXAMPLE_NS + 22 * 10**9, status=TrackStatus.LOST, range_m=0.861 * 1852,
                    bearing_deg=122.9, sog_kn=8.4, cog_deg=270.8)  # fmt: skip
    assert nmea.ttm(lost, 7) == "$RATTM,07,0.861,122.9,T,8.4,270.8,T,,,N,TRK4711,L,,123541.00,A*50\r\n"
    assert nmea.tll(lost, 7) == "$RATLL,07,5332.0305,N,00959.1948,E,TRK4711,123541.00,L,*7B\r\n"


def test_acquiring_without_velocity_leaves_speed_and_course_empty() -> None:
    fix = make_fix(track_id=4715, status=TrackStatus.ACQUIRING, range_m=1.732 * 1852, bearing_deg=45.0,
                   sog_kn=None, cog_deg=None)  # fmt: skip
    line = nmea.ttm(fix, 12)
    # docs/nmea.md: bearing "%.1f", so "45.0" (the research note's example pads it to "045.0").
    assert line.startswith("$RATTM,12,1.732,45.0,T,,,T,,,N,TRK4715,Q,,123519.50,A*")
    assert pynmea2.parse(line, check=True).speed is None


def test_checksum_and_tag_block_known_answers() -> None:
    assert nmea.checksum("RATTM,07,0.854,123.4,T,8.6,271.3,T,,,N,TRK4711,T,,123519.50,A") == "42"
    assert nmea.tag_block("RA0001", 17) == "\\s:RA0001,n:17*25\\"
    datagram = nmea.udpbc_datagram(nmea.ttm(make_fix(), 7), "RA0001", 17)
    assert datagram == (b"UdPbC\x00\\s:RA0001,n:17*25\\$RATTM,07,0.854,123.4,T,8.6,271.3,T,,,N,TRK4711,T,,"
                        b"123519.50,A*42\r\n")  # fmt: skip
    assert [nmea.next_line_count(n) for n in (1, 998, 999)] == [2, 999, 1]
    for source, count in (("RA001", 1), ("ra0001", 1), ("RA0001", 0), ("RA0001", 1000)):
        with pytest.raises(nmea.NmeaError):
            nmea.tag_block(source, count)


# -- field formats -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("deg", "text"),
    [(359.96, "0.0"), (359.99, "0.0"), (359.94, "359.9"), (360.0, "0.0"), (-0.04, "0.0"), (-0.06, "359.9"),
     (0.0, "0.0"), (123.46, "123.5"), (None, ""), (math.nan, "")],
)  # fmt: skip
def test_angles_wrap_never_360(deg: float | None, text: str) -> None:
    assert nmea.fmt_angle(deg) == text


@given(st.floats(-1e4, 1e4))
def test_angles_stay_in_range_and_close(deg: float) -> None:
    value = float(nmea.fmt_angle(deg))
    assert 0.0 <= value < 360.0
    diff = abs((value - deg + 180.0) % 360.0 - 180.0)
    assert diff <= 0.05 + 1e-9


def test_minutes_that_round_to_60_carry_into_degrees() -> None:
    assert nmea.fmt_lat(53 + 59.99996 / 60) == ("5400.0000", "N")
    assert nmea.fmt_lat(-(53 + 59.99996 / 60)) == ("5400.0000", "S")
    assert nmea.fmt_lon(9 + 59.99995 / 60) == ("01000.0000", "E")
    assert nmea.fmt_lon(-(179 + 59.99999 / 60)) == ("18000.0000", "W")
    assert nmea.fmt_lat(-1e-9) == ("0000.0000", "N")  # no "S" for a value that prints as zero
    assert nmea.fmt_lat(None) == ("", "") and nmea.fmt_lon(math.inf) == ("", "")


@given(st.floats(-89.9, 89.9), st.floats(-180.0, 180.0))
def test_lat_lon_round_trip_within_half_a_printed_step(lat: float, lon: float) -> None:
    for value, (text, hemisphere), deg_digits in ((lat, nmea.fmt_lat(lat), 2), (lon, nmea.fmt_lon(lon), 3)):
        degrees, minutes = int(text[:deg_digits]), float(text[deg_digits:])
        assert minutes < 60.0 and len(text) == deg_digits + 7
        sign = -1 if hemisphere in "SW" else 1
        assert abs(sign * (degrees + minutes / 60) - value) <= 0.5e-4 / 60 + 1e-12


def test_utc_is_the_measurement_time_truncated_to_hundredths() -> None:
    assert nmea.fmt_utc(T_EXAMPLE_NS + 500_000_000) == "123519.50"
    last = int(dt.datetime(2026, 5, 1, 23, 59, 59, tzinfo=dt.UTC).timestamp()) * 10**9 + 999_999_999
    assert nmea.fmt_utc(last) == "235959.99"
    assert nmea.fmt_utc(last + 1) == "000000.00"


def test_unknown_values_are_empty_never_zero() -> None:
    line = nmea.ttm(make_fix(sog_kn=None, cog_deg=math.nan, range_m=math.nan, bearing_deg=math.inf), 7)
    assert line.startswith("$RATTM,07,,,T,,,T,,,N,TRK4711,T,,123519.50,A*")
    assert nmea.tll(make_fix(lat_deg=math.nan, lon_deg=None), 7).startswith("$RATLL,07,,,,,TRK4711,")
    assert nmea.txy(make_fix(sog_kn=None), 7).startswith("$PXXXTXY,07,1320.4,-870.6,,,3.5,")
    assert nmea.fmt_number(-0.0001, 2) == "0.00"


def test_live_target_distance_is_never_zero_but_lost_may_be() -> None:
    assert nmea.fmt_distance_nm(0.5, live=True) == "0.001"
    assert nmea.fmt_distance_nm(0.5, live=False) == "0.000"
    assert nmea.ttm(make_fix(range_m=0.9), 1).split(",")[2] == "0.001"
    assert nmea.ttm(make_fix(range_m=0.9, status=TrackStatus.LOST), 1).split(",")[2] == "0.000"


def test_target_names_fit_eight_characters() -> None:
    assert [nmea.target_name(i) for i in (0, 4711, 99999, 123456, 1234567, 12345678, 123456789)] == [
        "TRK0", "TRK4711", "TRK99999", "TR123456", "T1234567", "12345678", "23456789"]  # fmt: skip


def test_target_numbers_are_padded_and_bounded() -> None:
    assert nmea.fmt_target_number(7) == "07" and nmea.fmt_target_number(7, 3) == "007"
    for number, digits in ((100, 2), (-1, 2), (1000, 3)):
        with pytest.raises(nmea.NmeaError):
            nmea.fmt_target_number(number, digits)


# -- framing rules -------------------------------------------------------------------------


@pytest.mark.parametrize("bad", ["$", "*", ",", "!", "\\", "^", "~", "\r", "\n", "\t", "é"])
def test_reserved_characters_in_fields_are_refused_and_removed_from_names(bad: str) -> None:
    with pytest.raises(nmea.NmeaError, match="reserved"):
        nmea.sentence("RATTM", ["07", f"A{bad}B"])
    assert ",AB," in nmea.ttm(make_fix(), 7, name=f"A{bad}B")  # a name from outside is sanitised


def test_82_character_limit_is_enforced() -> None:
    fixed = len("$RATLL,") + len("*hh\r\n")
    assert len(nmea.sentence("RATLL", ["X" * (82 - fixed)])) == 82
    with pytest.raises(nmea.NmeaError, match="82"):
        nmea.sentence("RATLL", ["X" * (83 - fixed)])
    with pytest.raises(nmea.NmeaError, match="82"):
        nmea.ttm(make_fix(range_m=1e30, sog_kn=1e30), 7)


def test_addresses_talkers_and_manufacturers_are_checked() -> None:
    for talker in ("RA", "II", "U0"):
        assert nmea.ttm(make_fix(), 7, talker=talker).startswith(f"${talker}TTM,")
    for talker in ("P1", "R", "RAA", "ra", "R,"):
        with pytest.raises(nmea.NmeaError):
            nmea.ttm(make_fix(), 7, talker=talker)
    for code in ("XX", "xxx", "XX,", "XXXX"):
        with pytest.raises(nmea.NmeaError):
            nmea.txy(make_fix(), 7, manufacturer=code)
    with pytest.raises(nmea.NmeaError):
        nmea.track_sentences(make_fix(), 7, ("TTM", "VDM"))


def test_independent_parsers_reject_a_corrupted_checksum() -> None:
    line = nmea.ttm(make_fix(), 7).replace("*42", "*43")
    with pytest.raises(pynmea2.ChecksumError):
        pynmea2.parse(line, check=True)
    with pytest.raises(pynmeagps.NMEAParseError):
        NMEAReader.parse(line.encode(), validate=VALCKSUM)
    assert not opencpn_accepts(line)


# -- acceptance: any fix within 10 km, three parsers ----------------------------------------


def opencpn_accepts(line: str) -> bool:
    """OpenCPN's NMEA gate (ais_decoder.cpp NMEACheckSumOK + length check), re-implemented."""
    if len(line) > 128 or not line.startswith("$") or "*" not in line:
        return False
    body, _, tail = line[1:].partition("*")
    value = 0
    for char in body.encode():
        value ^= char
    return tail[:2].upper() == f"{value:02X}"


@st.composite
def fixes(draw: st.DrawFn) -> ShipFix:
    site_lat = draw(st.floats(-80.0, 80.0))
    site_lon = draw(st.floats(-180.0, 180.0))
    range_m = draw(st.floats(0.0, 10_000.0))
    bearing = draw(st.floats(0.0, 360.0, exclude_max=True))
    # spherical destination: any plausible position near the site will do for formatting
    lat = site_lat + math.degrees(range_m * math.cos(math.radians(bearing)) / 6_371_000)
    lon = site_lon + math.degrees(range_m * math.sin(math.radians(bearing)) / 6_371_000) / math.cos(
        math.radians(lat))  # fmt: skip
    return ShipFix(
        t_ns=draw(st.integers(0, 4 * 10**18)), track_id=draw(st.integers(0, 10**9)),
        status=draw(st.sampled_from(list(TrackStatus))), x_m=0.0, y_m=0.0, z_m=range_m, range_m=range_m,
        bearing_deg=bearing, lat_deg=lat, lon_deg=(lon + 180.0) % 360.0 - 180.0,
        sog_kn=draw(st.none() | st.floats(0.0, 60.0)), cog_deg=draw(st.none() | st.floats(0.0, 360.0)),
        sigma_m=draw(st.floats(0.0, 999.0)), disparity_px=1.0,
    )  # fmt: skip


def close_angle(text_value: float, deg: float) -> bool:
    return abs((text_value - deg + 180.0) % 360.0 - 180.0) <= 0.05 + 1e-9


def expected_time(t_ns: int) -> dt.time:
    centis = t_ns // 10**7 % 8_640_000
    s = centis // 100
    return dt.time(s // 3600, s // 60 % 60, s % 60, centis % 100 * 10_000)


def check_ttm(line: str, fix: ShipFix, number: int) -> None:
    msg, gps = pynmea2.parse(line, check=True), NMEAReader.parse(line.encode(), validate=VALCKSUM | VALMSGID)
    live = fix.status is not TrackStatus.LOST
    nm = fix.range_m / 1852
    expected_nm = 0.001 if live and nm < 0.0005 else nm
    for distance in (float(msg.distance), gps.targetdist):
        assert abs(distance - expected_nm) <= 0.0005 + 1e-12
        assert distance > 0 or not live  # OpenCPN: 0 means lost
    assert msg.target_number == gps.targetnum == number
    assert close_angle(float(msg.bearing), fix.bearing_deg) and close_angle(
        gps.targetbearing, fix.bearing_deg
    )
    assert msg.brg_ref == msg.cog_unit == "T" and msg.dist_unit == "N" and msg.acquisition == "A"
    if fix.sog_kn is None:
        assert msg.speed is None and gps.targetspeed == ""
    else:
        assert (
            abs(float(msg.speed) - fix.sog_kn) <= 0.05 + 1e-9
            and abs(gps.targetspeed - fix.sog_kn) <= 0.05 + 1e-9
        )
    if fix.cog_deg is None:
        assert msg.cog is None and gps.targetcourse == ""
    else:
        assert close_angle(float(msg.cog), fix.cog_deg) and close_angle(gps.targetcourse, fix.cog_deg)
    assert msg.dist_cpa is None and msg.time_cpa is None and msg.reference == ""
    assert msg.name == gps.targetname == nmea.target_name(fix.track_id)
    assert msg.status == gps.targetstatus == fix.status.value
    assert msg.timestamp.replace(tzinfo=None) == gps.time == expected_time(fix.t_ns)


def check_tll(line: str, fix: ShipFix, number: int) -> None:
    msg, gps = pynmea2.parse(line, check=True), NMEAReader.parse(line.encode(), validate=VALCKSUM | VALMSGID)
    step = 0.5e-4 / 60 + 1e-9
    assert abs(msg.latitude - fix.lat_deg) <= step and abs(msg.longitude - fix.lon_deg) <= step
    assert abs((-1 if gps.targetlatNS == "S" else 1) * gps.targetlat - fix.lat_deg) <= step
    assert abs((-1 if gps.targetlonEW == "W" else 1) * gps.targetlon - fix.lon_deg) <= step
    assert msg.target_number == gps.targetnum == number
    assert msg.target_status == gps.status == fix.status.value and msg.reference == ""
    assert msg.target_name == gps.targetname == nmea.target_name(fix.track_id)
    assert msg.timestamp.replace(tzinfo=None) == gps.time == expected_time(fix.t_ns)


def check_txy(line: str, fix: ShipFix, number: int) -> None:
    msg = pynmea2.parse(line, check=True)
    assert isinstance(msg, pynmea2.ProprietarySentence) and msg.manufacturer == "XXX"
    gps = NMEAReader.parse(line.encode(), validate=VALCKSUM | VALMSGID, userdefined=TXY_USERDEFINED)
    east, north = nmea.east_north_m(fix)
    assert gps.targetnum == number and abs(gps.x - east) <= 0.05 + 1e-6 and abs(gps.y - north) <= 0.05 + 1e-6
    assert abs(gps.sigma - fix.sigma_m) <= 0.05 + 1e-9 and gps.status == fix.status.value
    if fix.sog_kn is None or fix.cog_deg is None:
        assert gps.vx == gps.vy == ""
    else:
        assert math.hypot(gps.vx, gps.vy) == pytest.approx(fix.sog_kn * nmea.MPS_PER_KNOT, abs=0.01)
    assert gps.time == expected_time(fix.t_ns)


@settings(max_examples=300, deadline=None)
@given(fixes(), st.integers(1, 99))
def test_every_sentence_parses_with_pynmea2_and_pynmeagps_and_obeys_opencpn(
    fix: ShipFix, number: int
) -> None:
    lines = nmea.track_sentences(fix, number, nmea.KINDS)
    for line, check in zip(lines, (check_ttm, check_tll, check_txy), strict=True):
        assert len(line) <= nmea.MAX_SENTENCE_CHARS and line.endswith("\r\n")
        assert all(" " <= c <= "~" for c in line[:-2])
        assert opencpn_accepts(line)
        fields = line[1:].split("*")[0].split(",")
        assert len(fields) == {"TTM": 16, "TLL": 10}.get(fields[0][2:], 10)  # trailing empties kept
        check(line, fix, number)


HOSTILE_NAMES = st.text(max_size=40) | st.sampled_from(
    ["$GPGGA,1*00\r\n", "A,B", "X*7F", "\\s:x*00\\", "~^!", "\x00\x1b[2J", " ", "ÄGIR 1", "A VERY LONG SHIP"])


@settings(max_examples=60, deadline=None)
@given(fixes(), st.integers(1, 99), HOSTILE_NAMES)
def test_any_target_name_from_outside_gives_valid_sentences_within_82_chars(
    fix: ShipFix, number: int, name: str
) -> None:
    safe = nmea.sanitise_name(name, fix.track_id)
    assert 1 <= len(safe) <= nmea.NAME_CHARS and safe == safe.strip()
    assert all(" " <= c <= "~" and c not in "$!*,\\^~" for c in safe)
    for line in (nmea.ttm(fix, number, name=name), nmea.tll(fix, number, name=name),
                 nmea.txy(fix, number, name=name)):
        assert len(line) <= nmea.MAX_SENTENCE_CHARS and line.count("$") == 1 and line.endswith("\r\n")
        assert line.count("\r") == line.count("\n") == 1 and opencpn_accepts(line)
    assert pynmea2.parse(nmea.ttm(fix, number, name=name), check=True).name == safe
    assert pynmea2.parse(nmea.tll(fix, number, name=name), check=True).target_name == safe


# -- AIS names (issue 17) ------------------------------------------------------------------------


@given(name=st.text(min_size=0, max_size=40))
@settings(max_examples=60, deadline=None)
def test_ais_names_are_safe_and_within_82_characters(name: str) -> None:
    fx = make_fix(ais_mmsi=431000123, ais_name=name, sog_kn=123.4, cog_deg=359.9, range_m=99_999.0)
    kept = " ".join("".join(c for c in name if " " <= c <= "~" and c not in "$*,!\\^~").split())[:20].strip()
    for line in nmea.track_sentences(fx, 99, ("TTM", "TLL", "TXY")):
        assert len(line) <= nmea.MAX_SENTENCE_CHARS
        msg = pynmea2.parse(line.strip())  # an independent parser reads it back
        kind = line[3:6]
        got = msg.data[10] if kind == "TTM" else msg.data[5] if kind == "TLL" else None
        if got is not None:  # the name, cut (not below 8 characters) only where the line would pass 82
            expected = kept or "431000123"
            assert expected.startswith(got) and (got == expected or len(got) >= nmea.NAME_CHARS)


def test_mmsi_dark_and_prefix_names() -> None:
    ttm_line = nmea.track_sentences(make_fix(ais_mmsi=431000123), 7, ("TTM",))[0]
    assert pynmea2.parse(ttm_line.strip()).data[10] == "431000123"
    named = nmea.track_sentences(make_fix(ais_mmsi=431000123, ais_name="AKASHI MARU 3"), 7, ("TLL",))[0]
    assert pynmea2.parse(named.strip()).data[5] == "AKASHI MARU 3"
    dark = nmea.track_sentences(make_fix(dark=True), 7, ("TTM",))[0]
    assert pynmea2.parse(dark.strip()).data[10] == "DARK4711"
    other = nmea.track_sentences(make_fix(dark=True), 7, ("TTM",), dark_prefix="NOAIS")[0]
    assert pynmea2.parse(other.strip()).data[10] == "NOAIS4711"
    plain = nmea.track_sentences(make_fix(dark=True), 7, ("TTM",), dark_prefix="")[0]
    assert pynmea2.parse(plain.strip()).data[10] == "TRK4711"
