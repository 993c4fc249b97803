"""tools/bench-capture and lab/bench/capture.py: every format measured, the table printed."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from lab.bench.capture import FORMATS, run, table

ROOT = Path(__file__).resolve().parents[3]


def test_rows_for_every_format() -> None:
    rows = run(sizes=((64, 48),), pairs=3)
    assert [r.pixel_format for r in rows] == list(FORMATS)
    assert all(r.capture_us > 0 and r.copy_us > 0 for r in rows)
    assert rows[0].bytes_per_frame == 64 * 48 and "ratio" in table(rows)


def test_tool_parses_its_arguments() -> None:
    out = subprocess.run(
        [
            sys.executable,
            str(ROOT / "tools" / "bench-capture"),
            "--sizes",
            "32x24",
            "--formats",
            "grey,yuyv",
            "--pairs",
            "2",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 0, out.stderr
    assert "32x24" in out.stdout and "YUYV" in out.stdout and "MJPEG" not in out.stdout
    bad = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "bench-capture"), "--sizes", "720"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert bad.returncode == 2 and "not WIDTHxHEIGHT" in bad.stderr
