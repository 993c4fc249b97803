"""edge.recording.capture: pairs all or nothing on disk, the clock rebased to 0, sequence numbers kept, the
queue policy (live: drop the oldest queued pair and count it; otherwise block), and a full disk at every
step (left PNG, right PNG, frames.csv row) leaving a recording the replay driver reads."""

from __future__ import annotations

import errno
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import edge.recording.capture as rec
import edge.recording.format as fmt
from drivers.camera.base import FramePair
from drivers.camera.replay import ReplaySource, read_frames
from drivers.camera.virtual import VirtualSource

W, H = 64, 48
T0_NS = 5_000_000_000  # an absolute (monotonic-like) first stamp, to see the rebasing


def _meta() -> dict:
    return {"format": 1, "fps": 10.0, "width": W, "height": H, "calibration": None, "site": None,
            "notes": "test"}


def _pair(k: int, seq_offset: int = 0) -> FramePair:
    left = np.full((H, W), k % 256, np.uint8)
    right = np.full((H, W), (k + 1) % 256, np.uint8)
    t_ns = T0_NS + k * 100_000_000
    return FramePair(left, right, t_ns, k + seq_offset, k + seq_offset, t_ns - 1000, t_ns + 2000)


def _source(n: int) -> VirtualSource:
    return VirtualSource([_pair(k) for k in range(n)])


def _files(tmp_path: Path) -> fmt.RecordingWriter:
    return fmt.RecordingWriter(tmp_path / "rec", _meta())


def _replayed(root: Path) -> list[FramePair]:
    with ReplaySource(root) as src:
        return list(src)


def test_pairs_are_rebased_to_zero_and_replay_reads_them_exactly(tmp_path: Path) -> None:
    files = _files(tmp_path)
    result = rec.record(_source(6), files, live=False, frames=10)
    files.close()
    assert (result.reason, result.written, result.captured) == (rec.SOURCE_ENDED, 6, 6)
    assert result.t0_ns == T0_NS
    rows = read_frames(files.root)
    assert [r[0] for r in rows] == list(range(6))
    assert [r[1] for r in rows] == [k * 100_000_000 for k in range(6)]
    assert all((r[4] - r[1], r[5] - r[1]) == (-1000, 2000) for r in rows)  # the skew survives
    pairs = _replayed(files.root)
    assert len(pairs) == 6 and all(np.array_equal(p.left, _pair(k).left) for k, p in enumerate(pairs))
    assert not list(files.root.rglob("*" + fmt.PART))


def test_frames_limit_stops_at_n(tmp_path: Path) -> None:
    files = _files(tmp_path)
    result = rec.record(_source(20), files, live=False, frames=4)
    files.close()
    assert (result.reason, result.written) == (rec.DONE_FRAMES, 4)
    assert len(read_frames(files.root)) == 4


def test_stop_event_ends_the_recording(tmp_path: Path) -> None:
    stop = threading.Event()
    stop.set()
    files = _files(tmp_path)
    result = rec.record(_source(5), files, live=False, frames=5, stop=stop)
    files.close()
    assert (result.reason, result.written) == (rec.SIGNALLED, 0)
    assert read_frames(files.root) == []


def _slow_png(monkeypatch: pytest.MonkeyPatch, delay_s: float) -> None:
    real = fmt.write_png

    def slow(path: Path, image: np.ndarray) -> None:
        time.sleep(delay_s)
        real(path, image)

    monkeypatch.setattr(fmt, "write_png", slow)


def test_live_source_drops_the_oldest_pair_when_the_writer_lags_and_the_gap_shows(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _slow_png(monkeypatch, 0.01)
    monkeypatch.setattr(rec, "queue_capacity", lambda w, h: 4)
    files = _files(tmp_path)
    result = rec.record(_source(60), files, live=True, frames=60)
    files.close()
    assert result.dropped_by_writer > 0
    assert result.written + result.dropped_by_writer == 60
    with ReplaySource(files.root) as src:
        assert len(list(src)) == result.written
        assert src.dropped == result.dropped_by_writer  # every loss is a sequence gap replay counts
    rows = read_frames(files.root)
    assert (rows[0][2], rows[-1][2]) == (0, 59)  # the first and the newest pair always reach the disk


def test_a_non_live_source_waits_for_the_writer_and_loses_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _slow_png(monkeypatch, 0.005)
    monkeypatch.setattr(rec, "queue_capacity", lambda w, h: 2)
    files = _files(tmp_path)
    result = rec.record(_source(20), files, live=False, frames=20)
    files.close()
    assert (result.written, result.dropped_by_writer) == (20, 0)


@pytest.mark.parametrize("fail_call", [7, 8])  # the left PNG of pair 3, or its right PNG (left done)
def test_a_full_disk_keeps_every_pair_before_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fail_call: int
) -> None:
    real, calls = fmt.write_png, [0]

    def full(path: Path, image: np.ndarray) -> None:
        calls[0] += 1
        if calls[0] >= fail_call:
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        real(path, image)

    monkeypatch.setattr(fmt, "write_png", full)
    files = _files(tmp_path)
    result = rec.record(_source(10), files, live=False, frames=10)
    files.close()
    assert result.reason == rec.WRITE_FAILED
    assert isinstance(result.error, OSError) and result.error.errno == errno.ENOSPC
    assert result.written == 3
    assert len(_replayed(files.root)) == 3
    assert sorted(p.name for p in (files.root / "left").iterdir()) == [f"{k:06d}.png" for k in range(3)]
    assert sorted(p.name for p in (files.root / "right").iterdir()) == [f"{k:06d}.png" for k in range(3)]


def test_a_row_cut_short_by_a_full_disk_is_truncated_away(tmp_path: Path) -> None:
    files = _files(tmp_path)
    files.add(0, _pair(0))

    def half_then_full(fd: int, data: memoryview) -> int:
        if len(data) > 3:
            import os
            return os.write(fd, data[:3])
        raise OSError(errno.ENOSPC, "No space left on device")

    files._write_some = half_then_full  # type: ignore[method-assign]
    with pytest.raises(OSError):
        files.add(1, _pair(1))
    files.close()
    assert len(read_frames(files.root)) == 1  # header and one complete row: the file still parses
    assert not (files.root / "left" / "000001.png").exists()


def test_meta_update_merges_keys_and_survives_a_refusal(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                                                        ) -> None:
    files = _files(tmp_path)
    assert files.update_meta(recorded={"pairs": 0})
    assert ReplaySource(files.root).meta["recorded"] == {"pairs": 0}

    def refuse(path: Path, data: bytes) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(fmt, "write_file_atomic", refuse)
    assert not files.update_meta(recorded={"pairs": 5})
    files.close()
    assert ReplaySource(files.root).meta["recorded"] == {"pairs": 0}


def test_a_pair_of_the_wrong_size_stops_the_recording(tmp_path: Path) -> None:
    small = FramePair(np.zeros((10, 10), np.uint8), np.zeros((10, 10), np.uint8), 0, 0, 0, 0, 0)
    files = _files(tmp_path)
    result = rec.record(VirtualSource([small]), files, live=False, frames=1)
    files.close()
    assert (result.reason, result.written) == (rec.WRONG_SIZE, 0)
    assert "10x10" in str(result.error)


def test_queue_capacity_is_bounded_by_memory() -> None:
    assert rec.queue_capacity(720, 480) == 64
    assert 4 <= rec.queue_capacity(2048, 1536) < 64
    assert rec.queue_capacity(100_000, 100_000) == 4


class _Flaky(VirtualSource):
    """Times out twice (a camera away), then delivers; then fails for good."""

    def __init__(self, n: int) -> None:
        super().__init__([_pair(k) for k in range(n)])
        self.timeouts = 2

    def read(self) -> FramePair | None:
        if self.timeouts:
            self.timeouts -= 1
            raise TimeoutError("no pair within 2 s")
        pair = super().read()
        if pair is None:
            raise RuntimeError("camera gone for good")
        return pair


def test_read_timeouts_are_retried_and_a_failing_source_keeps_what_was_captured(tmp_path: Path) -> None:
    files = _files(tmp_path)
    result = rec.record(_Flaky(3), files, live=True, frames=10)
    files.close()
    assert (result.reason, result.read_timeouts, result.written) == (rec.SOURCE_FAILED, 2, 3)
    assert "gone for good" in str(result.error)
    assert len(_replayed(files.root)) == 3
