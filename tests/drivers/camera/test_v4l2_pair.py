"""drivers/camera/v4l2_pair.py over fake devices fired by a virtual trigger: pairs, drops, faults."""

from __future__ import annotations

import threading
import time

import pytest

from drivers.camera import v4l2_abi as abi
from drivers.camera.v4l2 import CameraSettings, V4L2Camera
from drivers.camera.v4l2_pair import PairTimeout, V4L2PairSource
from drivers.trigger.controls import TriggerControls
from drivers.trigger.virtual import VirtualTrigger
from lab.fakes.v4l2_fake import FakeControl, FakeDevice, FakeKernel

RATE = 50.0
MODE = 0x009A092F


def rig(**source_args):
    devices = {
        p: FakeDevice(
            {"GREY": [(32, 24)]},
            controls=[FakeControl(MODE, "Trigger Mode", type=abi.CTRL_TYPE_BOOLEAN, maximum=1)],
        )
        for p in ("/dev/mast/cam-left", "/dev/mast/cam-right")
    }
    kernel = FakeKernel(devices)
    left, right = devices.values()
    skew = {"ns": 300_000}
    trigger = VirtualTrigger(
        RATE,
        [lambda t: left.produce(t), lambda t: right.produce(t + skew["ns"])],
        camera_setup=TriggerControls("test", free_run_value=False),
    )
    settings = [CameraSettings(p, 32, 24, "GREY", buffers=3) for p in devices]
    args = {"backoff_s": (0.02, 0.1), "poll_s": 0.02, "read_timeout_s": 1.0} | source_args
    source = V4L2PairSource(*settings, trigger, open_camera=lambda s: V4L2Camera(s, kernel=kernel), **args)
    return source, left, right, skew


def wait_for(predicate, timeout_s: float = 5.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def test_pairs_with_metadata_utc_offset_and_trigger_setup() -> None:
    source, left, right, _ = rig()
    with source:
        pairs = [source.read() for _ in range(10)]
        assert left.controls[MODE].value == 1 and right.controls[MODE].value == 1  # armed before streaming
        for p in pairs:
            assert p.skew_ns == 300_000 and p.t_ns == p.t_left_ns + 150_000
            assert p.left.shape == (24, 32) and p.left.base is None  # owns its pixels
            assert abs(p.t_utc_ns - time.time_ns()) < 5e9
        seqs = [(p.seq_left - pairs[0].seq_left, p.seq_right - pairs[0].seq_right) for p in pairs]
        assert seqs == [(k, k) for k in range(10)]
        assert not source.degraded and source.faults["left"].reconnects == 0
        c = source.counters
        assert c["pairs"] >= 10 and c["drops_left"] == 0 and abs(c["skew"]["mean_ms"] - 0.3) < 1e-9
    assert source.read() is None and left.controls[MODE].value == 0  # released at close


def test_drops_are_counted_per_camera() -> None:
    source, left, right, _ = rig()
    with source:
        source.read()
        right.drop_next(3)
        wait_for(lambda: source.counters["drops_right"] == 3)
        assert source.counters["drops_left"] == 0
        wait_for(lambda: source.counters["unpaired_left"] >= 3)


def test_camera_gone_faults_reconnects_and_read_times_out_meanwhile() -> None:
    source, left, right, _ = rig(read_timeout_s=0.3)
    with source:
        source.read()
        right.unplug()
        wait_for(lambda: source.faults["right"].faulted)
        fault = source.faults["right"]
        assert "/dev/mast/cam-right" in fault.reason and fault.since_ns > 0 and source.degraded
        with pytest.raises(PairTimeout, match="no frame pair within 0.3 s .right: /dev/mast/cam-right"):
            while True:
                source.read()  # pairs queued before the unplug drain first
        right.replug()
        pair = source.read(timeout_s=3.0)
        assert pair is not None and source.faults["right"].reconnects == 1
        assert not source.faults["right"].faulted and source.counters["reconnects_right"] == 1


def test_stalled_camera_and_timeout_without_pulses() -> None:
    source, left, right, _ = rig(read_timeout_s=0.2, stall_periods=3)
    source.trigger.on_pulse.pop()  # the right camera never sees a pulse
    with source:
        with pytest.raises(PairTimeout):
            source.read()
        wait_for(lambda: source.stalled("right"))
        assert not source.stalled("left") and source.degraded and not source.faults["right"].faulted


def test_close_wakes_a_blocked_reader() -> None:
    source, *_ = rig(read_timeout_s=30.0)
    source.trigger.on_pulse.clear()
    result: list = []
    reader = threading.Thread(target=lambda: result.append(source.read()))
    reader.start()
    time.sleep(0.1)
    source.close()
    reader.join(timeout=5.0)
    assert result == [None]
