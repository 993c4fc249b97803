"""The page's live pictures: both cameras' latest frames, scaled, overlaid and JPEG-encoded, at most
`image_hz` times a second, on the page's own encoder thread.

The processing thread's part is `offer` after each step: one flag test, and only when the encoder
has asked for a frame (at most `image_hz` a second, and only while someone looked at a picture in
the last `VIEWER_IDLE_S`), a handful of references and small lists: the pair (whose images the
pipeline never writes and whose source never reuses: drivers.camera), the fixes and each track's
rectified box and disparity, the last detection boxes. Scaling, drawing and encoding happen here.

Overlays (colours in docs/page.md): the site masks' excluded pixels tinted red, the sea horizon
green (where the rays start to meet the sea, edge.core.masks), the last detections cyan (raw
boxes, left image), each track's box with `id status range +-sigma` (green tracking, yellow
acquiring, grey lost; on the right image shifted by its disparity). The static layers (mask, the
horizon) are computed once, on this thread, at the first picture: start-up pays nothing.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from drivers.camera.base import FramePair
from edge.core.camera import CameraModel
from edge.core.masks import cast_to_sea, horizon_rows
from edge.fix import ShipFix, TrackStatus
from edge.pipeline import Pipeline

HORIZON_BAND_ROWS = 16  # picture rows per lens-model call while finding the horizon
VIEWER_IDLE_S = 5.0  # no picture requested this long: stop asking the processing thread for frames
JPEG_QUALITY = 75
MASK_BGR = np.array((0, 0, 255), np.float32)
MASK_TINT = 0.4
HORIZON_BGR = (0, 255, 0)
DETECTION_BGR = (255, 255, 0)
STATUS_BGR = {TrackStatus.TRACKING: (0, 255, 0), TrackStatus.ACQUIRING: (0, 255, 255),
              TrackStatus.LOST: (160, 160, 160)}


@dataclass(frozen=True)
class TrackBox:
    track_id: int
    status: TrackStatus
    box_rect: tuple[float, float, float, float]  # rectified left image, x0 y0 x1 y1
    disparity_px: float | None


@dataclass(frozen=True)
class Frame:
    """What one picture shows, handed over by the processing thread."""

    pair: FramePair
    fixes: Sequence[ShipFix]
    tracks: tuple[TrackBox, ...]
    detections: tuple[tuple[int, int, int, int], ...]  # raw left image, x0 y0 x1 y1 (end exclusive)
    utc_ns: int


@dataclass(frozen=True)
class Jpeg:
    seq: int  # increases with each new picture
    data: bytes


class Pictures:
    """The latest left and right JPEGs; `run` is the encoder thread's body."""

    def __init__(self, pipeline: Pipeline, search_mask: np.ndarray | None, image_hz: float,
                 width_px: int) -> None:
        self.pipeline = pipeline  # swapped by the daemon on a reload (geometry may change)
        self.search_mask = search_mask
        self.period_s = 1.0 / image_hz
        self.width_px = width_px
        self._want = False  # the encoder asks; the processing thread answers once
        self._frame: Frame | None = None
        self._ready = threading.Event()
        self._last_view_s = -math.inf
        self._static: tuple[int, tuple[int, int], list[np.ndarray | None], np.ndarray | None] | None = None
        self.latest: dict[str, Jpeg] = {}
        self.seq = 0
        self.encode_s = 0.0  # time spent drawing and encoding, for the docs' cost figures
        self.errors = 0

    # ---------------------------------------------------------------- processing thread
    def offer(self, pair: FramePair, fixes: Sequence[ShipFix], utc_ns: int) -> None:
        """After a step: hand the pair over if the encoder asked for one (else return at once)."""
        if not self._want:
            return
        self._want = False
        pipe = self.pipeline
        tracks = tuple(TrackBox(t.id, t.status, tuple(float(v) for v in t.box), t.point.disparity)  # type: ignore[arg-type]
                       for t in pipe.table.tracks)
        self._frame = Frame(pair, fixes, tracks, pipe.last_detections, utc_ns)
        self._ready.set()

    # ---------------------------------------------------------------- HTTP threads
    def get(self, side: str) -> Jpeg | None:
        """The latest picture of `side` ("left", "right"); marks someone as watching."""
        self._last_view_s = time.monotonic()
        return self.latest.get(side)

    # ---------------------------------------------------------------- encoder thread
    def run(self, stop: threading.Event) -> None:
        next_s = time.monotonic()
        while not stop.is_set():
            if time.monotonic() - self._last_view_s > VIEWER_IDLE_S and self.latest:
                stop.wait(0.2)  # nobody watching (the first picture is made regardless)
                continue
            self._ready.clear()
            self._want = True
            if not self._ready.wait(1.0) and not stop.is_set():
                continue  # no pair came (a camera gone): ask again
            frame = self._frame
            if frame is None:
                continue
            t0 = time.perf_counter()
            try:
                self._encode(frame)
            except Exception:  # a drawing bug must not end the pictures (counted, shown in /metrics)
                self.errors += 1
            self.encode_s += time.perf_counter() - t0
            next_s = max(next_s + self.period_s, time.monotonic())
            stop.wait(max(0.0, next_s - time.monotonic()))

    def _encode(self, frame: Frame) -> None:
        pipe = self.pipeline
        rig = pipe.rig
        scale = min(1.0, self.width_px / rig.width)
        size = (max(1, round(rig.width * scale)), max(1, round(rig.height * scale)))
        excluded, horizons = self._layers(pipe, size)
        ranges = {f.track_id: f for f in frame.fixes}
        out = {}
        for side, image in ((0, frame.pair.left), (1, frame.pair.right)):
            small = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
            bgr = cv2.cvtColor(small, cv2.COLOR_GRAY2BGR) if small.ndim == 2 else small.copy()
            if side == 0 and excluded is not None:
                bgr[excluded] = (bgr[excluded] * (1 - MASK_TINT) + MASK_BGR * MASK_TINT).astype(np.uint8)
            line = horizons[side]
            if line is not None:
                cv2.polylines(bgr, [line], False, HORIZON_BGR, 1, cv2.LINE_AA)
            if side == 0:
                for x0, y0, x1, y1 in frame.detections:
                    cv2.rectangle(bgr, _pt(x0, y0, scale), _pt(x1 - 1, y1 - 1, scale), DETECTION_BGR, 1)
            for t in frame.tracks:
                self._track(bgr, pipe, t, ranges.get(t.track_id), side, scale)
            stamp = time.strftime("%H:%M:%S", time.gmtime(frame.utc_ns / 1e9))
            cv2.putText(bgr, f"{'LR'[side]} {stamp} UTC", (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                        (255, 255, 255), 1, cv2.LINE_AA)
            ok, data = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
            if not ok:
                raise RuntimeError("JPEG encoding failed")
            out["left" if side == 0 else "right"] = data.tobytes()
        self.seq += 1
        self.latest = {side: Jpeg(self.seq, data) for side, data in out.items()}  # one reference swap

    @staticmethod
    def _track(bgr: np.ndarray, pipe: Pipeline, t: TrackBox, fix: ShipFix | None, side: int,
               scale: float) -> None:
        x0, y0, x1, y1 = t.box_rect
        if side == 1:
            if t.disparity_px is None:
                return
            x0, x1 = x0 - t.disparity_px, x1 - t.disparity_px
        corners = np.array([[x0, y0], [x1, y0], [x0, y1], [x1, y1]], float) - 0.5  # edges -> centres
        raw = pipe.rect.rect_to_raw(corners, side)
        if not np.isfinite(raw).all():
            return
        lo, hi = raw.min(axis=0) + 0.5, raw.max(axis=0) + 0.5
        colour = STATUS_BGR.get(t.status, (255, 255, 255))
        p0, p1 = _pt(lo[0], lo[1], scale), _pt(hi[0], hi[1], scale)
        cv2.rectangle(bgr, p0, p1, colour, 1)
        label = f"{t.track_id} {t.status.value}"
        if fix is not None and math.isfinite(fix.range_m):
            label += f" {fix.range_m:.0f} m"
            if math.isfinite(fix.sigma_m):
                label += f" +-{fix.sigma_m:.0f}"
        cv2.putText(bgr, label, (p0[0], max(10, p0[1] - 3)), cv2.FONT_HERSHEY_SIMPLEX, 0.35, colour, 1,
                    cv2.LINE_AA)

    def _layers(self, pipe: Pipeline, size: tuple[int, int]
                ) -> tuple[np.ndarray | None, list[np.ndarray | None]]:
        """The excluded pixels at picture size and each camera's horizon polyline, made once per
        pipeline (a reload may bring another rig, site or mask)."""
        key = (id(pipe), size)
        if self._static is None or self._static[:2] != key:
            rig, scale = pipe.rig, size[0] / pipe.rig.width
            mask = self.search_mask
            excluded = None if mask is None else cv2.resize(
                (~mask).astype(np.uint8), size, interpolation=cv2.INTER_NEAREST).astype(bool)
            horizons = [_horizon(camera, (side - 0.5) * rig.baseline_m, pipe.site.height_m, size, scale)
                        for side, camera in enumerate((rig.left, rig.right))]
            self._static = (key[0], key[1], horizons, excluded)
        _, _, lines, excl = self._static
        return excl, lines


def _horizon(camera: CameraModel, x_m: float, height_m: float, size: tuple[int, int], scale: float
             ) -> np.ndarray | None:
    """The camera's sea horizon as a polyline on the picture: per picture column, the first picture
    row whose ray meets the sea (edge.core.masks), found in bands of rows from the top so the lens
    model's temporaries stay small (the whole picture at once peaked at 60 MiB)."""
    xs = (np.arange(size[0]) + 0.5) / scale - 0.5  # the picture's pixel centres, raw pixels
    first = np.full(size[0], np.nan)
    for r0 in range(0, size[1], HORIZON_BAND_ROWS):
        ys = (np.arange(r0, min(size[1], r0 + HORIZON_BAND_ROWS)) + 0.5) / scale - 0.5
        uv = np.stack(np.meshgrid(xs, ys), axis=-1)
        rows = horizon_rows(cast_to_sea(camera.pixel_to_normalised(uv), x_m, height_m)) + 0.5 + r0
        first = np.where(np.isnan(first), rows, first)
        if np.isfinite(first).all():
            break
    cols = np.flatnonzero(np.isfinite(first))
    if len(cols) < 2:
        return None
    return np.round(np.stack([cols, first[cols] - 0.5], axis=-1)).astype(np.int32).reshape(-1, 1, 2)


def _pt(x: float, y: float, scale: float) -> tuple[int, int]:
    return int(round((x + 0.5) * scale - 0.5)), int(round((y + 0.5) * scale - 0.5))
