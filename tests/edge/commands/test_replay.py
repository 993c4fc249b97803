"""`mast-stereo replay` as a subprocess: NMEA on stdout or --nmea, the CSV, the summary on stderr,
identical output on a second run, exit 78 for a directory that is not a recording."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

_local = Path(sys.executable).with_name("mast-stereo")
CLI = str(_local) if _local.exists() else shutil.which("mast-stereo")


def _run(*args: str) -> subprocess.CompletedProcess:
    assert CLI, "the mast-stereo console script is not installed (pip install -e .)"
    return subprocess.run([CLI, "replay", *args], capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def akashi(recording):
    return recording("akashi-crossing", 30)


def test_replay_writes_nmea_csv_and_a_summary(akashi, tmp_path) -> None:
    out = _run(str(akashi), "--tracks", str(tmp_path / "a.csv"))
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("$RATTM,") and "$RATLL," in out.stdout
    assert "pairs in recording 30" in out.stderr and "fixes" in out.stderr
    csv_text = (tmp_path / "a.csv").read_text()
    assert csv_text.startswith("t_ns,track_id,status,x_m,y_m,z_m,range_m,bearing_deg,lat,lon,")
    again = _run(str(akashi), "--nmea", str(tmp_path / "b.nmea"), "--tracks", str(tmp_path / "b.csv"))
    assert again.returncode == 0 and again.stdout == ""
    # (text-mode capture turned stdout's CR LF into LF; the file keeps IEC 61162-1's CR LF)
    assert (tmp_path / "b.nmea").read_bytes().replace(b"\r\n", b"\n") == out.stdout.encode("ascii")
    assert (tmp_path / "b.nmea").read_bytes().count(b"\r\n") == out.stdout.count("\n")
    assert (tmp_path / "b.csv").read_text() == csv_text


def test_not_a_recording_exits_78_with_one_line(tmp_path) -> None:
    out = _run(str(tmp_path))
    assert out.returncode == 78
    assert len(out.stderr.strip().splitlines()) == 1 and "recording" in out.stderr
