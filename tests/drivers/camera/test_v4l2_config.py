"""drivers/camera/v4l2_config.py: the worked examples in config/cameras/ parse, and a parsed block streams."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
import yaml

from drivers.camera import v4l2_abi as abi
from drivers.camera.v4l2 import V4L2Camera
from drivers.camera.v4l2_config import cameras_from_config
from drivers.trigger.gpio import GpioTrigger
from lab.fakes.v4l2_fake import FakeControl, FakeDevice, FakeKernel

EXAMPLES = sorted((Path(__file__).resolve().parents[3] / "config" / "cameras").glob("*.yaml"))


def load(name: str) -> dict:
    return yaml.safe_load(next(p for p in EXAMPLES if p.name == name).read_text())["cameras"]


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_examples_parse(path: Path) -> None:
    config = cameras_from_config(yaml.safe_load(path.read_text())["cameras"])
    assert config.left.device == "/dev/mast/cam-left" and config.right.device == "/dev/mast/cam-right"
    assert config.trigger.period_ns > 0 and config.trigger.describe()


def test_alvium_example_details() -> None:
    config = cameras_from_config(load("alvium-triggered.yaml"))
    assert config.left.subdevice == "/dev/mast/cam-left-sensor" and config.left.fps is None
    assert list(config.left.controls.items()) == [
        ("auto_exposure", "Manual Mode"),
        ("exposure_time_absolute", 2000),
        ("gain", 0),
    ]
    assert config.max_skew_ns == 5_000_000 and config.trigger.kind == "controls"
    assert "trigger_activation=Rising Edge" in config.trigger.describe()
    gpio = cameras_from_config(load("gpio-driven.yaml"))
    assert isinstance(gpio.trigger, GpioTrigger) and gpio.trigger.line == 17 and gpio.left.controls == {}
    assert not cameras_from_config(load("free-running.yaml")).trigger.synchronised


def test_errors_name_the_key() -> None:
    block = load("vc-mipi-triggered.yaml")
    with pytest.raises(ValueError, match="unknown key.*exposre"):
        cameras_from_config(block | {"exposre": "auto"})
    with pytest.raises(ValueError, match="cameras.left needs a device"):
        cameras_from_config(block | {"left": {}})
    with pytest.raises(ValueError, match="cameras.gain: 'auto' or"):
        cameras_from_config(block | {"gain": 3})
    with pytest.raises(ValueError, match="not supported"):
        cameras_from_config(block | {"pixel_format": "NV12"})


def test_a_parsed_block_streams_pairs_from_fakes() -> None:
    block = load("vc-mipi-triggered.yaml") | {
        "width": 32,
        "height": 24,
        "trigger": {"kind": "external", "rate_hz": 20},
    }
    controls = [FakeControl(0x00980911, "Exposure", maximum=10000), FakeControl(0x00980913, "Gain")]
    devices = {
        p: FakeDevice({"Y16": [(32, 24)]}, controls=[FakeControl(**vars(c)) for c in controls])
        for p in ("/dev/mast/cam-left", "/dev/mast/cam-right")
    }
    kernel = FakeKernel(devices)
    config = cameras_from_config(block)
    with config.source(open_camera=lambda s: V4L2Camera(s, kernel=kernel), poll_s=0.02) as source:
        source.start()
        t = time.monotonic_ns() + 10**9  # after STREAMON (earlier stamps are stale)
        for k in range(6):  # the external pulses, as the fakes would see them
            for device in devices.values():
                while not device.produce(t + k * 50_000_000):
                    pass
        pair = source.read(timeout_s=2.0)
        assert pair.left.shape == (24, 32) and pair.skew_ns == 0
    assert all(
        d.controls[0x00980911].value == 5000 and d.controls[0x00980913].value == 10 for d in devices.values()
    )
    assert abi.fourcc_str(devices["/dev/mast/cam-left"].pixelformat) == "Y16"
