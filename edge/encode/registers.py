"""The Modbus register map, declared once as a table, and the snapshot builder.

`FIELDS` is the single source of truth for the Modbus map (docs/modbus.md): every register's
block, offset, type, scale, unit, "not available" sentinel and description.
From it come (a) `build_snapshot()`, a pure function turning the live fixes
and health into a complete, gap-free tuple of u16 registers that the Modbus
driver publishes atomically, (b) `read_field()` for clients and tests, and
(c) `edge.encode.register_table.render_markdown_table()`, the documented register table
(docs/modbus.md, written by `tools/gen-docs`; a test fails if the page drifts from it).

Layout: identity block at 0, health block at 16, track slots of fixed stride
from 100 (slot k at 100 + 20k), then (map version 2) one u32 MMSI per slot from
MMSI_BASE = 100 + 20N (740 with the default 32 slots). The AIS calibration monitor and input
counters sit in the health block at 40-55; they are read from the `ais` health stage's counters
(milli-units there, so the registers carry them unchanged) and are "not available" without it.
Scaled integers: stored = round(value / scale),
saturated just short of the sentinel (angles and counters wrap instead).
32-bit values use the configured word order (default high word first); the
PROBE register reads 0x12345678 in that order. A slot keeps its row while its
track lives: slots are keyed by track id and carried from one snapshot to the
next in `SlotAssignment`.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from edge.appliance.health import HealthSnapshot
from edge.encode.ais_rows import ais_values
from edge.encode.alert_rows import AlertImage, alert_values
from edge.fix import ShipFix, TrackStatus

MAP_VERSION = 2  # 2: TARGET_FLAGS, the MMSI block, the AIS health registers; the alerts
PROBE_VALUE = 0x12345678
TRACK_BASE = 100
TRACK_STRIDE = 20
DEFAULT_MAX_TRACKS = 32
MMSI_STRIDE = 2  # one u32 per slot
ALERT_BLOCK = 900  # the alert block (present with alerts.enabled), slots from ALERT_SLOT_BASE
ALERT_SLOT_BASE = 910
ALERT_STRIDE = 16
ALERT_SLOTS = 16
MAX_TRACKS_WITH_ALERTS = 36  # track slots and the AIS MMSI block (2 per slot after them) end below 900
BLOCKS = {"identity": (0, 16), "health": (16, TRACK_BASE - 16), "track": (TRACK_BASE, TRACK_STRIDE),
          "mmsi": (TRACK_BASE + TRACK_STRIDE * DEFAULT_MAX_TRACKS, MMSI_STRIDE),  # mmsi: base for N = 32
          "alert": (ALERT_BLOCK, ALERT_SLOT_BASE - ALERT_BLOCK),
          "alert_slot": (ALERT_SLOT_BASE, ALERT_STRIDE)}
TARGET_FLAG_AIS, TARGET_FLAG_DARK = 1 << 0, 1 << 1
TYPES = {"u16": (1, False), "i16": (1, True), "u32": (2, False), "i32": (2, True)}  # words, signed
NA_U16, NA_I16, NA_U32, NA_I32 = 0xFFFF, 0x8000, 0xFFFFFFFF, 0x7FFFFFFF
SLOT_STATUS = {None: 0, TrackStatus.ACQUIRING: 1, TrackStatus.TRACKING: 2, TrackStatus.LOST: 3}
_STATUS_PRIORITY = {TrackStatus.TRACKING: 0, TrackStatus.ACQUIRING: 1, TrackStatus.LOST: 2}


class WordOrder(enum.IntEnum):
    HIGH_FIRST = 0  # ABCD: high word at the lower address (Modbus default here)
    LOW_FIRST = 1  # CDAB: Modicon/Schneider style


@dataclass(frozen=True, slots=True)
class Field:
    name: str
    block: str  # identity | health | track | mmsi
    offset: int  # from the block start (track: from the slot start)
    type: str  # u16 | i16 | u32 | i32
    scale: float  # physical units per count
    unit: str
    na: int | None  # raw "not available" sentinel; None = always present
    description: str
    wrap_at: int | None = None  # raw modulus for angles and counters (else saturate)

    @property
    def words(self) -> int:
        return TYPES[self.type][0]


def _f(name, block, offset, type_, scale, unit, na, description, wrap_at=None) -> Field:
    return Field(name, block, offset, type_, scale, unit, na, description, wrap_at)


FIELDS: tuple[Field, ...] = (
    _f("MAP_VERSION", "identity", 0, "u16", 1, "", None, f"Register map version (= {MAP_VERSION})"),
    _f("FW_MAJOR", "identity", 1, "u16", 1, "", None, "Firmware version, major"),
    _f("FW_MINOR", "identity", 2, "u16", 1, "", None, "Firmware version, minor"),
    _f("FW_PATCH", "identity", 3, "u16", 1, "", None, "Firmware version, patch"),
    _f("PROBE", "identity", 4, "u32", 1, "", None,
       "Always 0x12345678: read it as u32 to check the word order"),
    _f("MAX_TRACKS", "identity", 6, "u16", 1, "", None, "Number of track slots N"),
    _f("TRACK_BASE", "identity", 7, "u16", 1, "", None, f"Address of slot 0 (= {TRACK_BASE})"),
    _f("TRACK_STRIDE", "identity", 8, "u16", 1, "", None,
       f"Registers per slot (= {TRACK_STRIDE})"),
    _f("WORD_ORDER", "identity", 9, "u16", 1, "", None,
       "32-bit word order: 0 = high word first (ABCD), 1 = low word first (CDAB)"),
    _f("MMSI_BASE", "identity", 10, "u16", 1, "", None,
       "Address of the MMSI block (= TRACK_BASE + TRACK_STRIDE x MAX_TRACKS; "
       f"{TRACK_BASE + TRACK_STRIDE * DEFAULT_MAX_TRACKS} by default)"),
    _f("HEARTBEAT", "health", 0, "u16", 1, "s", None,
       "+1 per second of uptime, wraps; stops when publishing stops (PLC watchdog)", 1 << 16),
    _f("STATUS", "health", 1, "u16", 1, "bits", None, "Status bits, see below"),
    _f("FAULT_CODE", "health", 2, "u16", 1, "", None,
       "0 = none, else 10 x stage + kind of the worst problem, see below"),
    _f("ACTIVE_TRACKS", "health", 3, "u16", 1, "", None,
       "Live tracks (acquiring or tracking), including any without a slot"),
    _f("FRAME_RATE", "health", 4, "u16", 0.1, "fps", NA_U16, "Processed frame pairs per second"),
    _f("LATENCY", "health", 5, "u16", 0.001, "s", NA_U16, "Capture-to-output latency, ms"),
    _f("UPTIME", "health", 6, "u32", 1, "s", None, "Seconds since the daemon started"),
    _f("SNAPSHOT_UTC", "health", 8, "u32", 1, "s", None, "Time of this snapshot, Unix seconds (UTC)"),
    _f("SNAPSHOT_MS", "health", 10, "u16", 0.001, "s", None, "Milliseconds part of SNAPSHOT_UTC"),
    _f("UPDATE_COUNTER", "health", 11, "u16", 1, "", None,
       "+1 per published snapshot, wraps at 65536", 1 << 16),
    _f("SITE_LAT", "health", 14, "i32", 1e-7, "deg", NA_I32,
       "Latitude of the site (baseline midpoint), WGS-84, north positive"),
    _f("SITE_LON", "health", 16, "i32", 1e-7, "deg", NA_I32, "Longitude of the site, east positive"),
    _f("AIS_DISP_OFFSET", "health", 24, "i16", 0.001, "px", NA_I16,
       "AIS calibration check: disparity offset (measured - expected; right-camera yaw drift)"),
    _f("AIS_DISP_SIGMA", "health", 25, "u16", 0.001, "px", NA_U16, "1-sigma of AIS_DISP_OFFSET"),
    _f("AIS_BRG_OFFSET", "health", 26, "i16", 0.001, "deg", NA_I16,
       "AIS calibration check: bearing offset (measured - expected; heading error)"),
    _f("AIS_BRG_SIGMA", "health", 27, "u16", 0.001, "deg", NA_U16, "1-sigma of AIS_BRG_OFFSET"),
    _f("AIS_MONITOR_SHIPS", "health", 28, "u16", 1, "", NA_U16, "Class-A ships behind the estimates"),
    _f("AIS_MONITOR_FAULTS", "health", 29, "u16", 1, "bits", NA_U16,
       "Bit 0 disparity offset beyond its bound with confidence, bit 1 bearing offset"),
    _f("AIS_TARGETS", "health", 30, "u16", 1, "", NA_U16, "AIS targets with a recent position report"),
    _f("AIS_LINES", "health", 32, "u32", 1, "", NA_U32, "AIS lines received, wraps", 1 << 32),
    _f("AIS_DECODED", "health", 34, "u32", 1, "", NA_U32, "AIS messages decoded and used, wraps", 1 << 32),
    _f("AIS_CHECKSUM_ERRORS", "health", 36, "u16", 1, "", NA_U16, "AIS lines with a bad checksum, wraps",
       1 << 16),
    _f("AIS_MALFORMED", "health", 37, "u16", 1, "", NA_U16,
       "AIS lines malformed or of an unknown message type, wraps", 1 << 16),
    _f("AIS_INCOMPLETE", "health", 38, "u16", 1, "", NA_U16,
       "Multi-part AIS messages dropped with fragments missing, wraps", 1 << 16),
    _f("AIS_TOO_OLD", "health", 39, "u16", 1, "", NA_U16, "AIS position reports dropped for age, wraps",
       1 << 16),
    _f("AIS_INPUT_ERRORS", "health", 40, "u16", 1, "", NA_U16,
       "AIS input faults: failed opens/reads and lines lost to a full queue, wraps", 1 << 16),
    _f("SLOT_STATUS", "track", 0, "u16", 1, "", None,
       "0 empty, 1 acquiring (Q), 2 tracking (T), 3 lost (L, while held)"),
    _f("TARGET_NUMBER", "track", 1, "u16", 1, "", NA_U16, "NMEA TTM/TLL target number"),
    _f("TRACK_ID", "track", 2, "u32", 1, "", NA_U32, "Internal track id, never reused"),
    _f("LAT", "track", 4, "i32", 1e-7, "deg", NA_I32, "Latitude, WGS-84"),
    _f("LON", "track", 6, "i32", 1e-7, "deg", NA_I32, "Longitude, WGS-84"),
    _f("SOG", "track", 8, "u16", 0.01, "kn", NA_U16, "Speed over ground"),
    _f("COG", "track", 9, "u16", 0.01, "deg", NA_U16, "Course over ground, true", 36000),
    _f("RANGE", "track", 10, "u16", 1, "m", NA_U16, "Horizontal distance from the site"),
    _f("BEARING", "track", 11, "u16", 0.01, "deg", NA_U16, "True bearing from the site", 36000),
    _f("X_EAST", "track", 12, "i16", 1, "m", NA_I16, "Position east of the site"),
    _f("Y_NORTH", "track", 13, "i16", 1, "m", NA_I16, "Position north of the site"),
    _f("AGE", "track", 14, "u16", 0.1, "s", NA_U16, "Time from the measurement to this snapshot"),
    _f("SIGMA", "track", 15, "u16", 0.1, "m", NA_U16, "1-sigma range error"),
    _f("CONFIDENCE", "track", 16, "u16", 1, "%", NA_U16,
       "Share of the last 10 s of pairs in which the track was measured, not coasted"),
    _f("TARGET_FLAGS", "track", 17, "u16", 1, "bits", None,
       "Bit 0 AIS associated (MMSI in the MMSI block), bit 1 DARK (tracking, no AIS for ais.dark_after_s)"),
    _f("LENGTH", "track", 18, "u16", 1, "m", NA_U16, "Apparent ship length estimate"),
    _f("SEQ", "track", 19, "u16", 1, "", None,
       "UPDATE_COUNTER of the snapshot this slot was written in", 1 << 16),
    _f("MMSI", "mmsi", 0, "u32", 1, "", NA_U32,
       "MMSI of slot k's associated AIS target, at MMSI_BASE + 2k (0xFFFFFFFF: none)"),
)
FIELDS += (  # alerts (edge.alerts); all 0 / "not available" with alerts off
    _f("ALERTS_ACTIVE", "health", 44, "u16", 1, "", None, "Active alerts (address 60)"),
    _f("ALERTS_UNACK", "health", 45, "u16", 1, "", None, "Active alerts not acknowledged"),
    _f("ALERTS_RAISED", "health", 46, "u16", 1, "", None, "Alerts raised since start, wraps", 1 << 16),
    _f("HBT_STATUS", "health", 47, "u16", 1, "", None, "NMEA HBT status: 2 A (health OK), 1 V, 0 alerts off"),
    _f("ALERT_BLOCK_ADDR", "health", 48, "u16", 1, "", None,
       f"Address of the alert block (= {ALERT_BLOCK}); 0 with alerts off"),
    _f("ALERT_COUNT", "alert", 0, "u16", 1, "", None, "Active alerts (all, including any without a slot)"),
    _f("ALERT_SLOTS", "alert", 1, "u16", 1, "", None, f"Alert slots M (= {ALERT_SLOTS})"),
    _f("ALERT_BASE", "alert", 2, "u16", 1, "", None, f"Address of alert slot 0 (= {ALERT_SLOT_BASE})"),
    _f("ALERT_STRIDE", "alert", 3, "u16", 1, "", None, f"Registers per alert slot (= {ALERT_STRIDE})"),
    _f("ALERT_ID", "alert_slot", 0, "u16", 1, "", None,
       "0 empty, else the ALF alert id (190-193, 10001-10004: docs/alerts.md)"),
    _f("ALERT_INSTANCE", "alert_slot", 1, "u32", 1, "", NA_U32, "ALF alert instance (first NMEA port's)"),
    _f("ALERT_STATE", "alert_slot", 3, "u16", 1, "", None,
       "0 empty, 1 active unacknowledged (V), 2 acknowledged (A)"),
    _f("ALERT_PRIORITY", "alert_slot", 4, "u16", 1, "", None, "0 empty, 1 alarm, 2 warning, 3 caution"),
    _f("ALERT_REVISION", "alert_slot", 5, "u16", 1, "", None, "ALF revision counter 1-99"),
    _f("ALERT_TARGET_A", "alert_slot", 6, "u16", 1, "", NA_U16, "NMEA target number of the (first) ship"),
    _f("ALERT_TARGET_B", "alert_slot", 7, "u16", 1, "", NA_U16, "Close quarters: the other ship's number"),
    _f("ALERT_TRACK_A", "alert_slot", 8, "u32", 1, "", NA_U32, "Track id of the (first) ship"),
    _f("ALERT_TRACK_B", "alert_slot", 10, "u32", 1, "", NA_U32, "Close quarters: the other ship's track id"),
    _f("ALERT_CPA", "alert_slot", 12, "u16", 1, "m", NA_U16, "Close quarters: CPA now"),
    _f("ALERT_TCPA", "alert_slot", 13, "i16", 1, "s", NA_I16, "Close quarters: TCPA now (negative: passed)"),
    _f("ALERT_AGE", "alert_slot", 14, "u16", 1, "s", NA_U16, "Time since the alert was raised"),
)
BY_NAME = {f.name: f for f in FIELDS}
BLOCK_FIELDS = {block: tuple(f for f in FIELDS if f.block == block) for block in BLOCKS}
AIS_NAMES = [f.name for f in BLOCK_FIELDS["health"] if f.name.startswith("AIS_")]


def _check_layout() -> None:
    for block, (_, size) in BLOCKS.items():
        used: set[int] = set()
        for f in (f for f in FIELDS if f.block == block):
            cells = set(range(f.offset, f.offset + f.words))
            if cells & used or max(cells) >= size:
                raise RuntimeError(f"register map: {f.name} overlaps another field or leaves {block}")
            used |= cells


_check_layout()


@dataclass(frozen=True, slots=True)
class Identity:
    firmware_version: tuple[int, int, int]
    max_tracks: int = DEFAULT_MAX_TRACKS
    word_order: WordOrder = WordOrder.HIGH_FIRST
    site_lat_deg: float | None = None
    site_lon_deg: float | None = None
    alert_slots: int = 0  # ALERT_SLOTS with alerts.enabled, else 0 (no alert block)

    def __post_init__(self) -> None:
        if not 1 <= self.max_tracks <= (0x10000 - TRACK_BASE) // (TRACK_STRIDE + MMSI_STRIDE):
            raise ValueError(f"max_tracks {self.max_tracks} does not fit the 16-bit address space")
        if self.alert_slots and self.max_tracks > MAX_TRACKS_WITH_ALERTS:
            raise ValueError(f"with the alert block at {ALERT_BLOCK} max_tracks must be "
                             f"<= {MAX_TRACKS_WITH_ALERTS}")

    @property
    def mmsi_base(self) -> int:
        return TRACK_BASE + TRACK_STRIDE * self.max_tracks

    @property
    def size(self) -> int:
        if self.alert_slots:
            return ALERT_SLOT_BASE + ALERT_STRIDE * self.alert_slots
        return self.mmsi_base + MMSI_STRIDE * self.max_tracks


@dataclass(frozen=True, slots=True)
class SlotAssignment:
    """Which track id holds each slot, and the counter of the last snapshot built."""

    track_ids: tuple[int | None, ...]
    update_counter: int = 0

    @classmethod
    def empty(cls, max_tracks: int) -> SlotAssignment:
        return cls((None,) * max_tracks)


@dataclass(frozen=True, slots=True)
class RegisterSnapshot:
    registers: tuple[int, ...]  # u16, address 0 .. size-1, no gaps
    assignment: SlotAssignment  # pass to the next build_snapshot()
    unslotted: tuple[int, ...]  # track ids that found no free slot


def address_of(name: str, slot: int | None = None, max_tracks: int | None = None) -> int:
    """0-based register address of a field (track and MMSI fields need `slot`; the MMSI block's
    place depends on the number of slots, default 32)."""
    f = BY_NAME[name]
    if f.block == "track":
        if slot is None or slot < 0:
            raise ValueError(f"{name} is a track field: give slot >= 0")
        return TRACK_BASE + TRACK_STRIDE * slot + f.offset
    if f.block == "alert_slot":
        if slot is None or slot < 0:
            raise ValueError(f"{name} is an alert-slot field: give slot >= 0")
        return ALERT_SLOT_BASE + ALERT_STRIDE * slot + f.offset
    if f.block == "mmsi":
        if slot is None or slot < 0:
            raise ValueError(f"{name} is a per-slot field: give slot >= 0")
        return (max_tracks or DEFAULT_MAX_TRACKS) * TRACK_STRIDE + TRACK_BASE + MMSI_STRIDE * slot
    return BLOCKS[f.block][0] + f.offset


def encode(f: Field, value: float | None, word_order: WordOrder) -> tuple[int, ...]:
    """Physical value -> the field's u16 words (None -> the sentinel)."""
    bits = 16 * f.words
    signed = TYPES[f.type][1]
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        if f.na is None:
            raise ValueError(f"{f.name} has no 'not available' value")
        raw = f.na
    else:
        raw = round(value / f.scale)
        if f.wrap_at is not None:
            raw %= f.wrap_at
        else:
            lo, hi = (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if signed else (0, (1 << bits) - 1)
            if f.na is not None:  # keep the sentinel free: saturate one step inside it
                lo, hi = (lo + 1, hi) if signed and f.na == (1 << (bits - 1)) else (lo, hi - 1)
            if f.na is None and not lo <= raw <= hi:
                raise ValueError(f"{f.name} = {value} does not fit {f.type}")
            raw = min(max(raw, lo), hi)
        raw &= (1 << bits) - 1
    if f.words == 1:
        return (raw,)
    high, low = raw >> 16, raw & 0xFFFF
    return (high, low) if word_order == WordOrder.HIGH_FIRST else (low, high)


def decode(f: Field, words: Sequence[int], word_order: WordOrder) -> float | None:
    """The field's u16 words -> physical value (None for the sentinel)."""
    if f.words == 1:
        raw = words[0]
    else:
        high, low = (words[0], words[1]) if word_order == WordOrder.HIGH_FIRST else (words[1], words[0])
        raw = (high << 16) | low
    if f.na is not None and raw == f.na:
        return None
    bits = 16 * f.words
    if TYPES[f.type][1] and raw >= 1 << (bits - 1):
        raw -= 1 << bits
    return raw * f.scale


def read_field(registers: Sequence[int], name: str, *, slot: int | None = None,
               word_order: WordOrder = WordOrder.HIGH_FIRST, max_tracks: int | None = None) -> float | None:
    f = BY_NAME[name]
    at = address_of(name, slot, max_tracks)
    return decode(f, registers[at:at + f.words], word_order)


def assign_slots(fixes: Sequence[ShipFix], previous: Sequence[int | None]
                 ) -> tuple[tuple[int | None, ...], tuple[int, ...]]:
    """Tracks keep their slot; new ones take the lowest free slots, best first.

    A slot is freed when its track is no longer among the fixes. New tracks are
    placed tracking before acquiring before lost, then nearest first.
    Returns (track id per slot, ids left without a slot).
    """
    live = {fx.track_id for fx in fixes}
    slots = [tid if tid in live else None for tid in previous]
    placed = {tid for tid in slots if tid is not None}
    new = sorted((fx for fx in fixes if fx.track_id not in placed),
                 key=lambda fx: (_STATUS_PRIORITY[fx.status], fx.range_m, fx.track_id))
    free = iter([k for k, tid in enumerate(slots) if tid is None])
    unslotted = []
    for fx in new:
        k = next(free, None)
        if k is None:
            unslotted.append(fx.track_id)
        else:
            slots[k] = fx.track_id
    return tuple(slots), tuple(unslotted)


def build_snapshot(fixes: Sequence[ShipFix], health: HealthSnapshot, identity: Identity,
                   previous: SlotAssignment, *, utc_ns: int,
                   target_numbers: Mapping[int, int] | None = None,
                   alerts: AlertImage | None = None) -> RegisterSnapshot:
    """Pure: the complete register image for this moment.

    `fixes` holds one ShipFix per live track (a track missing from it is gone
    and frees its slot); `utc_ns` is the snapshot time; `target_numbers` maps
    track id -> NMEA target number where one is assigned.
    """
    ids = [fx.track_id for fx in fixes]
    if len(set(ids)) != len(ids):
        raise ValueError(f"duplicate track ids in fixes: {ids}")
    prev = tuple(previous.track_ids[:identity.max_tracks])
    prev += (None,) * (identity.max_tracks - len(prev))
    slots, unslotted = assign_slots(fixes, prev)
    counter = (previous.update_counter + 1) & 0xFFFF
    regs = [0] * identity.size
    order = identity.word_order

    def write(block_base: int, block: str, values: Mapping[str, float | None]) -> None:
        for f in BLOCK_FIELDS[block]:
            regs[block_base + f.offset:block_base + f.offset + f.words] = encode(f, values[f.name], order)

    write(0, "identity", _identity_values(identity))
    active = sum(1 for fx in fixes if fx.status != TrackStatus.LOST)
    write(BLOCKS["health"][0], "health", _health_values(health, identity, utc_ns, counter, active))
    by_id = {fx.track_id: fx for fx in fixes}
    numbers = target_numbers or {}
    for k, tid in enumerate(slots):
        fx = by_id.get(tid) if tid is not None else None
        write(TRACK_BASE + TRACK_STRIDE * k, "track", _slot_values(fx, numbers, utc_ns, counter))
        write(identity.mmsi_base + MMSI_STRIDE * k, "mmsi", {"MMSI": None if fx is None else fx.ais_mmsi})
    if alerts is not None:  # the header's alert fields, and the block when it exists
        header = alerts.header(ALERT_BLOCK if identity.alert_slots else 0)
        for f in BLOCK_FIELDS["health"][-5:]:
            at = BLOCKS["health"][0] + f.offset
            regs[at:at + f.words] = encode(f, header[f.name], order)
    if identity.alert_slots:
        rows = alerts.rows if alerts is not None else ()
        write(ALERT_BLOCK, "alert", {"ALERT_COUNT": len(rows), "ALERT_SLOTS": identity.alert_slots,
                                     "ALERT_BASE": ALERT_SLOT_BASE, "ALERT_STRIDE": ALERT_STRIDE})
        for k in range(identity.alert_slots):
            row = rows[k] if k < len(rows) else None
            write(ALERT_SLOT_BASE + ALERT_STRIDE * k, "alert_slot",
                  alert_values(row, [f.name for f in BLOCK_FIELDS["alert_slot"]]))
    return RegisterSnapshot(tuple(regs), SlotAssignment(slots, counter), unslotted)


def _identity_values(identity: Identity) -> dict[str, float | None]:
    major, minor, patch = identity.firmware_version
    return {"MAP_VERSION": MAP_VERSION, "FW_MAJOR": major, "FW_MINOR": minor, "FW_PATCH": patch,
            "PROBE": PROBE_VALUE, "MAX_TRACKS": identity.max_tracks, "TRACK_BASE": TRACK_BASE,
            "TRACK_STRIDE": TRACK_STRIDE, "WORD_ORDER": int(identity.word_order),
            "MMSI_BASE": identity.mmsi_base}


def _health_values(h: HealthSnapshot, identity: Identity, utc_ns: int, counter: int,
                   active: int) -> dict[str, float | None]:
    return {"HEARTBEAT": math.floor(h.uptime_s), "STATUS": h.status_bits, "FAULT_CODE": h.fault_code,
            "ACTIVE_TRACKS": active, "FRAME_RATE": h.frame_rate_hz, "LATENCY": h.latency_s,
            "UPTIME": math.floor(h.uptime_s), "SNAPSHOT_UTC": utc_ns // 1_000_000_000,
            "SNAPSHOT_MS": (utc_ns // 1_000_000 % 1000) / 1000, "UPDATE_COUNTER": counter,
            "SITE_LAT": identity.site_lat_deg, "SITE_LON": identity.site_lon_deg, **ais_values(h, AIS_NAMES),
            "ALERTS_ACTIVE": 0, "ALERTS_UNACK": 0, "ALERTS_RAISED": 0, "HBT_STATUS": 0, "ALERT_BLOCK_ADDR": 0}


def _slot_values(fx: ShipFix | None, numbers: Mapping[int, int], utc_ns: int,
                 counter: int) -> dict[str, float | None]:
    values: dict[str, float | None] = {f.name: None for f in BLOCK_FIELDS["track"]}
    values.update(SLOT_STATUS=SLOT_STATUS[None], SEQ=counter, TARGET_FLAGS=0)
    if fx is None:
        return values
    brg = math.radians(fx.bearing_deg)
    values.update(
        SLOT_STATUS=SLOT_STATUS[fx.status], TARGET_NUMBER=numbers.get(fx.track_id),
        TRACK_ID=fx.track_id, LAT=fx.lat_deg, LON=fx.lon_deg, SOG=fx.sog_kn, COG=fx.cog_deg,
        RANGE=fx.range_m, BEARING=fx.bearing_deg,
        X_EAST=fx.range_m * math.sin(brg), Y_NORTH=fx.range_m * math.cos(brg),
        AGE=max(0, utc_ns - fx.t_ns) / 1e9, SIGMA=fx.sigma_m,
        CONFIDENCE=None if fx.confidence is None else 100 * fx.confidence, LENGTH=fx.length_m,
        TARGET_FLAGS=(TARGET_FLAG_AIS if fx.ais_mmsi is not None else 0)
        | (TARGET_FLAG_DARK if fx.dark else 0))
    return values
