"""replay(): byte-identical outputs, CSV in the DESIGN.md columns, NMEA that independent parsers
accept, and damaged recordings played to the end with their faults counted."""

from __future__ import annotations

import csv
import io
import shutil

import pynmea2
import pytest

from edge.errors import ConfigError
from edge.replay import CSV_HEADER, replay

FRAMES = 30


@pytest.fixture(scope="module")
def akashi(recording):
    return recording("akashi-crossing", FRAMES)


def _run(path) -> tuple[str, str, object]:
    nmea, tracks = io.StringIO(), io.StringIO()
    summary = replay(path, nmea=nmea, tracks=tracks)
    return nmea.getvalue(), tracks.getvalue(), summary


def test_outputs_are_byte_identical_and_well_formed(akashi) -> None:
    nmea, tracks, summary = _run(akashi)
    assert (nmea, tracks) == _run(akashi)[:2]
    rows = list(csv.DictReader(io.StringIO(tracks)))
    assert tracks.splitlines()[0] == CSV_HEADER and len(rows) == summary.csv_rows > 0
    for row in rows:
        assert row["status"] in {"Q", "T", "L"}
        float(row["lat"]), float(row["lon"]), float(row["sigma_m"])
        assert 0.0 <= float(row["bearing_deg"]) < 360.0
        assert row["sog_kn"] == "" or float(row["sog_kn"]) >= 0.0
    lines = nmea.splitlines(keepends=True)
    assert lines and len(lines) == summary.nmea_lines
    kinds = set()
    for line in lines:
        assert line.endswith("\r\n") and len(line) <= 82
        msg = pynmea2.parse(line.strip(), check=True)  # checksum verified
        kinds.add(msg.sentence_type)
    assert kinds == {"TTM", "TLL"}
    assert summary.pipeline.processed == FRAMES and summary.skipped_pairs == 0


def test_damaged_recording_plays_to_the_end_with_counts(akashi, tmp_path) -> None:
    damaged = tmp_path / "rec"
    shutil.copytree(akashi, damaged)
    (damaged / "left" / "000004.png").write_bytes(b"not a png")
    (damaged / "right" / "000011.png").unlink()
    frames = (damaged / "frames.csv").read_text().splitlines()
    (damaged / "frames.csv").write_text("\n".join(frames[:16] + frames[20:]) + "\n")  # a gap: 4 pairs lost
    _, tracks, summary = _run(damaged)
    assert summary.skipped_pairs == 2
    assert summary.dropped_pairs == 4  # sequence-number gap
    assert summary.pipeline.processed == FRAMES - 2 - 4
    assert summary.pipeline.gaps >= 4  # the filters coasted through the missing periods
    assert summary.csv_rows > 0 and len(tracks.splitlines()) == summary.csv_rows + 1


def test_not_a_recording_is_a_configuration_error(tmp_path) -> None:
    with pytest.raises(ConfigError) as err:
        replay(tmp_path)
    assert "recording" in err.value.message
