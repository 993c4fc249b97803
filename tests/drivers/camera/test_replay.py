"""drivers/camera/replay.py against recordings written by hand (independent of the simulator's writer)."""

from __future__ import annotations

import logging
from pathlib import Path

import cv2
import numpy as np
import pytest

from drivers.camera.replay import RecordingFormatError, ReplaySource

HEADER = "index,t_ns,seq_left,seq_right,t_left_ns,t_right_ns\n"


def make_recording(root: Path, n: int = 5, fmt: object = 1, period_ns: int = 100_000_000, gaps=()) -> list:
    (root / "left").mkdir(parents=True)
    (root / "right").mkdir()
    (root / "meta.yaml").write_text(f"format: {fmt}\nfps: 10.0\nwidth: 32\nheight: 24\nnotes: hand-made\n")
    rng = np.random.default_rng(1)
    rows, images, seq = [], [], 100
    for i in range(n):
        seq += 1 + (i in gaps)
        left = rng.integers(0, 256, (24, 32), dtype=np.uint8)
        right = rng.integers(0, 256, (24, 32, 3), dtype=np.uint8)  # BGR is allowed too
        cv2.imwrite(str(root / "left" / f"{i:06d}.png"), left)
        cv2.imwrite(str(root / "right" / f"{i:06d}.png"), right)
        t = 5_000_000_000 + i * period_ns
        rows.append((i, t, seq, seq + 7, t - 1000, t + 2500))
        images.append((left, right))
    (root / "frames.csv").write_text(HEADER + "".join(",".join(map(str, r)) + "\n" for r in rows))
    return list(zip(rows, images, strict=True))


def test_pairs_come_back_exactly(tmp_path: Path) -> None:
    expected = make_recording(tmp_path / "rec", gaps={3})
    source = ReplaySource(tmp_path / "rec")
    assert source.meta["notes"] == "hand-made" and source.info["pairs"] == 5
    pairs = list(source)
    assert len(pairs) == 5 and source.skipped == 0 and source.dropped == 1
    for pair, ((_, t, sl, sr, tl, tr), (left, right)) in zip(pairs, expected, strict=True):
        assert (pair.t_ns, pair.seq_left, pair.seq_right, pair.t_left_ns, pair.t_right_ns) == (
            t,
            sl,
            sr,
            tl,
            tr,
        )
        assert np.array_equal(pair.left, left) and np.array_equal(pair.right, right)
        assert pair.skew_ns == 3500
    assert source.read() is None


def test_missing_and_corrupt_images_are_skipped_with_a_warning(tmp_path: Path, caplog) -> None:
    make_recording(tmp_path / "rec")
    (tmp_path / "rec" / "left" / "000001.png").unlink()
    (tmp_path / "rec" / "right" / "000003.png").write_bytes(b"\x89PNG\r\n\x1a\n garbage")
    with caplog.at_level(logging.WARNING, logger="drivers.camera.replay"):
        pairs = list(ReplaySource(tmp_path / "rec"))
    assert [p.seq_left for p in pairs] == [101, 103, 105]
    text = caplog.text
    assert "left/000001.png" in text and "right/000003.png" in text


def test_skip_counter(tmp_path: Path) -> None:
    make_recording(tmp_path / "rec")
    (tmp_path / "rec" / "right" / "000000.png").unlink()
    source = ReplaySource(tmp_path / "rec")
    list(source)
    assert source.skipped == 1


@pytest.mark.parametrize("fmt", [2, 0, '"1"', "true"])
def test_other_format_versions_are_refused(tmp_path: Path, fmt: object) -> None:
    make_recording(tmp_path / "rec", fmt=fmt)
    with pytest.raises(RecordingFormatError, match="format"):
        ReplaySource(tmp_path / "rec")


def test_not_a_recording(tmp_path: Path) -> None:
    with pytest.raises(RecordingFormatError, match="no meta.yaml"):
        ReplaySource(tmp_path)
    make_recording(tmp_path / "rec")
    (tmp_path / "rec" / "frames.csv").write_text("index,t_ns\n0,1\n")
    with pytest.raises(RecordingFormatError, match="header"):
        ReplaySource(tmp_path / "rec")
    (tmp_path / "rec" / "frames.csv").write_text(HEADER + "0,1,2,3,x,5\n")
    with pytest.raises(RecordingFormatError, match="line 2"):
        ReplaySource(tmp_path / "rec")


class FakeClock:
    def __init__(self) -> None:
        self.now = 1_000
        self.sleeps: list[float] = []

    def __call__(self) -> int:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.now += round(seconds * 1e9)


def test_paced_replay_follows_the_recorded_intervals(tmp_path: Path) -> None:
    make_recording(tmp_path / "rec", n=4, period_ns=250_000_000)
    clock = FakeClock()
    source = ReplaySource(tmp_path / "rec", pace=True, speed=2.0, clock=clock, sleep=clock.sleep)
    released = []
    for _ in source:
        released.append(clock.now)
        clock.now += 10_000_000  # the consumer takes 10 ms per pair
    assert np.allclose(np.diff(released), 125_000_000)  # 250 ms recorded, played twice as fast
    assert clock.sleeps and all(s > 0 for s in clock.sleeps)


def test_unpaced_replay_never_sleeps_and_loop_keeps_time_increasing(tmp_path: Path) -> None:
    make_recording(tmp_path / "rec", n=3)
    clock = FakeClock()
    source = ReplaySource(tmp_path / "rec", loop=True, clock=clock, sleep=clock.sleep)
    stamps = [source.read().t_ns for _ in range(7)]
    assert clock.sleeps == []
    assert np.all(np.diff(stamps) == 100_000_000)  # seamless across the loop
    assert source.dropped == 0
    source.close()
    assert source.read() is None
