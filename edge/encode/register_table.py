"""The documented Modbus register table (docs/modbus.md), rendered from edge.encode.registers' field
table (`tools/gen-docs`, `tools/register-table`; tests/edge/encode/test_registers.py fails when the page
drifts from it)."""

from __future__ import annotations

from collections.abc import Iterable

from edge.appliance.health import Status
from edge.encode.registers import (
    ALERT_BLOCK,
    ALERT_SLOT_BASE,
    ALERT_SLOTS,
    ALERT_STRIDE,
    BLOCKS,
    DEFAULT_MAX_TRACKS,
    FIELDS,
    MAX_TRACKS_WITH_ALERTS,
    MMSI_STRIDE,
    TRACK_BASE,
    TRACK_STRIDE,
)


def _span(start: int, words: int) -> str:
    return f"{start}" if words == 1 else f"{start}–{start + words - 1}"


def _reserved_rows(block: str, base: int, size: int, prefix: str) -> Iterable[tuple[int, str]]:
    used = {o for f in FIELDS if f.block == block for o in range(f.offset, f.offset + f.words)}
    start = None
    for o in range(size + 1):
        if o < size and o not in used:
            start = o if start is None else start
        elif start is not None:
            cells = f"{prefix}{_span(base + start, o - start)}"
            yield start, f"| {cells} | — | reserved | | | | Reads 0 |"
            start = None


def render_markdown_table(max_tracks: int = DEFAULT_MAX_TRACKS) -> str:
    """The register map as documented: the whole address range, reserved gaps included."""
    size = TRACK_BASE + (TRACK_STRIDE + MMSI_STRIDE) * max_tracks
    out = [
        f"Input registers (FC4, references 30001 + address) with a read-only mirror in holding "
        f"registers (FC3, 40001 + address); addresses are 0-based. The map covers 0–{size - 1} "
        f"without gaps (N = {max_tracks} slots by default); writes and addresses outside it get "
        "exception 02. Slot k starts at T = 100 + 20·k; its MMSI is at M = MMSI_BASE + 2·k "
        f"(MMSI_BASE = 100 + 20·N = {TRACK_BASE + TRACK_STRIDE * max_tracks}). "
        "Stored value = physical value / scale, rounded; an empty \"Not available\" cell means the "
        "value is always valid; 32-bit values high word first unless WORD_ORDER says otherwise.",
        "",
        "| Address | Name | Type | Scale | Unit | Not available | Description |",
        "|---|---|---|---|---|---|---|",
    ]
    for block, (base, bsize) in BLOCKS.items():
        if block == "alert":
            out.append(f"| {size}–{ALERT_BLOCK - 1} | — | reserved "
                       "| | | | Reads 0; present only with alerts.enabled |")
        prefix, base_shown = {"track": ("T+", 0), "mmsi": ("M+", 0), "alert_slot": ("A+", 0)}.get(
            block, ("", base))
        rows = [(f.offset, f"| {prefix}{_span(base_shown + f.offset, f.words)} | {f.name} | {f.type} "
                 f"| {f.scale:g} | {f.unit} | {'' if f.na is None else f'0x{f.na:X}'} "
                 f"| {f.description} |") for f in FIELDS if f.block == block]
        rows += _reserved_rows(block, base_shown, bsize, prefix)
        out += [row for _, row in sorted(rows)]
    out += ["", "STATUS bits: " + ", ".join(f"{m.value.bit_length() - 1} {m.name}" for m in Status) + ".",
            "FAULT_CODE = 10 × stage + kind; stages 1 camera_left, 2 camera_right, 3 processing, "
            "4… outputs in configuration order, 90 ais (when configured); "
            "kind 1 no heartbeat, 2 fault reported.",
            f"Alert block (only with alerts.enabled; then max_tracks <= {MAX_TRACKS_WITH_ALERTS}): "
            f"900–{ALERT_SLOT_BASE - 1}, then {ALERT_SLOTS} alert slots, slot k at A = {ALERT_SLOT_BASE} + "
            f"{ALERT_STRIDE}·k, most urgent first; the map then ends at "
            f"{ALERT_SLOT_BASE + ALERT_STRIDE * ALERT_SLOTS - 1}."]
    return "\n".join(out) + "\n"
