"""What capture costs per pair, from a filled driver buffer to a paired grey image (tools/bench-capture).

For each size and pixel format two `FakeDevice` cameras are streamed through
the real V4L2Camera code (poll, DQBUF, conversion to grey with its one copy,
QBUF) and a `Pairer`; the device's filling of the buffer (the DMA a real
driver does) is outside the timed section. The baseline, measured in the same
run and the same loop, is a plain memory copy of the same bytes (both
buffers' bytesused into preallocated arrays): the least any capture path into
memory of our own can cost. Times are this thread's CPU time
(time.thread_time_ns), medians over the pairs; ratio = capture / copy.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass

import numpy as np

from drivers.camera.pairing import LEFT, RIGHT, Pairer
from drivers.camera.v4l2 import CameraSettings, V4L2Camera
from lab.fakes.v4l2_fake import FakeDevice, FakeKernel

FORMATS = ("GREY", "Y16", "YUYV", "MJPEG")
SIZES = ((720, 480), (2048, 1536))
PERIOD_NS = 100_000_000


@dataclass(frozen=True)
class Row:
    width: int
    height: int
    pixel_format: str
    bytes_per_frame: int
    pairs: int
    capture_us: float  # median per pair: both cameras' buffer -> grey copy, and the pairing
    copy_us: float  # median per pair: memcpy of both buffers' bytes

    @property
    def ratio(self) -> float:
        return self.capture_us / self.copy_us if self.copy_us else float("inf")


def scene(width: int, height: int, seed: int = 0) -> np.ndarray:
    """A textured grey image (JPEG sizes depend on content: flat images would flatter MJPEG)."""
    rng = np.random.default_rng(seed)
    ramp = np.add.outer(np.arange(height) * 0.2, np.arange(width) * 0.1)
    return np.clip(ramp + rng.normal(0, 12, (height, width)) + 60, 0, 255).astype(np.uint8)


def measure(width: int, height: int, fmt: str, pairs: int) -> Row:
    paths = ("/dev/bench-left", "/dev/bench-right")
    devices = {p: FakeDevice({fmt: [(width, height)]}, rates=(10,)) for p in paths}
    kernel = FakeKernel(devices)
    cams = [
        V4L2Camera(CameraSettings(p, width, height, fmt, fps=10, buffers=4), kernel=kernel, clock=lambda: 0)
        for p in paths
    ]
    payloads = [devices[p].encode(scene(width, height, seed)) for seed, p in enumerate(paths)]
    copies = [np.empty(len(b), np.uint8) for b in payloads]
    pairer: Pairer = Pairer(PERIOD_NS)
    capture_ns, copy_ns = [], []
    try:
        for cam in cams:
            cam.start()
        for k in range(pairs + 3):  # the first three warm up
            t = (k + 1) * PERIOD_NS
            for p, payload in zip(paths, payloads, strict=True):
                devices[p].produce(t, payload)
            t0 = time.thread_time_ns()
            got, used = [], []
            for side in (LEFT, RIGHT):
                frame = cams[side].read(0.0)
                assert frame is not None  # the fake always has a frame queued
                got += pairer.push(side, frame)
                used.append(frame.index)
            t1 = time.thread_time_ns()
            for dst, p, payload, index in zip(copies, paths, payloads, used, strict=True):
                buffer = devices[p].buffers[index]  # the same bytes, from the same buffer
                np.copyto(dst, np.frombuffer(buffer, np.uint8, count=len(payload)))
            t2 = time.thread_time_ns()
            assert len(got) == 1 and got[0][0].image.shape == (height, width)
            if k >= 3:
                capture_ns.append(t1 - t0)
                copy_ns.append(t2 - t1)
    finally:
        for cam in cams:
            cam.close()
    return Row(
        width,
        height,
        fmt,
        len(payloads[0]),
        pairs,
        statistics.median(capture_ns) / 1e3,
        statistics.median(copy_ns) / 1e3,
    )


def run(sizes=SIZES, formats=FORMATS, pairs: int = 60) -> list[Row]:
    return [
        measure(w, h, f, pairs if f != "MJPEG" else max(3, pairs // 3)) for w, h in sizes for f in formats
    ]


def table(rows: list[Row]) -> str:
    head = (
        f"{'size':>10} {'format':<6} {'bytes/frame':>11} {'pairs':>5} {'capture us':>10} {'copy us':>8} "
        f"{'ratio':>6}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r.width:>5}x{r.height:<4} {r.pixel_format:<6} {r.bytes_per_frame:>11} {r.pairs:>5} "
            f"{r.capture_us:>10.1f} {r.copy_us:>8.1f} {r.ratio:>6.2f}"
        )
    return "\n".join(lines)
