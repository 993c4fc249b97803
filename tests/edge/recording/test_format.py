"""Recordings: written by the simulator, read back by drivers/camera/replay.py, bit for bit.

- same seed -> byte-identical recording (whatever the number of workers);
  another seed -> different noise, same geometry and truth;
- write -> replay round trip preserves pixels, sequence numbers, timestamps;
- the `simulate` command writes it and reports scenario errors as exit 78.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
import yaml

from drivers.camera.base import FramePair
from drivers.camera.replay import ReplaySource
from edge.cli import main
from edge.config.calibration import calibration_from_dict
from edge.errors import EX_CONFIG
from edge.recording.format import RecordingWriter, build_meta, read_truth
from edge.sim.render_recording import write_recording
from edge.sim.scenario import scenario_from_dict
from edge.sim.simulator import Simulation


def _small(sim_tools, **extra) -> dict:
    cal = sim_tools.calibration("ideal-720")
    w, h, f = 240, 160, 300.0
    cam = {
        "model": "pinhole",
        "fx": f,
        "fy": f,
        "cx": (w - 1) / 2,
        "cy": (h - 1) / 2,
        "dist": [0.0] * 5,
        "rotation_deg": [-1.0, 0.0, 0.0],
    }
    cal.update(image={"width": w, "height": h}, cameras={"left": cam, "right": cam})
    ships = [sim_tools.ship(7, "coaster", 80.0, [(-100.0, 900.0), (100.0, 950.0)], speed_kn=15.0)]
    return sim_tools.scenario(
        cal,
        ships,
        duration_s=0.6,
        glints={"rate_hz": 20.0, "near_ship": 0.5},
        trigger={"jitter_ns": 2e5, "drop_rate": 0.2},
        **extra,
    )


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_same_seed_same_bytes_other_seed_other_noise(sim_tools, tmp_path: Path) -> None:
    scenario = scenario_from_dict(_small(sim_tools), tmp_path / "small.yaml")
    write_recording(Simulation(scenario, seed=3), tmp_path / "a", jobs=1)
    write_recording(Simulation(scenario, seed=3), tmp_path / "b", jobs=2)
    write_recording(Simulation(scenario, seed=4), tmp_path / "c", jobs=1)
    a, b, c = (_files(tmp_path / n) for n in "abc")
    assert a == b
    assert len(a) > 6
    pngs = [k for k in a if k.endswith(".png") and k in c]
    assert pngs and all(a[k] != c[k] for k in pngs)  # independent noise in every image
    with open(tmp_path / "a" / "frames.csv") as f:
        rows = list(csv.DictReader(f))
    skew = [int(r["t_right_ns"]) - int(r["t_left_ns"]) for r in rows]
    assert len(set(skew)) > 1  # trigger jitter is in the timestamps


def test_simulated_recording_replays_exactly(sim_tools, tmp_path: Path) -> None:
    scenario = scenario_from_dict(_small(sim_tools), tmp_path / "small.yaml")
    sim = Simulation(scenario, seed=5)
    written = write_recording(sim, tmp_path / "rec", jobs=1)
    source = ReplaySource(tmp_path / "rec")
    pairs = list(source)
    assert len(pairs) == written == len(sim.pairs) and source.skipped == 0
    inner_drops = sim.pairs[-1].k - sim.pairs[0].k + 1 - written
    assert written < sim.n_frames and source.dropped == inner_drops  # drops between pairs are seq gaps
    for pair, trig in zip(pairs, sim.pairs, strict=True):
        left, right = sim.images(trig.k)
        assert np.array_equal(pair.left, left) and np.array_equal(pair.right, right)
        assert pair.left.dtype == np.uint8 and pair.left.shape == (160, 240)
        assert (pair.t_ns, pair.seq_left, pair.seq_right, pair.t_left_ns, pair.t_right_ns) == (
            trig.t_ns,
            trig.seq_left,
            trig.seq_right,
            trig.t_left_ns,
            trig.t_right_ns,
        )
    cal = calibration_from_dict(source.meta["calibration"], "meta.yaml", "calibration")
    assert cal.rig == scenario.calibration.rig  # the calibration survives the YAML round trip exactly
    truth = read_truth(tmp_path / "rec")
    assert list(truth) == [7] and len(truth[7]) == written
    expected = sim.truth(sim.pairs[-1])[0][1]
    assert np.allclose(truth[7][-1, 1:], expected, atol=1e-6)


def test_writer_round_trip_of_arbitrary_pixels(tmp_path: Path) -> None:
    cal = calibration_from_dict(
        yaml.safe_load((Path(__file__).parents[3] / "config/calibration/akashi-poly10.yaml").read_text()),
        "akashi-poly10.yaml",
    )
    rng = np.random.default_rng(0)
    frames = [
        (rng.integers(0, 256, (480, 720), dtype=np.uint8), rng.integers(0, 256, (480, 720), dtype=np.uint8))
        for _ in range(3)
    ]
    stamps = [(0, 10**18 + 5, 41, 977, 10**18 + 3, 10**18 + 11), (1, 10**18 + 100_000_007, 43, 979, 1, 2**62)]
    with RecordingWriter(tmp_path / "r", build_meta(cal, 12.5, "test")) as w:
        for (index, *rest), (left, right) in zip(stamps, frames, strict=False):
            w.add(index, FramePair(left, right, *rest))
    pairs = list(ReplaySource(tmp_path / "r"))
    assert [(p.t_ns, p.seq_left, p.seq_right, p.t_left_ns, p.t_right_ns) for p in pairs] == [
        s[1:] for s in stamps
    ]
    for pair, (left, right) in zip(pairs, frames, strict=False):
        assert np.array_equal(pair.left, left) and np.array_equal(pair.right, right)
    with pytest.raises(FileExistsError):
        RecordingWriter(tmp_path / "r", build_meta(cal, 12.5, "again"))


def test_simulate_command_writes_a_recording(sim_tools, tmp_path: Path, capsys) -> None:
    path = tmp_path / "small.yaml"
    path.write_text(yaml.safe_dump(_small(sim_tools)))
    assert main(["simulate", str(path), "--out", str(tmp_path / "out"), "--seed", "2", "--frames", "3"]) == 0
    err = capsys.readouterr().err
    assert "[" not in err  # no progress bar when stderr is not a terminal
    meta = yaml.safe_load((tmp_path / "out" / "meta.yaml").read_text())
    assert meta["format"] == 1 and meta["seed"] == 2 and meta["triggers"] == 3
    assert meta["width"] == 240 and meta["site"]["height_m"] == 25.0
    assert len(list(ReplaySource(tmp_path / "out"))) <= 3
    # existing output without --force is refused; with --force it is replaced
    assert main(["simulate", str(path), "--out", str(tmp_path / "out"), "--frames", "1"]) != 0
    assert main(["simulate", str(path), "--out", str(tmp_path / "out"), "--frames", "1", "--force"]) == 0


def test_simulate_command_reports_scenario_errors_as_exit_78(sim_tools, tmp_path: Path, capsys) -> None:
    data = _small(sim_tools)
    data["ships"][0]["track"]["speed_kn"] = [-3.0]
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["simulate", str(path), "--out", str(tmp_path / "out")]) == EX_CONFIG
    err = capsys.readouterr().err
    assert "bad.yaml" in err and "ships[0].track.speed_kn[0]" in err
    assert main(["simulate", "no-such-scenario", "--out", str(tmp_path / "out")]) == EX_CONFIG
    assert "akashi-crossing" in capsys.readouterr().err  # the known names are listed
