"""edge/recording/live.py (`run --record`): pairs recorded as processed and replayed back; a full disk
stops the recording with fault 72 and never blocks the caller; `run --record` onto a used directory
exits 73 before anything runs."""

from __future__ import annotations

import argparse
import errno
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

import edge.recording.format as fmt
from drivers.camera.base import FramePair
from drivers.camera.replay import ReplaySource
from edge.appliance.health import HealthMonitor, HealthState, standard_stages
from edge.commands import run as run_cmd
from edge.recording.live import LiveRecorder, recording_stage
from edge.sim.scenario import load_scenario


def _recorder(root: Path) -> LiveRecorder:
    scenario = load_scenario("akashi-crossing")
    from edge.config.calibration import Calibration

    return LiveRecorder(root, Calibration(scenario.calibration.rig, scenario.site), 10.0, "test pairs")


def _pair(k: int) -> FramePair:
    rng = np.random.default_rng(k)
    left = rng.integers(0, 255, (480, 720), dtype=np.uint8)
    t = 5_000_000_000 + k * 100_000_000
    return FramePair(left, left[:, ::-1].copy(), t, 40 + k, 41 + k, t - 1000, t + 1000, 0)


def test_processed_pairs_replay_back_rebased_with_their_sequence_numbers(tmp_path: Path) -> None:
    recorder = _recorder(tmp_path / "rec")
    pairs = [_pair(k) for k in range(4)]
    for p in pairs:
        recorder.offer(p)
    recorder.close()
    with ReplaySource(tmp_path / "rec") as source:
        got = list(source)
    assert [g.t_ns for g in got] == [p.t_ns - pairs[0].t_ns for p in pairs]
    assert [(g.seq_left, g.seq_right, g.skew_ns) for g in got] == [(p.seq_left, p.seq_right, 2000)
                                                                    for p in pairs]
    assert all(np.array_equal(g.left, p.left) and np.array_equal(g.right, p.right)
               for g, p in zip(got, pairs, strict=True))
    meta = yaml.safe_load((tmp_path / "rec" / "meta.yaml").read_text())
    assert meta["recorded"]["written"] == 4 and meta["recorded"]["t0_ns"] == pairs[0].t_ns


def test_a_full_disk_is_fault_72_and_offering_never_blocks(tmp_path: Path,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    real, calls = fmt.write_png, [0]

    def full(path: Path, image: np.ndarray) -> None:
        calls[0] += 1
        if calls[0] > 4:  # two pairs fit
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        real(path, image)

    monkeypatch.setattr(fmt, "write_png", full)
    health = HealthMonitor(standard_stages() + (recording_stage(2.0),))
    recorder = _recorder(tmp_path / "rec")
    for k in range(6):
        recorder.offer(_pair(k))
    deadline = time.monotonic() + 10
    while recorder.fault is None and time.monotonic() < deadline:
        recorder.offer(_pair(99))
        time.sleep(0.01)
    t0 = time.monotonic()
    for k in range(50):
        recorder.offer(_pair(k))  # after the failure: returns at once, nothing queued
    assert time.monotonic() - t0 < 0.5
    for stage in ("camera_left", "camera_right", "processing"):
        health.beat(stage)
    recorder.beat(health)
    snap = health.snapshot()
    assert snap.state is HealthState.DEGRADED and snap.fault_code == 72
    assert "No space left on device" in snap.reason and snap.reason.startswith("recording: stopped")
    recorder.close()
    assert recorder.counters["write_failures"] == 1 and recorder.counters["written"] == 2
    with ReplaySource(tmp_path / "rec") as source:
        assert len(list(source)) == 2  # every pair before the failure, complete


def test_run_record_into_a_used_directory_exits_73_before_running(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    config = tmp_path / "run.yaml"
    config.write_text(yaml.safe_dump({"outputs": {"modbus": {"tcp": {"enabled": False}}}}))
    used = tmp_path / "used"
    used.mkdir()
    (used / "notes.txt").write_text("not a recording")
    parser = argparse.ArgumentParser()
    run_cmd.add_arguments(parser)
    args = parser.parse_args(["--config", str(config), "--record", str(used), "--seconds", "30"])
    t0 = time.monotonic()
    assert run_cmd.run(args) == 73
    assert time.monotonic() - t0 < 20
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--record" in err[0] and "not empty" in err[0]
