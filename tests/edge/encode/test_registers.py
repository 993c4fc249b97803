"""Register map: known answers, scaling/sentinels, slot allocation, the documented table in sync."""

from __future__ import annotations

import math
import re
import struct
import subprocess
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.appliance.health import HealthSnapshot, HealthState, Status
from edge.encode.register_table import render_markdown_table
from edge.encode.registers import (
    ALERT_SLOT_BASE,
    ALERT_STRIDE,
    BY_NAME,
    FIELDS,
    PROBE_VALUE,
    TRACK_BASE,
    TRACK_STRIDE,
    Identity,
    SlotAssignment,
    WordOrder,
    address_of,
    build_snapshot,
    decode,
    encode,
    read_field,
)
from edge.fix import ShipFix, TrackStatus

ROOT = Path(__file__).resolve().parents[3]
T0_NS = 1_790_000_000_123_456_789
HEALTH = HealthSnapshot(HealthState.OK, "", int(Status.OK | Status.TRACKER_RUNNING), 0, 29.97, 0.0456,
                        70000.7)
IDENT = Identity((1, 2, 3), max_tracks=4, site_lat_deg=53.5416667, site_lon_deg=9.9666667)


def fix(track_id: int, status: TrackStatus = TrackStatus.TRACKING, range_m: float = 1581.6,
        bearing_deg: float = 123.4, **kw) -> ShipFix:
    values = dict(t_ns=T0_NS - 2_300_000_000, track_id=track_id, status=status, x_m=0.0, y_m=0.0,
                  z_m=range_m, range_m=range_m, bearing_deg=bearing_deg, lat_deg=53.5338422,
                  lon_deg=9.9865804, sog_kn=8.6, cog_deg=271.3, sigma_m=3.5, disparity_px=4.0,
                  confidence=0.87, length_m=42.4)
    values.update(kw)
    return ShipFix(**values)


def build(fixes, identity=IDENT, previous=None, **kw):
    previous = previous or SlotAssignment.empty(identity.max_tracks)
    return build_snapshot(fixes, HEALTH, identity, previous, utc_ns=T0_NS, **kw)


def words(regs, at: int, n: int = 1) -> tuple[int, ...]:
    return tuple(regs[at:at + n])


@pytest.mark.parametrize("order, probe", [(WordOrder.HIGH_FIRST, (0x1234, 0x5678)),
                                          (WordOrder.LOW_FIRST, (0x5678, 0x1234))])
def test_identity_block_and_probe(order: WordOrder, probe: tuple[int, int]) -> None:
    ident = Identity((1, 2, 3), max_tracks=4, word_order=order)
    regs = build([], ident).registers
    assert words(regs, 0, 11) == (2, 1, 2, 3, *probe, 4, 100, 20, int(order), 180)
    assert read_field(regs, "PROBE", word_order=order) == PROBE_VALUE
    assert words(regs, 11, 5) == (0,) * 5  # reserved
    assert read_field(regs, "MMSI_BASE") == 100 + 20 * 4  # map version 2: the MMSI block follows the slots


def test_worked_example_slot_matches_the_research_note() -> None:
    # research/nmea-modbus.md §6: LAT 535338422 = 0x1FE8 0x9DB6, LON 99865804 = 0x05F3 0xD4CC,
    # SOG 860, COG 27130, RANGE 1582, BRG 12340; x/y from the TXY example (1320.4, -870.6).
    snap = build([fix(4711)], target_numbers={4711: 7})
    s = snap.registers[TRACK_BASE:TRACK_BASE + TRACK_STRIDE]
    assert s[0:4] == (2, 7, 0, 4711)
    assert s[4:8] == (0x1FE8, 0x9DB6, 0x05F3, 0xD4CC)
    assert s[8:12] == (860, 27130, 1582, 12340)
    assert s[12:14] == (1320, 0x10000 - 871)
    assert s[14:20] == (23, 35, 87, 0, 42, 1)
    assert snap.assignment.track_ids == (4711, None, None, None) and snap.unslotted == ()


def test_health_block() -> None:
    regs = build([fix(1), fix(2, TrackStatus.ACQUIRING), fix(3, TrackStatus.LOST)]).registers
    assert regs[16] == 70000 % 65536  # heartbeat: whole seconds of uptime, wrapped
    assert words(regs, 17, 5) == (int(Status.OK | Status.TRACKER_RUNNING), 0, 2, 300, 46)
    assert words(regs, 22, 2) == (70000 >> 16, 70000 & 0xFFFF)
    assert (regs[24] << 16 | regs[25], regs[26], regs[27]) == (1_790_000_000, 123, 1)
    assert words(regs, 28, 2) == (0, 0)
    lat, lon = struct.unpack(">ii", struct.pack(">8H", *words(regs, 30, 4), 0, 0, 0, 0)[:8])
    assert (lat, lon) == (535416667, 99666667)


def test_not_available_values_and_empty_slots() -> None:
    health = HealthSnapshot(HealthState.STALLED, "x", int(Status.FAULT), 31, None, None, 1.0)
    ident = Identity((0, 1, 0), max_tracks=2)
    snap = build_snapshot([fix(9, sog_kn=None, cog_deg=None, confidence=None, length_m=None)], health,
                          ident, SlotAssignment.empty(2), utc_ns=T0_NS)
    regs = snap.registers
    assert words(regs, 20, 2) == (0xFFFF, 0xFFFF)
    assert words(regs, 30, 4) == (0x7FFF, 0xFFFF, 0x7FFF, 0xFFFF)
    slot0 = regs[100:120]
    assert (slot0[1], slot0[8], slot0[9], slot0[16], slot0[18]) == (0xFFFF,) * 5
    empty = regs[120:140]
    assert empty[0] == 0 and empty[19] == 1
    assert empty[1:19] == (0xFFFF, 0xFFFF, 0xFFFF, 0x7FFF, 0xFFFF, 0x7FFF, 0xFFFF, 0xFFFF, 0xFFFF,
                           0xFFFF, 0xFFFF, 0x8000, 0x8000, 0xFFFF, 0xFFFF, 0xFFFF, 0, 0xFFFF)
    assert read_field(regs, "LAT", slot=1) is None


def test_angles_wrap_and_values_saturate_short_of_the_sentinel() -> None:
    regs = build([fix(1, bearing_deg=359.996, cog_deg=359.994, range_m=1e5, sigma_m=1e4,
                      lat_deg=-33.9, sog_kn=-1.0)]).registers
    s = regs[100:120]
    assert (s[11], s[9]) == (0, 35999)
    assert (s[10], s[15], s[8]) == (65534, 65534, 0)
    assert s[4:6] == struct.unpack(">2H", struct.pack(">i", -339000000))
    far = build([fix(1, range_m=1e5, bearing_deg=123.4)]).registers  # x = +83.5 km, y = -55.0 km
    assert far[112:114] == (0x7FFF, 0x8001)  # +-32767 m: saturated, never the sentinel 0x8000


_SCALED = [f for f in FIELDS if f.na is not None and f.scale != 1 or f.name in ("RANGE", "X_EAST")]


@settings(max_examples=60, deadline=None)
@given(data=st.data(), order=st.sampled_from(list(WordOrder)))
def test_encode_decode_round_trip_within_half_a_step(data, order: WordOrder) -> None:
    f = data.draw(st.sampled_from(_SCALED))
    bits = 16 * f.words
    signed = f.type.startswith("i")
    lo = -(1 << (bits - 1)) + 1 if signed else 0
    hi = (1 << (bits - 1)) - 2 if signed else (1 << bits) - 2
    if f.wrap_at:
        hi = f.wrap_at - 1
    value = data.draw(st.floats(lo * f.scale, hi * f.scale))
    ws = encode(f, value, order)
    back = decode(f, ws, order)
    step = f.scale
    err = abs(back - value)
    if f.wrap_at:
        err = min(err, f.wrap_at * step - err)
    assert err <= step / 2 + 4 * math.ulp(abs(value) + step)
    raw = round(value / f.scale)
    raw = raw % f.wrap_at if f.wrap_at else raw
    fmt = {"u16": ">H", "i16": ">h", "u32": ">I", "i32": ">i"}[f.type]
    packed = struct.unpack(f">{f.words}H", struct.pack(fmt, raw))  # independent: struct packing
    assert ws == (packed if order == WordOrder.HIGH_FIRST else packed[::-1])


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sets(st.integers(0, 11), max_size=7), min_size=1, max_size=12))
def test_slots_stay_put_while_tracks_live(updates: list[set[int]]) -> None:
    previous = SlotAssignment.empty(4)
    for n, live in enumerate(updates, start=1):
        snap = build([fix(i, range_m=100.0 + i) for i in sorted(live)], previous=previous)
        slots = snap.assignment.track_ids
        held = [t for t in slots if t is not None]
        assert len(held) == len(set(held)) and set(held) <= live
        assert set(held) | set(snap.unslotted) == live
        if snap.unslotted:
            assert None not in slots
        for k, tid in enumerate(previous.track_ids):
            if tid in live:
                assert slots[k] == tid, "a live track moved"
        for k, tid in enumerate(slots):
            regs = snap.registers
            assert read_field(regs, "TRACK_ID", slot=k) == tid
            assert regs[address_of("SEQ", k)] == n
        assert snap.registers[27] == n
        previous = snap.assignment


def test_overflow_prefers_tracking_then_nearest() -> None:
    ident = Identity((0, 1, 0), max_tracks=2)
    snap = build([fix(1, TrackStatus.ACQUIRING, 100.0), fix(2, range_m=900.0), fix(3, range_m=300.0)],
                 ident)
    assert snap.assignment.track_ids == (3, 2) and snap.unslotted == (1,)
    again = build([fix(1, TrackStatus.ACQUIRING, 100.0), fix(2, range_m=900.0)], ident,
                  previous=snap.assignment)
    assert again.assignment.track_ids == (1, 2) and again.unslotted == ()


def test_update_counter_wraps_and_map_is_complete() -> None:
    snap = build([fix(5)], previous=SlotAssignment((None,) * 4, update_counter=0xFFFF))
    assert snap.registers[27] == 0 and snap.assignment.update_counter == 0
    assert len(snap.registers) == 100 + 20 * 4 + 2 * 4  # the slots, then one u32 MMSI per slot
    assert all(0 <= r <= 0xFFFF for r in snap.registers)
    with pytest.raises(ValueError, match="duplicate"):
        build([fix(5), fix(5)])
    with pytest.raises(ValueError, match="address space"):
        Identity((0, 1, 0), max_tracks=4000)


def test_addresses() -> None:
    assert address_of("SITE_LAT") == 30 and address_of("UPDATE_COUNTER") == 27
    assert address_of("LAT", slot=1) == 124
    with pytest.raises(ValueError):
        address_of("LAT")


def _covered(table: str) -> tuple[list[int], list[int], list[int], list[int]]:
    fixed, slot, alert, mmsi = [], [], [], []
    for m in re.finditer(r"^\| ([TAM]\+)?(\d+)(?:–(\d+))? \|", table, re.M):
        cells = range(int(m[2]), int(m[3] or m[2]) + 1)
        {"T+": slot, "A+": alert, "M+": mmsi, None: fixed}[m[1]].extend(cells)
    return fixed, slot, alert, mmsi


def test_table_documents_every_address_once() -> None:
    fixed, slot, alert, mmsi = _covered(render_markdown_table())
    mmsi_end = TRACK_BASE + (TRACK_STRIDE + 2) * 32
    # identity and health, then (issue 18) the gap after the MMSI block (issue 17) and the alert block's head
    assert sorted(fixed) == list(range(TRACK_BASE)) + list(range(mmsi_end, ALERT_SLOT_BASE))
    assert sorted(slot) == list(range(TRACK_STRIDE)) and sorted(alert) == list(range(ALERT_STRIDE))
    assert sorted(mmsi) == [0, 1]
    for f in FIELDS:
        assert f"| {f.name} |" in render_markdown_table()
    assert BY_NAME["LAT"].scale == 1e-7


def test_documented_register_table_is_the_generated_one() -> None:
    page = (ROOT / "docs" / "modbus.md").read_text()
    m = re.search(r"<!-- registers:begin -->\n(.*?)<!-- registers:end -->", page, re.S)
    assert m, "docs/modbus.md lacks the <!-- registers:begin/end --> markers"
    assert m[1] == render_markdown_table(), "docs/modbus.md register table is stale: run tools/gen-docs"


def test_register_table_tool_prints_the_generated_table() -> None:
    out = subprocess.run([str(ROOT / "tools" / "register-table")], capture_output=True, text=True,
                         check=True, timeout=300)
    assert out.stdout == render_markdown_table()


def test_ais_slot_flags_mmsi_block_and_health_registers() -> None:
    """Map version 2 (issue 17): TARGET_FLAGS, one u32 MMSI per slot after the slots, and the AIS
    monitor's values read from the `ais` health stage's counters (milli-units)."""
    from edge.appliance.health import StageHealth

    ais = StageHealth("ais", True, 0.1, None, {"disparity_offset_mpx": -87, "disparity_sigma_mpx": 12,
                                               "bearing_offset_mdeg": 250, "bearing_sigma_mdeg": 40,
                                               "monitor_ships": 3, "disparity_fault": 1, "lines": 70000,
                                               "checksum_errors": 5, "malformed": 2, "unknown_type": 1})
    health = HealthSnapshot(HEALTH.state, "", HEALTH.status_bits, 0, 29.97, 0.05, 100.0, (ais,))
    snap = build_snapshot([fix(5, ais_mmsi=431000123), fix(6, dark=True), fix(7)], health, IDENT,
                          SlotAssignment.empty(4), utc_ns=T0_NS)
    regs = snap.registers
    assert [read_field(regs, "TARGET_FLAGS", slot=k) for k in range(4)] == [1, 2, 0, 0]
    assert read_field(regs, "MMSI", slot=0, max_tracks=4) == 431000123
    assert read_field(regs, "MMSI", slot=1, max_tracks=4) is None  # 0xFFFFFFFF: none
    assert address_of("MMSI", slot=0, max_tracks=4) == read_field(regs, "MMSI_BASE") == 180
    assert address_of("MMSI", slot=0) == 740 and address_of("AIS_DISP_OFFSET") == 40
    assert math.isclose(read_field(regs, "AIS_DISP_OFFSET"), -0.087)
    assert math.isclose(read_field(regs, "AIS_BRG_OFFSET"), 0.25)
    assert read_field(regs, "AIS_MONITOR_FAULTS") == 1 and read_field(regs, "AIS_MONITOR_SHIPS") == 3
    assert read_field(regs, "AIS_LINES") == 70000 and read_field(regs, "AIS_MALFORMED") == 3
    plain = build([fix(5)]).registers  # without an `ais` stage: "not available"
    assert read_field(plain, "AIS_DISP_OFFSET") is None and read_field(plain, "AIS_LINES") is None
    assert all(40 <= address_of(f.name) <= 59 for f in FIELDS if f.name.startswith("AIS_"))
