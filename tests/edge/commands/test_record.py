"""`mast-stereo record`: a virtual source recorded and replayed in full; a full disk (exit 74) and a
SIGTERM (exit 143) leave a recording replay reads up to the last complete pair; --seconds stops in
time; a bad configuration exits 78 before anything is written; an existing recording needs --force."""

from __future__ import annotations

import errno
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from helpers import ROOT, run_cli

import edge.recording.format as fmt
from drivers.camera.replay import read_frames
from edge.cli import main
from edge.replay import replay


def _config(tmp_path: Path, cameras: dict, name: str = "record.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump({"version": 1, "cameras": cameras}), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def akashi(recording) -> Path:
    return recording("akashi-crossing", 30)


def _replay_config(tmp_path: Path, akashi: Path, pace: bool = False, loop: bool = False) -> Path:
    return _config(tmp_path, {"kind": "replay", "path": str(akashi), "pace": pace, "loop": loop})


def test_virtual_cameras_recorded_then_replayed_in_full(tmp_path: Path) -> None:
    config = _config(tmp_path, {"kind": "virtual", "scenario": "akashi-crossing", "pace": False,
                                "loop": False})
    out = tmp_path / "rec"
    done = run_cli("record", "--config", config, "--out", out, "--frames", "4")
    assert done.returncode == 0, done.stderr
    assert "4 pairs written" in done.stderr and "stopped: frames" in done.stderr
    rows = read_frames(out)
    assert [r[0] for r in rows] == [0, 1, 2, 3]
    t_ns = [r[1] for r in rows]
    assert t_ns[0] == 0 and all(b > a for a, b in zip(t_ns, t_ns[1:], strict=False))
    assert [(r[2], r[3]) for r in rows] == [(0, 0), (1, 1), (2, 2), (3, 3)]
    meta = yaml.safe_load((out / "meta.yaml").read_text())
    assert (meta["format"], meta["fps"], meta["width"], meta["height"]) == (1, 10.0, 720, 480)
    assert meta["calibration"]["baseline_m"] == 8.14 and meta["site"]["lat_deg"] == 34.63
    assert "virtual scenario 'akashi-crossing'" in meta["notes"] and "UTC" in meta["notes"]
    assert meta["recorded"]["pairs"] == 4 and meta["recorded"]["stopped"] == "frames"
    summary = replay(out)
    assert (summary.pairs_in_recording, summary.pipeline.pairs, summary.pipeline.processed) == (4, 4, 4)
    assert (summary.skipped_pairs, summary.dropped_pairs) == (0, 0)


def test_a_recorded_recording_is_the_same_pixels(tmp_path: Path, akashi: Path) -> None:
    out = tmp_path / "copy"
    assert main(["record", "--config", str(_replay_config(tmp_path, akashi)), "--out", str(out),
                 "--frames", "5"]) == 0
    for k in range(5):
        for side in ("left", "right"):
            name = f"{side}/{k:06d}.png"
            assert np.array_equal(cv2.imread(str(out / name), -1), cv2.imread(str(akashi / name), -1))
    assert [r[2:4] for r in read_frames(out)] == [r[2:4] for r in read_frames(akashi)[:5]]


def test_a_full_disk_exits_74_and_keeps_the_pairs_before_it(
    tmp_path: Path, akashi: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    real, calls = fmt.write_png, [0]

    def full_after_three_pairs(path: Path, image: np.ndarray) -> None:
        calls[0] += 1
        if calls[0] > 2 * 3:
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        real(path, image)

    monkeypatch.setattr(fmt, "write_png", full_after_three_pairs)
    out = tmp_path / "full"
    status = main(["record", "--config", str(_replay_config(tmp_path, akashi)), "--out", str(out),
                   "--frames", "20"])
    assert status == 74
    err = capsys.readouterr().err
    assert "stopped: write failed" in err and "No space left on device" in err
    summary = replay(out)
    assert (summary.pairs_in_recording, summary.pipeline.pairs, summary.skipped_pairs) == (3, 3, 0)
    assert not list(out.rglob("*.part"))


def test_seconds_stops_in_time(tmp_path: Path, akashi: Path) -> None:
    config = _replay_config(tmp_path, akashi, pace=True, loop=True)  # 10 pairs/s
    start = time.monotonic()
    assert main(["record", "--config", str(config), "--out", str(tmp_path / "s"), "--seconds", "1"]) == 0
    elapsed_s = time.monotonic() - start
    assert elapsed_s < 2.5
    assert 8 <= len(read_frames(tmp_path / "s")) <= 13


def test_sigterm_stops_cleanly_with_a_readable_recording(tmp_path: Path, akashi: Path) -> None:
    config = _replay_config(tmp_path, akashi, pace=True, loop=True)
    out = tmp_path / "term"
    proc = subprocess.Popen([sys.executable, "-m", "edge.cli", "record", "--config", str(config),
                             "--out", str(out), "--seconds", "60"], cwd=ROOT,
                            stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            frames = out / "frames.csv"
            if frames.is_file() and frames.read_text().count("\n") > 3:
                break
            time.sleep(0.05)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 128 + signal.SIGTERM, err
    assert "stopped: signal" in err
    meta = yaml.safe_load((out / "meta.yaml").read_text())
    assert meta["recorded"]["stopped"] == "signal"
    summary = replay(out)
    assert summary.pipeline.pairs == summary.pairs_in_recording == meta["recorded"]["pairs"] >= 3


def test_a_bad_config_exits_78_before_anything_is_written(tmp_path: Path) -> None:
    missing = _config(tmp_path, {"kind": "replay", "path": str(tmp_path / "nowhere")}, "missing.yaml")
    bad_key = tmp_path / "bad.yaml"
    bad_key.write_text("version: 1\npipeline: {window: 4}\n", encoding="utf-8")
    for config in (missing, bad_key):
        out = tmp_path / f"out-{config.stem}"
        done = run_cli("record", "--config", config, "--out", out, "--frames", "3")
        assert done.returncode == 78, done.stderr
        assert len(done.stderr.strip().splitlines()) == 1 and "configuration error" in done.stderr
        assert not out.exists()


def test_an_existing_recording_needs_force(tmp_path: Path, akashi: Path) -> None:
    config, out = str(_replay_config(tmp_path, akashi)), str(tmp_path / "again")
    assert main(["record", "--config", config, "--out", out, "--frames", "2"]) == 0
    assert main(["record", "--config", config, "--out", out, "--frames", "3"]) == 73
    assert len(read_frames(out)) == 2
    assert main(["record", "--config", config, "--out", out, "--frames", "3", "--force"]) == 0
    assert len(read_frames(out)) == 3


def test_a_limit_is_required(tmp_path: Path) -> None:
    done = run_cli("record", "--config", "config/demo.yaml", "--out", tmp_path / "x")
    assert done.returncode == 2 and "--seconds" in done.stderr
