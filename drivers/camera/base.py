"""The frame-pair source contract every camera driver implements.

A `FramePairSource` hands the pipeline one `FramePair` at a time: the two
8-bit images, the pair timestamp `t_ns` (what pairing and tracking use), each
camera's own sequence number and exposure timestamp (so the consumer can see
trigger skew and dropped frames), plus two counters:

- ``skipped``: pairs the source had but could not deliver (an unreadable PNG
  in a recording, a corrupt buffer from a camera);
- ``dropped``: pairs the source knows were never produced or were thrown away
  (gaps in the sequence numbers, frames abandoned to keep up in real time).

Live sources also give each pair ``realtime_offset_ns`` (CLOCK_REALTIME minus
CLOCK_MONOTONIC, sampled as the pair is made), so ``t_utc_ns`` = the exposure
instant in UTC even if NTP steps the wall clock between exposure and output.

Implementations: `v4l2_pair.py` (two V4L2 cameras and a trigger), `replay.py`
(a recording directory, at its recorded pace or as fast as read); the virtual
one, `virtual.py`, wraps a generator such as the simulator. Drivers never import `edge`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterator
from dataclasses import dataclass
from types import TracebackType

import numpy as np


@dataclass(frozen=True, slots=True, eq=False)
class FramePair:
    """One stereo pair: left is the reference image (docs/design.md)."""

    left: np.ndarray  # (H, W) uint8 grey, or (H, W, 3) BGR
    right: np.ndarray
    t_ns: int  # pair timestamp (CLOCK_MONOTONIC when live; the recording's clock in replay)
    seq_left: int  # the left camera's own frame counter
    seq_right: int
    t_left_ns: int  # each camera's exposure timestamp, same clock as t_ns
    t_right_ns: int
    # live sources: CLOCK_REALTIME - CLOCK_MONOTONIC when the pair was made (None: t_ns is not monotonic)
    realtime_offset_ns: int | None = None

    @property
    def skew_ns(self) -> int:
        """Right exposure time minus left: the trigger skew of this pair."""
        return self.t_right_ns - self.t_left_ns

    @property
    def t_utc_ns(self) -> int | None:
        """The exposure instant on CLOCK_REALTIME (UTC ns), for live pairs; None otherwise."""
        return None if self.realtime_offset_ns is None else self.t_ns + self.realtime_offset_ns


class FramePairSource(ABC):
    """Blocking source of frame pairs; iterate it, or call `read()` until it returns None."""

    def __init__(self) -> None:
        self.skipped = 0
        self.dropped = 0
        self._closed = False

    @abstractmethod
    def read(self) -> FramePair | None:
        """The next pair (blocking until it is due); None once the source is exhausted or closed."""

    @property
    def info(self) -> dict:
        """Descriptive facts about the source (fps, width, height, ...); empty if unknown."""
        return {}

    @property
    def closed(self) -> bool:
        return self._closed

    def camera_faults(self) -> dict[str, str | None]:
        """Each camera's current problem ("left"/"right" -> text, None when healthy), for health.
        Sources without per-camera state report none: their failures surface as exceptions."""
        return {"left": None, "right": None}

    @property
    def counters(self) -> dict:
        """Counters for health (V4L2PairSource adds per-camera drops, unpaired frames, reconnects)."""
        return {"dropped_pairs": self.dropped, "skipped_pairs": self.skipped}

    def close(self) -> None:
        """Release files/devices; `read()` returns None afterwards. Safe to call twice."""
        self._closed = True

    def __iter__(self) -> Iterator[FramePair]:
        while (pair := self.read()) is not None:
            yield pair

    def __enter__(self) -> FramePairSource:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()
