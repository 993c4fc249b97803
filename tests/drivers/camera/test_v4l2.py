"""drivers/camera/v4l2.py against a fake device at the Kernel chokepoint: the V4L2 contract.

Struct sizes against the kernel's ioctl numbers, format negotiation and its error
naming what is offered, the mmap buffer cycle with metadata read before QBUF,
the four pixel formats to grey, drops from sequence gaps, stale frames,
ENODEV mid-stream -> CameraGone, controls by v4l2-ctl name (video node and sub-device).
"""

from __future__ import annotations

import errno

import numpy as np
import pytest

from drivers.camera import v4l2_abi as abi
from drivers.camera.v4l2 import CameraGone, CameraSettings, ControlError, DeviceError, FormatError, V4L2Camera
from drivers.camera.v4l2_node import Node, normalise_name
from lab.fakes.v4l2_fake import FakeControl, FakeDevice, FakeKernel, alvium_trigger_controls

MS = 1_000_000
CONTROLS = [
    FakeControl(0x00980900, "Brightness", minimum=0, maximum=255, default=128),
    FakeControl(0x009A0902, "Exposure Time, Absolute", minimum=1, maximum=10000, default=100),
    *alvium_trigger_controls(),
    FakeControl(0x009A0940, "Pixel Rate", type=abi.CTRL_TYPE_INTEGER64, maximum=1 << 40),
    FakeControl(0x00F0F000, "Sensor Temp", flags=abi.CTRL_FLAG_READ_ONLY, default=40),
]


def rig(**device_args):
    formats = device_args.pop("formats", {"GREY": [(64, 48), (32, 24)], "YUYV": [(64, 48)]})
    device = FakeDevice(formats, controls=[FakeControl(**vars(c)) for c in CONTROLS], **device_args)
    return device, FakeKernel({"/dev/mast/cam-left": device})


def camera(kernel, **settings) -> V4L2Camera:
    args = {
        "device": "/dev/mast/cam-left",
        "width": 64,
        "height": 48,
        "pixel_format": "GREY",
        "fps": 10,
    } | settings
    return V4L2Camera(CameraSettings(**args), kernel=kernel, clock=lambda: 5 * MS)


def test_struct_sizes_match_the_kernel_ioctl_numbers() -> None:
    assert abi.VIDIOC_QUERYCAP == 0x80685600
    assert abi.VIDIOC_S_FMT == 0xC0D05605
    assert abi.VIDIOC_S_PARM == 0xC0CC5616
    assert abi.VIDIOC_DQBUF == 0xC0585611 and abi.VIDIOC_QBUF == 0xC058560F
    assert abi.VIDIOC_QUERY_EXT_CTRL == 0xC0E85667 and abi.VIDIOC_QUERYMENU == 0xC02C5625
    assert abi.VIDIOC_S_EXT_CTRLS == 0xC0205648 and abi.VIDIOC_STREAMON == 0x40045612
    assert abi.VIDIOC_ENUM_FRAMESIZES == 0xC02C564A and abi.VIDIOC_ENUM_FRAMEINTERVALS == 0xC034564B


def test_format_negotiation_and_errors_naming_offers() -> None:
    device, kernel = rig()
    with camera(kernel, width=32, height=24) as cam:
        assert (cam.width, cam.height, cam.fps) == (32, 24, 10.0)
        assert cam.bytesperline == 32
    with pytest.raises(FormatError) as exc:
        camera(kernel, width=320, height=240)
    assert "/dev/mast/cam-left" in str(exc.value) and "GREY 64x48 32x24" in str(exc.value)
    assert "YUYV 64x48" in str(exc.value)
    with pytest.raises(FormatError, match="asked for Y16 64x48, the driver set GREY"):
        camera(kernel, pixel_format="Y16")
    with pytest.raises(FormatError, match="asked for 15 fps.*offers at 64x48: 10 fps, 30 fps"):
        camera(kernel, fps=15)
    with pytest.raises(ValueError, match="not supported"):
        camera(kernel, pixel_format="RGB3")


def test_querycap_and_open_errors_name_the_device() -> None:
    _, kernel = rig(caps=abi.CAP_VIDEO_CAPTURE)
    with pytest.raises(DeviceError, match="cam-left: fake 'Fake camera' lacks streaming"):
        camera(kernel)
    with pytest.raises(DeviceError, match="/dev/mast/nope: cannot open"):
        camera(kernel, device="/dev/mast/nope")


def test_buffer_cycle_metadata_before_qbuf_and_copy_rule() -> None:
    device, kernel = rig()
    with camera(kernel, buffers=3) as cam:
        cam.start()
        assert cam.read(0.0) is None  # nothing exposed yet: poll times out
        image = np.arange(64 * 48, dtype=np.uint8).reshape(48, 64)
        assert device.produce(7 * MS, image, flags=abi.BUF_FLAG_TSTAMP_SRC_SOE)
        frame = cam.dequeue(1.0)
        assert frame is not None and (frame.sequence, frame.t_ns, frame.clock, frame.source) == (
            0,
            7 * MS,
            "monotonic",
            "soe",
        )
        assert np.array_equal(frame.image, image) and frame.image.base is not None  # a view of the mmap
        cam.requeue(frame)  # the fake's QBUF zeroes the struct it is given: metadata was read before
        assert (frame.sequence, frame.t_ns) == (0, 7 * MS)
        for k in range(1, 7):  # more frames than buffers: the cycle must return every buffer
            assert device.produce((7 + k) * MS, image + k)
            owned = cam.read(1.0)
            assert owned.sequence == k and owned.source == "eof" and owned.image.base is None
            assert np.array_equal(owned.image, image + k)
        assert device.log.count("VIDIOC_QBUF") == 3 + 7 and cam.dropped == 0


@pytest.mark.parametrize("fmt", ["GREY", "Y16", "YUYV", "MJPEG"])
def test_pixel_formats_to_grey(fmt: str) -> None:
    device, kernel = rig(formats={fmt: [(40, 30)]})
    with camera(kernel, width=40, height=30, pixel_format=fmt) as cam:
        cam.start()
        image = (np.add.outer(np.arange(30), np.arange(40)) * 4 % 256).astype(np.uint8)
        device.produce(6 * MS, image)
        frame = cam.read(1.0)
        assert frame.image.shape == (30, 40) and frame.image.dtype == np.uint8
        tolerance = 12 if fmt == "MJPEG" else 0
        assert np.abs(frame.image.astype(int) - image).max() <= tolerance


def test_drops_stale_and_corrupt_frames() -> None:
    device, kernel = rig()
    with camera(kernel, skip_frames=1) as cam:
        cam.start()
        device.produce(4 * MS)  # seq 0, exposed before STREAMON (the clock says 5 ms): stale
        device.produce(6 * MS)  # seq 1, skip_frames=1
        device.produce(7 * MS, flags=abi.BUF_FLAG_ERROR)  # seq 2, corrupt
        device.produce(8 * MS)  # seq 3
        assert cam.read(0.1).sequence == 3 and (cam.stale, cam.corrupt) == (2, 1)
        device.drop_next(2)  # seq 4, 5 lost in the driver
        for t in (9, 10, 11):
            device.produce(t * MS)
        assert cam.read(0.1).sequence == 6 and cam.dropped == 2
        for _ in range(5):  # the application is late: 4 buffers fill, the driver drops the 5th (seq 11)
            device.produce(12 * MS)
        assert [cam.read(0.1).sequence for _ in range(4)] == [7, 8, 9, 10]
        device.produce(13 * MS)
        assert cam.read(0.1).sequence == 12 and cam.dropped == 3


def test_enodev_mid_stream_is_camera_gone_and_reopen_works() -> None:
    device, kernel = rig()
    cam = camera(kernel)
    cam.start()
    device.unplug()
    with pytest.raises(CameraGone) as exc:
        cam.read(1.0)
    assert exc.value.path == "/dev/mast/cam-left"
    cam.close()
    with pytest.raises(DeviceError, match="cannot open"):
        camera(kernel)
    device.replug()
    with camera(kernel) as again:
        again.start()
        device.produce(9 * MS)
        assert again.read(1.0).sequence == 0


def test_eio_from_dqbuf_is_camera_gone() -> None:
    device, kernel = rig()
    with camera(kernel) as cam:
        cam.start()
        device.produce(6 * MS)
        device._dqbuf = lambda a: (_ for _ in ()).throw(OSError(errno.EIO, "I/O error"))
        with pytest.raises(CameraGone, match="VIDIOC_DQBUF failed"):
            cam.read(1.0)


def test_controls_by_name() -> None:
    device, kernel = rig()
    with camera(kernel, controls={"Exposure Time, Absolute": 250}) as cam:
        assert normalise_name(" Exposure Time, Absolute ") == "exposure_time_absolute"
        assert cam.get_control("exposure_time_absolute") == 250
        node = cam.node
        assert set(node.controls) >= {"trigger_mode", "trigger_activation", "trigger_software", "pixel_rate"}
        assert node.set("trigger_mode", "on") == 1 and node.get("Trigger Mode") == 1
        assert node.set("trigger_activation", "falling edge") == 1 and node.get_item(
            "trigger_activation"
        ) == ("Falling Edge")
        assert node.set("trigger_activation", 3) == 3
        node.set("trigger_software", None)
        assert device.controls[0x009A0932].presses == 1
        assert node.set("pixel_rate", 1 << 33) == 1 << 33 and node.get("pixel_rate") == 1 << 33
        with pytest.raises(
            ControlError, match="'rising' is not an item of trigger_activation .*0: Rising Edge"
        ):
            node.set("trigger_activation", "rising")
        with pytest.raises(ControlError, match="out of range for exposure_time_absolute .int 1..10000"):
            node.set("exposure_time_absolute", 0)
        with pytest.raises(ControlError, match="read-only"):
            node.set("sensor_temp", 1)
        with pytest.raises(ControlError, match="no control 'gain' .this device has: brightness"):
            node.set("gain", 1)


def test_controls_without_query_ext_ctrl_and_on_a_subdevice() -> None:
    video = FakeDevice(
        {"GREY": [(64, 48)]}, controls=[FakeControl(0x00980900, "Brightness")], ext_ctrls=False
    )
    sub = FakeDevice(
        controls=[FakeControl(0x009A092F, "Trigger Mode", type=abi.CTRL_TYPE_BOOLEAN, maximum=1)]
    )
    kernel = FakeKernel({"/dev/mast/cam-left": video, "/dev/v4l-subdev2": sub})
    assert list(Node("/dev/mast/cam-left", kernel=kernel).controls) == ["brightness"]
    with camera(kernel, subdevice="/dev/v4l-subdev2") as cam:
        cam.set_control("trigger_mode", True)
        cam.set_control("brightness", 7)
        assert sub.controls[0x009A092F].value == 1 and video.controls[0x00980900].value == 7
        assert cam.has_control("trigger_mode") and not cam.has_control("trigger_source")
