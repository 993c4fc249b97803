"""ASTERIX records and data blocks: the FSPEC of a record and the CAT/LEN framing of a block.

A record is its FSPEC (one bit per Field Reference Number of the category's User Application
Profile, seven to an octet, bit 1 of each octet the FX bit that says another octet follows)
followed by the present items in FRN order. A data block is CAT (1 octet), LEN (2 octets, the
whole block's length) and one or more records of that category. `pack_blocks` fills blocks of
at most `max_bytes` (1,472: a UDP payload that fits a 1,500-byte Ethernet MTU unfragmented)
with whole records, in order; a record never spans two blocks.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

MAX_BLOCK_BYTES = 1472
BLOCK_HEADER_BYTES = 3


def fspec(frns: Iterable[int]) -> bytes:
    """The FSPEC for the given Field Reference Numbers (1-based), with FX bits; at least one octet."""
    present = sorted(set(frns))
    if present and present[0] < 1:
        raise ValueError(f"FRNs start at 1, got {present[0]}")
    octets = bytearray(max(1, (present[-1] + 6) // 7 if present else 1))
    for frn in present:
        index, bit = divmod(frn - 1, 7)
        octets[index] |= 0x80 >> bit
    for k in range(len(octets) - 1):
        octets[k] |= 0x01
    return bytes(octets)


def record(items: Mapping[int, bytes]) -> bytes:
    """A record from {FRN: item bytes}: FSPEC, then the items in FRN order."""
    return fspec(items) + b"".join(items[frn] for frn in sorted(items))


def data_block(category: int, records: Iterable[bytes]) -> bytes:
    """CAT, LEN and the records; ValueError if it would exceed 65,535 bytes."""
    body = b"".join(records)
    length = BLOCK_HEADER_BYTES + len(body)
    if not 0 <= category <= 255 or length > 0xFFFF:
        raise ValueError(f"category 0..255 and length <= 65535 needed, got {category}, {length}")
    return bytes((category,)) + length.to_bytes(2, "big") + body


def pack_blocks(category: int, records: Iterable[bytes], max_bytes: int = MAX_BLOCK_BYTES) -> list[bytes]:
    """Whole records into as few blocks of at most `max_bytes` as order allows (first fit, in order).
    ValueError for a record that cannot fit a block on its own."""
    blocks: list[bytes] = []
    current: list[bytes] = []
    size = BLOCK_HEADER_BYTES
    for rec in records:
        if BLOCK_HEADER_BYTES + len(rec) > max_bytes:
            raise ValueError(f"a {len(rec)}-byte record does not fit a {max_bytes}-byte block")
        if size + len(rec) > max_bytes:
            blocks.append(data_block(category, current))
            current, size = [], BLOCK_HEADER_BYTES
        current.append(rec)
        size += len(rec)
    if current:
        blocks.append(data_block(category, current))
    return blocks
