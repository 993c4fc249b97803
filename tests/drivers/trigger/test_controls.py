"""drivers/trigger/controls.py and config.py: camera-model adapters against the fake V4L2 device."""

from __future__ import annotations

import pytest

from drivers.camera import v4l2_abi as abi
from drivers.camera.v4l2 import CameraSettings, ControlError, V4L2Camera
from drivers.trigger.config import trigger_from_config
from drivers.trigger.controls import PRESETS, trigger_controls
from lab.fakes.v4l2_fake import FakeControl, FakeDevice, FakeKernel, alvium_trigger_controls

VC = [FakeControl(0x00980A00, "Trigger Mode", minimum=0, maximum=7)]


def open_camera(video: FakeDevice, sub: FakeDevice | None = None) -> V4L2Camera:
    devices = {"/dev/mast/cam-left": video} | ({"/dev/v4l-subdev0": sub} if sub else {})
    settings = CameraSettings("/dev/mast/cam-left", 64, 48, subdevice="/dev/v4l-subdev0" if sub else None)
    return V4L2Camera(settings, kernel=FakeKernel(devices))


def test_alvium_on_its_subdevice_in_order_and_released() -> None:
    video, sub = FakeDevice(), FakeDevice(controls=alvium_trigger_controls())
    trigger = trigger_from_config(
        {"kind": "controls", "rate_hz": 5, "camera": {"model": "alvium", "activation": "falling"}}
    )
    with open_camera(video, sub) as cam:
        trigger.configure_camera("left", cam)
        values = {c.label: c.value for c in sub.controls.values() if c.type != abi.CTRL_TYPE_BUTTON}
        assert values == {"Trigger Mode": 1, "Trigger Activation": 1, "Trigger Source": 0}
        names = [n for n in sub.log if n == "VIDIOC_S_CTRL"]
        assert len(names) == 3  # source, activation, then the mode last
        trigger.release_camera("left", cam)
        assert sub.controls[0x009A092F].value == 0
    assert trigger.period_ns == 200_000_000 and "Falling Edge" in trigger.describe()


def test_vision_components_integer_mode() -> None:
    video = FakeDevice(controls=VC)
    trigger = trigger_from_config({"kind": "external", "rate_hz": 10, "camera": {"model": "vc-mipi"}})
    with open_camera(video) as cam:
        trigger.configure_camera("right", cam)
        assert video.controls[0x00980A00].value == 1
        trigger.release_camera("right", cam)
        assert video.controls[0x00980A00].value == 0


def test_adapter_errors_name_what_is_wrong() -> None:
    with pytest.raises(ValueError, match="only a rising edge"):
        trigger_controls({"model": "vc-mipi", "activation": "falling"})
    with pytest.raises(ValueError, match="no preset"):
        trigger_controls({"model": "basler"})
    with pytest.raises(ValueError, match="unknown camera trigger setting.*mode_contrl"):
        trigger_controls({"model": "alvium", "mode_contrl": "x"})
    with pytest.raises(ValueError, match="unknown key.*rate"):
        trigger_from_config({"kind": "gpio", "rate": 10})
    with pytest.raises(ValueError, match="needs a camera"):
        trigger_from_config({"kind": "controls", "rate_hz": 10})
    custom = trigger_controls(
        {
            "model": "custom",
            "mode_control": "trigger_mode",
            "mode_value": 1,
            "settings": {"trigger_source": "Line1"},
        }
    )
    assert custom.plan() == [("trigger_source", "Line1"), ("trigger_mode", 1)]
    with (
        open_camera(FakeDevice(controls=VC)) as cam,
        pytest.raises(ControlError, match="no control 'trigger_source'"),
    ):
        PRESETS["alvium"].apply(cam)


def test_free_running_and_defaults() -> None:
    trigger = trigger_from_config(None, fps=25)
    assert trigger.kind == "none" and not trigger.synchronised and trigger.period_ns == 40_000_000
    with pytest.raises(ValueError, match="needs rate_hz"):
        trigger_from_config({"kind": "external"})
