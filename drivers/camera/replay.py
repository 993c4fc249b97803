"""Frame pairs from a recording directory (the format of docs/recordings.md), optionally at the recorded pace.

```
meta.yaml    format: 1, fps, width, height, calibration: {...}, site: {...}, notes
frames.csv   index,t_ns,seq_left,seq_right,t_left_ns,t_right_ns
left/000000.png, right/000000.png
```

This driver parses the format itself (drivers never import edge) and hands
`meta` (meta.yaml's raw mapping) to the caller, who builds the calibration.
A recording with another format version, or without meta.yaml/frames.csv,
is refused with `RecordingFormatError`. A missing or unreadable PNG is
skipped: counted in `skipped` and logged with the file name, the rest plays.
Jumps in the sequence numbers (pairs the recorder lost) add to `dropped`.
A pair whose timestamp is not later than the last pair released (a clock
step in the recorder, rows out of order), or lies further ahead than its
sequence numbers allow (more than `AHEAD_SLACK_FRAMES` frame periods beyond
the sequence step, when meta.yaml gives fps), is skipped, counted in
`out_of_order` and logged once: the filters downstream assume time moves
forward at the frame rate, and one stamp far ahead would make every later
pair look like it went back.

Pixels come back exactly as stored (IMREAD_UNCHANGED: grey stays 2-D), and
timestamps and sequence numbers exactly as in frames.csv. With `pace=True`
pairs are released at their recorded intervals (scaled by `speed`), measured
on `clock` from the first pair; otherwise as fast as they are read.
"""

from __future__ import annotations

import csv
import logging
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import yaml

from drivers.camera.base import FramePair, FramePairSource

log = logging.getLogger(__name__)

SUPPORTED_FORMAT = 1
AHEAD_SLACK_FRAMES = 10
FRAMES_HEADER = ("index", "t_ns", "seq_left", "seq_right", "t_left_ns", "t_right_ns")


class RecordingFormatError(Exception):
    """The directory is not a recording this version can read (the CLI reports it, exit 78)."""

    def __init__(self, path: str | Path, problem: str) -> None:
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{path}: {problem}")


def read_meta(root: str | Path) -> dict:
    """meta.yaml of a recording, checked for the format version."""
    path = Path(root) / "meta.yaml"
    try:
        meta = yaml.safe_load(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise RecordingFormatError(root, "not a recording (no meta.yaml)") from None
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise RecordingFormatError(path, f"unreadable meta.yaml ({exc})") from None
    if not isinstance(meta, dict):
        raise RecordingFormatError(path, "meta.yaml must be a mapping")
    version = meta.get("format")
    if version != SUPPORTED_FORMAT or isinstance(version, bool):
        raise RecordingFormatError(
            path, f"format {version!r} is not supported (this version reads format {SUPPORTED_FORMAT})"
        )
    return meta


def read_frames(root: str | Path) -> list[tuple[int, ...]]:
    """frames.csv rows as integer tuples in FRAMES_HEADER order."""
    path = Path(root) / "frames.csv"
    try:
        with open(path, encoding="utf-8", newline="") as f:
            reader = csv.reader(f)
            header = tuple(next(reader, ()))
            if header != FRAMES_HEADER:
                raise RecordingFormatError(path, f"expected the header {','.join(FRAMES_HEADER)}")
            rows = []
            for line, row in enumerate(reader, start=2):
                try:
                    values = tuple(int(v) for v in row)
                except ValueError:
                    values = ()
                if len(values) != len(FRAMES_HEADER):
                    raise RecordingFormatError(path, f"line {line}: expected {len(FRAMES_HEADER)} integers")
                rows.append(values)
    except FileNotFoundError:
        raise RecordingFormatError(root, "not a recording (no frames.csv)") from None
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise RecordingFormatError(path, f"unreadable frames.csv ({exc})") from None
    return rows


class ReplaySource(FramePairSource):
    """Plays a recording directory as a frame-pair source."""

    def __init__(
        self,
        root: str | Path,
        *,
        pace: bool = False,
        speed: float = 1.0,
        loop: bool = False,
        clock: Callable[[], int] = time.monotonic_ns,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        super().__init__()
        if speed <= 0.0:
            raise ValueError("speed must be positive")
        self.root = Path(root)
        self.meta = read_meta(self.root)
        self.rows = read_frames(self.root)
        self.pace, self.speed, self.loop = pace, speed, loop
        self._clock, self._sleep = clock, sleep
        self._next = 0
        self._start: tuple[int, int] | None = None  # (wall clock, t_ns) of the first pair released
        self._offset_ns = 0  # added to timestamps on each loop so time keeps increasing
        self._last_seq: tuple[int, int] | None = None
        self._last_t_ns: int | None = None
        self._last_released_seq = (0, 0)
        self.out_of_order = 0  # pairs skipped because their timestamp did not move forward

    @property
    def info(self) -> dict:
        return {k: self.meta.get(k) for k in ("fps", "width", "height")} | {"pairs": len(self.rows)}

    def __len__(self) -> int:
        return len(self.rows)

    def read(self) -> FramePair | None:
        while not self.closed:
            if self._next >= len(self.rows):
                if not (self.loop and self.rows):
                    return None
                span = self.rows[-1][1] - self.rows[0][1]
                period = span // max(len(self.rows) - 1, 1)
                self._offset_ns += span + period
                self._next, self._last_seq = 0, None
            index, t_ns, seq_l, seq_r, t_l, t_r = self.rows[self._next]
            self._next += 1
            self._count_gap(seq_l, seq_r)
            if not self._in_order(t_ns + self._offset_ns, seq_l, seq_r):
                self._count_out_of_order(index, t_ns + self._offset_ns)
                continue
            left, right = self._image("left", index), self._image("right", index)
            if left is None or right is None:
                self.skipped += 1
                continue
            off = self._offset_ns
            pair = FramePair(left, right, t_ns + off, seq_l, seq_r, t_l + off, t_r + off)
            self._last_t_ns, self._last_released_seq = pair.t_ns, (seq_l, seq_r)
            self._wait(pair.t_ns)
            return pair
        return None

    def _in_order(self, t_ns: int, seq_l: int, seq_r: int) -> bool:
        if self._last_t_ns is None:
            return True
        if t_ns <= self._last_t_ns:
            return False
        fps = self.meta.get("fps")
        if isinstance(fps, bool) or not isinstance(fps, int | float) or not fps > 0:
            return True
        steps = max(seq_l - self._last_released_seq[0], seq_r - self._last_released_seq[1], 1)
        return t_ns - self._last_t_ns <= (steps + AHEAD_SLACK_FRAMES) * 1e9 / fps

    def _count_out_of_order(self, index: int, t_ns: int) -> None:
        if self.out_of_order == 0:
            log.warning("recording %s: skipping pair %d, its time %d ns does not follow the previous "
                        "pair's %d ns (counted from now on)", self.root, index, t_ns, self._last_t_ns)
        self.out_of_order += 1

    def _count_gap(self, seq_l: int, seq_r: int) -> None:
        if self._last_seq is not None:
            gap = max(seq_l - self._last_seq[0], seq_r - self._last_seq[1]) - 1
            self.dropped += max(gap, 0)
        self._last_seq = (seq_l, seq_r)

    def _image(self, side: str, index: int):
        path = self.root / side / f"{index:06d}.png"
        image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED) if path.is_file() else None
        if image is None:
            log.warning("recording %s: skipping pair %d, %s is missing or unreadable", self.root, index, path)
        return image

    def _wait(self, t_ns: int) -> None:
        if not self.pace:
            return
        now = self._clock()
        if self._start is None:
            self._start = (now, t_ns)
            return
        due = self._start[0] + (t_ns - self._start[1]) / self.speed
        if due > now:
            self._sleep((due - now) / 1e9)
