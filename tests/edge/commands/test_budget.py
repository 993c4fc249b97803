"""`mast-stereo budget` as a subprocess: JSON equals the library, the table shows it, bad input exits 2."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from edge.core.budget import error_budget

_local = Path(sys.executable).with_name("mast-stereo")
CLI = str(_local) if _local.exists() else shutil.which("mast-stereo")
RIG = ["--width", "720", "--fov", "43", "--baseline", "8.14"]


def _run(*args: str) -> subprocess.CompletedProcess:
    assert CLI, "the mast-stereo console script is not installed (pip install -e .)"
    return subprocess.run([CLI, "budget", *args], capture_output=True, text=True, timeout=60)


def test_json_defaults_match_the_library() -> None:
    proc = _run(*RIG, "--delta", "0.5", "--json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == error_budget(720, 43.0, 8.14, 0.5).to_dict()


def test_json_with_options_matches_the_library() -> None:
    proc = _run(
        "--width", "2048", "--fov", "43", "--baseline", "8.14", "--delta", "0.11", "--json",
        "--tolerance", "150", "--tolerance", "20", "--range", "1500", "--range", "250000",
        "--ship-length", "30", "--min-pixels", "12",
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    got = json.loads(proc.stdout)
    want = error_budget(2048, 43.0, 8.14, 0.11, [150.0, 20.0], [1500.0, 250000.0], 30.0, 12.0)
    assert got == want.to_dict()
    assert [m["tolerance_m"] for m in got["max_ranges"]] == [150.0, 20.0]
    assert round(got["max_ranges"][0]["z_max_first_order_m"]) == 5372
    assert got["range_errors"][1]["error_far_m"] is None  # beyond L_B / eps: unmeasurable
    assert got["detectable_range_m"] == pytest.approx(30 * 2048 / (24 * math.tan(math.radians(21.5))))


def test_table_shows_the_figures() -> None:
    proc = _run(*RIG, "--delta", "0.5")
    assert proc.returncode == 0, proc.stderr
    b = error_budget(720, 43.0, 8.14, 0.5)
    out = proc.stdout
    assert f"{b.z_near_m:.1f} m" in out and f"{b.detectable_range_m:.0f} m" in out
    for m in b.max_ranges:
        assert f"{m.z_max_m:.0f}" in out and f"{m.z_max_first_order_m:.0f}" in out
    row = next(line for line in out.splitlines() if line.split()[:1] == ["1500"])
    assert row.split()[3:5] == ["-137.4", "168.2"]


@pytest.mark.parametrize(
    "args, word",
    [
        (["--width", "0", "--fov", "43", "--baseline", "8", "--delta", "0.5"], "--width"),
        (["--width", "720.5", "--fov", "43", "--baseline", "8", "--delta", "0.5"], "--width"),
        (["--width", "720", "--fov", "180", "--baseline", "8", "--delta", "0.5"], "--fov"),
        (["--width", "720", "--fov", "43", "--baseline", "-8", "--delta", "0.5"], "--baseline"),
        (["--width", "720", "--fov", "43", "--baseline", "8", "--delta", "nan"], "--delta"),
        ([*RIG, "--delta", "0.5", "--tolerance", "0"], "--tolerance"),
        ([*RIG, "--delta", "0.5", "--range", "x"], "--range"),
        ([*RIG], "--delta"),
    ],
)
def test_bad_arguments_exit_2_naming_the_argument(args: list[str], word: str) -> None:
    proc = _run(*args)
    assert proc.returncode == 2
    assert word in proc.stderr and "Traceback" not in proc.stderr
    assert proc.stdout == ""
