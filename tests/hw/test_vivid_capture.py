"""In the VM: drivers/camera/v4l2 and v4l2_pair against two real vivid capture devices.

vivid (6.1) instance 0 captures on /dev/video0, instance 1 on /dev/video2; its
webcam input offers 320x180 at up to 60 fps. Its test controls drive the
paths real cameras take rarely: `percentage_of_dropped_buffers` (sequence gaps),
`disconnect` (the node answers ENODEV until its last user closes it, then it
comes back). Small frames, tens of them: Python runs ~25x slower under TCG.
"""

from __future__ import annotations

import statistics
import time

import numpy as np
import pytest

from drivers.camera.v4l2 import CameraSettings, FormatError, V4L2Camera
from drivers.camera.v4l2_node import Node
from drivers.camera.v4l2_pair import V4L2PairSource
from drivers.trigger.none import FreeRunning

LEFT, RIGHT = "/dev/video0", "/dev/video2"
FPS = 30.0


def settings(device: str, fmt: str = "YUYV", **kw) -> CameraSettings:
    return CameraSettings(device, 320, 180, fmt, fps=FPS, buffers=4, **kw)


def test_two_cameras_capture_with_sequence_and_monotonic_timestamps() -> None:
    cams = [V4L2Camera(settings(LEFT, "GREY")), V4L2Camera(settings(RIGHT, "YUYV"))]
    try:
        for cam in cams:
            cam.start()
        frames: list[list] = [[], []]
        for _ in range(20):
            for side, cam in enumerate(cams):
                frames[side].append(cam.read(2.0))
        now = time.monotonic_ns()
        for side, cam in enumerate(cams):
            got = frames[side]
            assert all(f is not None for f in got)
            seqs = [f.sequence for f in got]
            steps = [b - a for a, b in zip(seqs, seqs[1:], strict=False)]
            # a gap of n is n-1 drops; vivid on a starved emulator sometimes repeats a number
            assert all(st >= 0 for st in steps) and cam.dropped == sum(st - 1 for st in steps if st > 0)
            assert cam.tracker.repeats == steps.count(0)
            assert all(f.clock == "monotonic" and f.source == "eof" for f in got)
            # vivid stamps start + sequence x period: ~33 ms per sequence step
            per_step = [
                (b.t_ns - a.t_ns) / (b.sequence - a.sequence)
                for a, b in zip(got, got[1:], strict=False)
                if b.sequence != a.sequence
            ]
            assert abs(statistics.median(per_step) - 1e9 / FPS) < 2e6
            assert cam.t_streamon_ns - 1e9 < got[0].t_ns < now + 1e9
            image = got[-1].image
            assert image.shape == (180, 320) and image.dtype == np.uint8 and image.std() > 5
    finally:
        for cam in cams:
            cam.close()


@pytest.mark.parametrize("fmt", ["GREY", "Y16", "YUYV"])
def test_pixel_formats_give_the_same_grey_pattern(fmt: str) -> None:
    with V4L2Camera(settings(LEFT, fmt)) as cam:
        cam.start()
        frame = cam.read(2.0)
        assert frame.image.shape == (180, 320) and frame.image.std() > 5


def test_unoffered_size_names_what_vivid_offers() -> None:
    with pytest.raises(FormatError) as exc:
        V4L2Camera(CameraSettings(LEFT, 320, 240, "GREY", fps=FPS))
    assert LEFT in str(exc.value) and "320x180" in str(exc.value) and "640x360" in str(exc.value)


def test_percentage_of_dropped_buffers_shows_as_counted_drops() -> None:
    with V4L2Camera(settings(LEFT, "GREY", controls={"percentage_of_dropped_buffers": 40})) as cam:
        try:
            cam.start()
            seqs = [cam.read(2.0).sequence for _ in range(20)]
        finally:
            cam.set_control("percentage_of_dropped_buffers", 0)
    gaps = sum(b - a - 1 for a, b in zip(seqs, seqs[1:], strict=False))
    assert gaps > 0 and cam.dropped == gaps


def wait_for(predicate, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


def test_disconnect_faults_the_camera_and_the_source_reconnects() -> None:
    source = V4L2PairSource(
        settings(LEFT),
        settings(RIGHT),
        FreeRunning(FPS),
        backoff_s=(0.1, 0.4),
        poll_s=0.1,
        read_timeout_s=5.0,
    )
    with source:
        pair = source.read()
        assert pair.left.shape == (180, 320) and abs(pair.skew_ns) <= 1e9 / FPS / 2
        assert abs(pair.t_utc_ns - time.time_ns()) < 5e9
        node = Node(RIGHT)
        node.set("disconnect", 1)  # vivid: unregistered until its last user closes it
        node.close()
        wait_for(lambda: source.faults["right"].faulted or source.faults["right"].reconnects, 10.0)
        wait_for(lambda: source.faults["right"].reconnects == 1 and not source.faults["right"].faulted, 15.0)
        assert source.read() is not None
        counters = source.counters
        assert (
            counters["reconnects_right"] == 1 and counters["reconnects_left"] == 0 and counters["pairs"] >= 2
        )
