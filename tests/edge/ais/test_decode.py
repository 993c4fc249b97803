"""AIS decoding: pyais's encoder as the independent peer (round trip of every used type),
multi-part assembly with interleaved and lost fragments, and 10 000 lines of garbage that are
all counted and never raise."""

from __future__ import annotations

import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyais import encode_dict

from edge.ais.decode import AisDecoder, PositionReport, StaticReport, sentence_text


def _one(lines: list[str], t_ns: int = 0) -> list:
    d = AisDecoder()
    out = []
    for line in lines:
        out += d.feed(line, t_ns)
    return out


@given(
    lat=st.floats(-89.9, 89.9),
    lon=st.floats(-179.9, 179.9),
    sog=st.floats(0.0, 60.0),
    cog=st.floats(0.0, 359.9),
    heading=st.integers(0, 359),
    accurate=st.booleans(),
    kind=st.sampled_from([1, 2, 3, 18]),
)
@settings(max_examples=30, deadline=None)
def test_position_round_trip(
    lat: float, lon: float, sog: float, cog: float, heading: int, accurate: bool, kind: int
) -> None:
    lines = encode_dict(
        {
            "type": kind,
            "mmsi": 431000123,
            "lat": lat,
            "lon": lon,
            "speed": sog,
            "course": cog,
            "heading": heading,
            "accuracy": int(accurate),
        },
        talker_id="AI",
        sentence_type="VDM",
    )
    (rep,) = _one(lines, 7)
    assert isinstance(rep, PositionReport)
    assert rep.mmsi == 431000123 and rep.t_ns == 7 and rep.accurate is accurate
    assert rep.ais_class == ("B" if kind == 18 else "A")
    assert abs(rep.lat_deg - lat) <= 1e-6 / 0.6 + 1e-9 and abs(rep.lon_deg - lon) <= 1e-6 / 0.6 + 1e-9
    assert (
        rep.sog_kn is not None and abs(rep.sog_kn - sog) <= 0.1 + 1e-9
    )  # 0.1 kn resolution (pyais truncates)
    assert rep.cog_deg is not None and abs(rep.cog_deg - cog) <= 0.1 + 1e-9
    assert rep.heading_deg == heading


def test_not_available_values() -> None:
    lines = encode_dict(
        {"type": 1, "mmsi": 1, "lat": 91.0, "lon": 181.0}, talker_id="AI", sentence_type="VDM"
    )
    d = AisDecoder()
    assert d.feed(lines[0], 0) == [] and d.counters.no_position == 1
    lines = encode_dict(
        {"type": 1, "mmsi": 1, "lat": 10.0, "lon": 20.0, "speed": 102.3, "course": 360.0, "heading": 511},
        talker_id="AI",
        sentence_type="VDM",
    )
    (rep,) = _one(lines)
    assert rep.sog_kn is None and rep.cog_deg is None and rep.heading_deg is None


def test_static_type5_two_parts_interleaved_with_positions() -> None:
    static = encode_dict(
        {
            "type": 5,
            "mmsi": 431000123,
            "shipname": "AKASHI MARU 3",
            "to_bow": 50,
            "to_stern": 20,
            "to_port": 6,
            "to_starboard": 5,
        },
        talker_id="AI",
        sentence_type="VDM",
        seq_id=3,
    )
    assert len(static) == 2
    pos = encode_dict({"type": 1, "mmsi": 7, "lat": 1.0, "lon": 2.0}, talker_id="AI", sentence_type="VDM")
    got = _one([static[0], pos[0], static[1]])
    assert isinstance(got[0], PositionReport) and got[0].mmsi == 7
    s = got[1]
    assert isinstance(s, StaticReport) and s.name == "AKASHI MARU 3"
    assert (s.to_bow_m, s.to_stern_m, s.to_port_m, s.to_starboard_m) == (50, 20, 6, 5)


def test_type24_parts_and_type19() -> None:
    a = encode_dict(
        {"type": 24, "mmsi": 9, "partno": 0, "shipname": "SEABIRD"}, talker_id="AI", sentence_type="VDM"
    )
    b = encode_dict(
        {"type": 24, "mmsi": 9, "partno": 1, "to_bow": 8, "to_stern": 8, "to_port": 2, "to_starboard": 2},
        talker_id="AI",
        sentence_type="VDM",
    )
    got = _one(a + b)
    assert [g.name for g in got] == ["SEABIRD", None] and got[1].to_bow_m == 8
    c = encode_dict(
        {
            "type": 19,
            "mmsi": 5,
            "lat": 3.0,
            "lon": 4.0,
            "shipname": "X",
            "to_bow": 1,
            "to_stern": 2,
            "to_port": 3,
            "to_starboard": 4,
        },
        talker_id="AI",
        sentence_type="VDM",
    )
    pos, stat = _one(c)
    assert pos.ais_class == "B" and stat.name == "X" and stat.to_starboard_m == 4


def test_lost_fragment_is_counted_and_the_next_message_decodes() -> None:
    first = encode_dict(
        {"type": 5, "mmsi": 1, "shipname": "A"}, talker_id="AI", sentence_type="VDM", seq_id=1
    )
    second = encode_dict(
        {"type": 5, "mmsi": 2, "shipname": "B"}, talker_id="AI", sentence_type="VDM", seq_id=1
    )
    d = AisDecoder()
    assert d.feed(first[0], 0) == []  # its part 2 never comes
    got = d.feed(second[0], 1) + d.feed(second[1], 2)
    assert [g.mmsi for g in got] == [2] and d.counters.incomplete == 1
    assert d.feed(first[0], 10) == [] and d.feed(first[1], int(5e9)) == []  # too late: expired
    assert d.counters.incomplete == 2


def test_checksum_and_framing() -> None:
    line = encode_dict({"type": 1, "mmsi": 1, "lat": 1.0, "lon": 1.0}, talker_id="AI", sentence_type="VDM")[0]
    bad = line[:-2] + ("00" if line[-2:] != "00" else "01")
    d = AisDecoder()
    assert d.feed(bad, 0) == [] and d.counters.checksum_errors == 1
    assert sentence_text("UdPbC\0\\s:AI0001*00\\" + line + "\r\n") == line  # IEC 61162-450 framing
    assert len(d.feed(b"UdPbC\x00\\s:AI0001*00\\" + line.encode(), 0)) == 1
    assert d.feed("$GPGGA,1,2,3*00", 0) == [] and d.counters.malformed == 1


def _garbage(rng: random.Random, good: list[str]) -> str | bytes:
    pick = rng.random()
    line = rng.choice(good)
    if pick < 0.25:
        return bytes(rng.getrandbits(8) for _ in range(rng.randint(0, 120)))
    if pick < 0.5:  # a truncated line
        return line[: rng.randint(0, len(line))]
    if pick < 0.7:  # one character changed: the checksum (or the framing) fails
        i = rng.randrange(len(line))
        return line[:i] + chr(rng.randint(32, 126)) + line[i + 1 :]
    if pick < 0.85:  # a lone fragment of a multi-part message
        return line.replace(",1,1,", ",2,1,1", 1)
    return line


@pytest.mark.parametrize("seed", [1, 2])
def test_ten_thousand_lines_of_garbage_are_counted(seed: int) -> None:
    rng = random.Random(seed)
    good = encode_dict({"type": 1, "mmsi": 3, "lat": 1.0, "lon": 1.0}, talker_id="AI", sentence_type="VDM")
    good += encode_dict(
        {"type": 5, "mmsi": 3, "shipname": "GARBAGE"}, talker_id="AI", sentence_type="VDM", seq_id=2
    )
    d = AisDecoder()
    for k in range(10_000):
        d.feed(_garbage(rng, good), k * 1_000_000)
    c = d.counters
    assert c.lines == 10_000
    outcomes = c.decoded + c.checksum_errors + c.malformed + c.unknown_type + c.unused + c.no_position
    assert c.checksum_errors > 500 and c.malformed > 1000 and c.decoded > 500
    assert outcomes <= c.lines  # every line ends in at most one outcome (fragments wait for their message)
