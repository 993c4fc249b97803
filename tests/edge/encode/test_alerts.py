"""Alert sentences (edge.encode.alerts) parsed by independent parsers: pynmeagps for every kind,
checksums valid and 82 characters at most. pynmea2 1.19 knows none of ALF/ALC/HBT/ALR/ACN (the
research note's "ALR, HBT" was wrong): it checks the frame and checksum first, then refuses the
type, so `_pynmea2_frame` asserts exactly that (a bad checksum would raise ChecksumError)."""

from __future__ import annotations

import pynmea2
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pynmeagps import NMEAReader

from edge.encode.alerts import alc, alf, alr, hbt, parse_acn
from edge.encode.nmea import checksum

UTC_NS = 1_700_000_000_123_456_789  # 22:13:20.12 UTC


def _gps(line: str):  # noqa: ANN202 - pynmeagps message
    assert line.endswith("\r\n") and len(line) <= 82
    _pynmea2_frame(line)
    return NMEAReader.parse(line.encode("ascii"), validate=1)  # validate=1: checksum checked


def _pynmea2_frame(line: str) -> None:
    with pytest.raises(pynmea2.SentenceTypeError):  # framing and checksum accepted, type unknown
        pynmea2.parse(line.strip(), check=True)
    with pytest.raises(pynmea2.ChecksumError):  # and it does check: one flipped checksum digit
        star = line.index("*")
        wrong = "0" if line[star + 1] != "0" else "1"
        pynmea2.parse(line[: star + 1] + wrong + line[star + 2 :].strip(), check=True)


def test_alf_parses_with_pynmeagps() -> None:
    line = alf("RA", 3, UTC_NS, "A", "A", "V", "", 191, 305, 1, "CPA 03 05 150M 4.0MIN")
    msg = _gps(line)
    assert msg.msgID == "ALF"
    assert (msg.numSen, msg.senNum, msg.seqmid) == (1, 1, 3)
    assert (msg.alertcat, msg.alertpriority, msg.alertstate) == ("A", "A", "V")
    assert tuple(int(v) for v in (msg.alertid, msg.alertinst, msg.revisionctr, msg.escalationctr)) == (
        191,
        305,
        1,
        0,
    )
    assert msg.alerttxt == "CPA 03 05 150M 4.0MIN"
    assert line.startswith("$RAALF,1,1,3,221320.12,A,A,V,,191,305,1,0,CPA")


def test_alf_cuts_long_text_to_82_characters() -> None:
    line = alf("RA", 9, UTC_NS, "B", "W", "N", "XXX", 10002, 999999, 99, "X" * 100, escalation=9)
    assert len(line) == 82
    assert int(_gps(line).alertid) == 10002


def test_alc_entries_fit_and_are_never_split() -> None:
    entries = [("", 191, 100 * k + k + 1, k % 99 + 1) for k in range(1, 12)]
    lines = alc("RA", 7, entries)
    assert len(lines) > 1
    got = []
    for k, line in enumerate(lines, start=1):
        msg = _gps(line)
        assert (msg.numSen, msg.senNum, msg.seqmid) == (len(lines), k, 7)
        fields = line[1 : line.index("*")].split(",")
        n = int(fields[4])
        assert len(fields) == 5 + 4 * n and msg.numAlerts == n  # whole entries only
        assert [int(getattr(msg, f"alertinst_{i + 1:02d}")) for i in range(n)] == [
            int(fields[7 + 4 * i]) for i in range(n)
        ]
        got += [
            (fields[5 + 4 * i], int(fields[6 + 4 * i]), int(fields[7 + 4 * i]), int(fields[8 + 4 * i]))
            for i in range(n)
        ]
    assert got == entries


def test_hbt_parses_with_pynmeagps() -> None:
    line = hbt("RA", 60, False, 12)
    msg = _gps(line)
    assert msg.msgID == "HBT" and msg.status == "V" and msg.seqid == 2 and msg.repeatint == 60


def test_alr_parses_with_pynmeagps() -> None:
    msg = _gps(alr("RA", UTC_NS, 10001, True, False, "DARK TARGET 07"))
    assert (msg.msgID, int(msg.alarmnum), msg.alarmcond, msg.alarmstate, msg.alarmtext) == (
        "ALR",
        901,
        "A",
        "V",
        "DARK TARGET 07",
    )


@settings(max_examples=60, deadline=None)
@given(
    st.sampled_from([190, 191, 192, 193, 10001, 10002, 10003, 10004]),
    st.integers(1, 999999),
    st.integers(1, 99),
    st.sampled_from("VAN"),
    st.text(
        st.characters(min_codepoint=32, max_codepoint=126).filter(lambda c: c not in "$*,!\\^~"), max_size=60
    ),
)
def test_every_alf_and_alr_is_valid(
    alert_id: int, instance: int, revision: int, state: str, text: str
) -> None:
    line = alf(
        "RA",
        instance,
        UTC_NS,
        "B",
        "W",
        state,
        "XXX" if alert_id >= 10000 else "",
        alert_id,
        instance,
        revision,
        text,
    )
    msg = _gps(line)
    assert tuple(int(v) for v in (msg.alertid, msg.alertinst, msg.revisionctr)) == (
        alert_id,
        instance,
        revision,
    )
    legacy = alr("RA", UTC_NS, alert_id, state != "N", state == "A", text)
    assert _gps(legacy).msgID == "ALR"


def _acn(body: str) -> str:
    return f"${body}*{checksum(body)}\r\n"


def test_acn_parsed_and_everything_else_refused() -> None:
    assert parse_acn(_acn("IIACN,221320.00,,191,305,A,C")) == ("", 191, 305, "A")
    assert parse_acn(_acn("IIACN,221320.00,XXX,10002,1,Q,C")) == ("XXX", 10002, 1, "Q")
    good = _acn("IIACN,221320.00,,191,305,A,C")
    assert parse_acn(good.replace("*", "*0")) is None  # bad checksum
    assert parse_acn(_acn("IIACN,221320.00,,191,305,X,C")) is None  # unknown command
    assert parse_acn(_acn("GPGGA,1,2,3,4,5,6")) is None
    assert parse_acn("garbage") is None


@pytest.mark.parametrize("interval", [0, 1000])
def test_hbt_interval_bounds(interval: int) -> None:
    with pytest.raises(ValueError):
        hbt("RA", interval, True, 0)


def test_alc_keeps_to_99_sentences_most_urgent_first() -> None:
    entries = [("", 191, 100 * (k % 99) + 1, 1) for k in range(1000)]
    lines = alc("RA", 0, entries)
    assert len(lines) == 99 and all(len(line) <= 82 for line in lines)
    assert lines[0].split(",")[7] == "1"  # the first (most urgent) entry is kept
