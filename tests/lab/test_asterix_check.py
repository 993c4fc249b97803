"""ASTERIX on a replay against the NMEA of the same replay, decoded by asterix-decoder (issue 26's
acceptance on a short cached recording; tools/asterix-check runs it on the evaluation recordings)."""

from __future__ import annotations

import io

import pytest

from edge.replay import replay
from lab.asterix_check import check_recording, compare, split_blocks

pytest.importorskip("asterix")  # asterix-decoder, the test extra


def test_replay_blocks_match_the_nmea_field_by_field(recording) -> None:
    check = check_recording(recording("akashi-crossing", 30))
    assert check.updates > 0 and check.unmatched == 0
    assert check.max_position_m <= 1.0
    assert check.number_changes == 0 and check.shared_numbers == 0
    assert check.tre_missing == 0 and check.numbers_ended >= check.tracks
    assert check.speed_bad == check.course_bad == check.velocity_missing == check.velocity_extra == 0
    assert check.largest_block <= 1472 and check.passed


def test_a_wrong_position_fails_the_check(recording) -> None:
    """The check is not vacuous: a TLL moved by 2 m no longer matches within 1 m."""
    nmea, blocks = io.StringIO(), io.BytesIO()
    replay(recording("akashi-crossing", 30), nmea=nmea, asterix=blocks)
    text = nmea.getvalue()
    line = next(x for x in text.splitlines() if "TLL" in x)
    fields = line.split(",")
    minutes = float(fields[2][2:]) + 2.0 / 1852.0  # 2 m north
    moved = ",".join([fields[0], fields[1], f"{fields[2][:2]}{minutes:07.4f}", *fields[3:]])
    check = compare("moved", split_blocks(blocks.getvalue()), text.replace(line, moved, 1))
    assert check.max_position_m > 1.5 and not check.passed
