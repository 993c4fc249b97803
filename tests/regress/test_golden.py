"""Golden replays: short simulator recordings whose NMEA and per-fix CSV are committed byte for byte.

The way gpsd's regression driver works: each case renders a recording deterministically (same
scenario, frames and seed give the same PNGs), runs `mast-stereo replay`'s code over it and compares
both outputs with `tests/regress/golden/<case>.nmea` and `<case>.csv`. A refactoring must leave them
byte-identical; a change that alters an output regenerates its golden files in the same commit
(`MAST_UPDATE_GOLDEN=1 tools/test tests/regress`) and says why in the message.

The cases cover both camera models (pinhole: akashi-crossing, glints, small-boat-fog; poly10:
two-ships-crossing), fog and glints, 10 fps and the 1 fps 2048 px photo mode (approach-2048).
"""

from __future__ import annotations

import io
import os
from collections.abc import Callable
from pathlib import Path

import pytest

from edge.replay import replay

GOLDEN = Path(__file__).resolve().parent / "golden"
CASES = {  # case name: (scenario, frames)
    "akashi-crossing-95": ("akashi-crossing", 95),
    "glints-40": ("glints", 40),
    "two-ships-crossing-60": ("two-ships-crossing", 60),
    "small-boat-fog-60": ("small-boat-fog", 60),
    "approach-2048-10": ("approach-2048", 10),
}
UPDATE = os.environ.get("MAST_UPDATE_GOLDEN") == "1"


def _first_difference(expected: str, got: str) -> str:
    for number, (a, b) in enumerate(zip(expected.splitlines(), got.splitlines(), strict=False), 1):
        if a != b:
            return f"line {number}:\n  golden: {a}\n  now:    {b}"
    return f"line counts differ: golden {expected.count(chr(10))}, now {got.count(chr(10))}"


@pytest.mark.parametrize("case", sorted(CASES))
def test_replay_matches_golden(case: str, recording: Callable[..., Path]) -> None:
    scenario, frames = CASES[case]
    nmea, tracks = io.StringIO(), io.StringIO()
    summary = replay(recording(scenario, frames), nmea=nmea, tracks=tracks)
    assert summary.pipeline.failed == 0
    outputs = {"nmea": nmea.getvalue(), "csv": tracks.getvalue()}
    assert outputs["csv"].count("\n") > 1, "a golden case must produce fixes to be worth its time"
    for suffix, got in outputs.items():
        path = GOLDEN / f"{case}.{suffix}"
        if UPDATE:
            path.write_bytes(got.encode())  # bytes: NMEA lines end in CR LF
            continue
        assert path.exists(), f"{path} missing: run MAST_UPDATE_GOLDEN=1 tools/test tests/regress"
        expected = path.read_bytes().decode()
        assert got == expected, f"{path.name} differs from its golden: {_first_difference(expected, got)}"
