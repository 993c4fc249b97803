"""The Modbus alert header and block (edge.encode.registers, issue 18): written and read back."""

from __future__ import annotations

from edge.appliance.health import HealthSnapshot, HealthState
from edge.encode.alert_rows import AlertImage, AlertRow
from edge.encode.registers import (
    ALERT_SLOT_BASE,
    Identity,
    SlotAssignment,
    address_of,
    build_snapshot,
    read_field,
)

HEALTH = HealthSnapshot(HealthState.OK, "", 1, 0, 10.0, 0.1, 5.0)


def test_alert_block_round_trip() -> None:
    ident = Identity((1, 0, 0), max_tracks=32, alert_slots=16)
    row = AlertRow(191, 102, False, "A", 1, (1, 2), (17, 23), 153.4, 240.6, 12.0)
    image = AlertImage((row,), 1, 5, True)
    regs = build_snapshot([], HEALTH, ident, SlotAssignment.empty(32), utc_ns=0, alerts=image).registers
    assert len(regs) == ALERT_SLOT_BASE + 16 * 16
    assert [
        read_field(regs, n)
        for n in (
            "ALERTS_ACTIVE",
            "ALERTS_UNACK",
            "ALERTS_RAISED",
            "HBT_STATUS",
            "ALERT_BLOCK_ADDR",
            "ALERT_COUNT",
            "ALERT_SLOTS",
            "ALERT_BASE",
            "ALERT_STRIDE",
        )
    ] == [1, 1, 5, 2, 900, 1, 16, 910, 16]
    got = {
        n: read_field(regs, n, slot=0)
        for n in (
            "ALERT_ID",
            "ALERT_INSTANCE",
            "ALERT_STATE",
            "ALERT_PRIORITY",
            "ALERT_TARGET_A",
            "ALERT_TARGET_B",
            "ALERT_TRACK_A",
            "ALERT_TRACK_B",
            "ALERT_CPA",
            "ALERT_TCPA",
            "ALERT_AGE",
        )
    }
    assert got == {
        "ALERT_ID": 191,
        "ALERT_INSTANCE": 102,
        "ALERT_STATE": 1,
        "ALERT_PRIORITY": 1,
        "ALERT_TARGET_A": 1,
        "ALERT_TARGET_B": 2,
        "ALERT_TRACK_A": 17,
        "ALERT_TRACK_B": 23,
        "ALERT_CPA": 153,
        "ALERT_TCPA": 241,
        "ALERT_AGE": 12,
    }
    assert read_field(regs, "ALERT_ID", slot=1) == 0 and read_field(regs, "ALERT_CPA", slot=1) is None
    assert address_of("ALERT_CPA", slot=1) == ALERT_SLOT_BASE + 16 + 12


def test_without_alerts_the_map_is_as_before() -> None:
    ident = Identity((1, 0, 0), max_tracks=32)
    regs = build_snapshot([], HEALTH, ident, SlotAssignment.empty(32), utc_ns=0).registers
    assert len(regs) == 100 + 22 * 32 and regs[60:65] == (0, 0, 0, 0, 0)  # slots, then the MMSI block
