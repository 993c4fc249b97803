"""A fake V4L2 capture device behind the `Kernel` chokepoint, for the contract tests and tools/bench-capture.

`FakeKernel` stands in for drivers.kernel.LINUX: `open` finds a `FakeDevice`
by path, `ioctl` answers the V4L2 requests the driver uses by filling the same
ctypes structures the kernel would (QUERYCAP, ENUM_FMT/FRAMESIZES/
FRAMEINTERVALS, G/S_FMT, G/S_PARM, REQBUFS, QUERYBUF, QBUF, DQBUF, STREAMON/OFF,
S_INPUT, QUERY_EXT_CTRL/QUERYCTRL with NEXT_CTRL, QUERYMENU, G/S_CTRL,
G/S_EXT_CTRLS), `mmap` hands out anonymous mmaps as the buffers and `poll`
waits for a produced frame. Like the kernel, S_FMT adjusts an unsupported
request to what it has, and QBUF/DQBUF rewrite the structure they are given.

The test (or a `VirtualTrigger` pulse) calls `device.produce(...)`: the oldest
queued buffer gets the pixels and metadata (sequence, timestamp, flags) and
becomes dequeueable; `produce(..., pulse=k)` also records the trigger pulse the
frame belongs to in `device.pulses` (its timestamp -> k), the ground truth a
fault test checks processed pairs against (a real driver has no such thing).
`device.drop_next(n)` makes the next n frames vanish
(their sequence numbers are skipped, as a driver that dropped them reports);
`device.unplug()` makes every ioctl fail with ENODEV and poll report
POLLERR|POLLHUP until `replug()`; `device.log` records the ioctl names.
`alvium_trigger_controls()` gives a device an Alvium-shaped trigger control set.
"""

from __future__ import annotations

import ctypes
import errno
import mmap
import os
import select
import threading
from collections import deque
from dataclasses import dataclass, field

import cv2
import numpy as np

from drivers.camera import v4l2_abi as abi
from drivers.camera.v4l2_convert import pixel_format
from drivers.kernel import Kernel

PAGE = mmap.PAGESIZE


@dataclass
class FakeControl:
    id: int
    label: str
    type: int = abi.CTRL_TYPE_INTEGER
    minimum: int = 0
    maximum: int = 100
    step: int = 1
    default: int = 0
    flags: int = 0
    menu: dict[int, str] = field(default_factory=dict)
    value: int | None = None
    presses: int = 0  # buttons


def menu_control(cid: int, label: str, items: list[str], default: int = 0) -> FakeControl:
    return FakeControl(
        cid,
        label,
        type=abi.CTRL_TYPE_MENU,
        maximum=len(items) - 1,
        menu=dict(enumerate(items)),
        default=default,
    )


def alvium_trigger_controls() -> list[FakeControl]:
    """Fresh controls shaped like an Alvium's trigger set (camera-class ids +47..+50)."""
    return [
        FakeControl(0x009A092F, "Trigger Mode", type=abi.CTRL_TYPE_BOOLEAN, maximum=1),
        menu_control(
            0x009A0930,
            "Trigger Activation",
            ["Rising Edge", "Falling Edge", "Any Edge", "Level High", "Level Low"],
        ),
        menu_control(0x009A0931, "Trigger Source", ["Line0", "Line1", "Line2", "Line3", "Software"], 4),
        FakeControl(
            0x009A0932, "Trigger Software", type=abi.CTRL_TYPE_BUTTON, flags=abi.CTRL_FLAG_WRITE_ONLY
        ),
    ]


def _oserror(code: int) -> OSError:
    return OSError(code, os.strerror(code))


class FakeDevice:
    """One capture node: formats {name: [(w, h), ...]}, frame rates, controls, a buffer queue."""

    def __init__(
        self,
        formats: dict[str, list[tuple[int, int]]] | None = None,
        *,
        rates: tuple = (10, 30),
        controls: list[FakeControl] | None = None,
        caps: int = abi.CAP_VIDEO_CAPTURE | abi.CAP_STREAMING,
        timestamp_flags: int = abi.BUF_FLAG_TIMESTAMP_MONOTONIC,
        ext_ctrls: bool = True,
    ) -> None:
        self.formats = formats or {"GREY": [(64, 48)]}
        self.rates, self.caps, self.timestamp_flags, self.ext_ctrls = rates, caps, timestamp_flags, ext_ctrls
        self.controls = {c.id: c for c in controls or []}
        for c in self.controls.values():
            c.value = c.default if c.value is None else c.value
        name, sizes = next(iter(self.formats.items()))
        self._set_fmt(pixel_format(name).fourcc, *sizes[0])
        self.fps = float(rates[0])
        self.buffers: list[mmap.mmap] = []
        self.queued: deque[int] = deque()
        self.done: deque[tuple[int, int, int, int, int]] = deque()  # index, bytesused, seq, t_ns, flags
        self.streaming, self.gone, self.sequence, self._drop = False, False, 0, 0
        self.input = 0
        self.log: list[str | None] = []  # ioctl names, in order
        self.pulses: dict[int, int] = {}  # ground truth: timestamp of a delivered frame -> its pulse
        self.cond = threading.Condition()

    # --- what a test drives ---------------------------------------------------------------------

    def produce(self, t_ns: int, image: np.ndarray | bytes | None = None, *, flags: int = 0,
                pulse: int | None = None) -> bool:
        """A frame exposed at t_ns: into the oldest queued buffer (False if none queued or not streaming).
        `pulse`: the trigger pulse it answers, kept in `pulses[t_ns]` if the frame is delivered."""
        with self.cond:
            seq = self.sequence
            self.sequence = (self.sequence + 1) % (1 << 32)
            if not self.streaming or not self.queued or self.gone:
                return False
            if self._drop:
                self._drop -= 1
                return False
            index = self.queued.popleft()
            data = self.encode(image if image is not None else self.pattern(seq))
            self.buffers[index][: len(data)] = data
            self.done.append((index, len(data), seq, t_ns, self.timestamp_flags | flags))
            if pulse is not None:
                self.pulses[t_ns] = pulse
            self.cond.notify_all()
            return True

    def drop_next(self, count: int) -> None:
        self._drop += count

    def unplug(self) -> None:
        with self.cond:
            self.gone = True
            self.cond.notify_all()

    def replug(self) -> None:
        with self.cond:
            self.gone, self.streaming, self.sequence = False, False, 0
            self.queued.clear()
            self.done.clear()

    def pattern(self, seq: int) -> np.ndarray:
        """A grey test image whose first pixel is seq % 256."""
        image = np.add.outer(np.arange(self.height), np.arange(self.width)).astype(np.uint8)
        image.flat[0] = seq % 256
        return image

    def encode(self, image: np.ndarray | bytes) -> bytes:
        """Grey image -> the bytes the negotiated format would carry (bytes pass through)."""
        if isinstance(image, bytes | bytearray):
            return bytes(image)
        name, pad = abi.fourcc_str(self.pixelformat), self.bytesperline
        if name == "MJPG":
            return cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 90])[1].tobytes()
        if name == "Y16":
            raw = (image.astype("<u2") << 8).view(np.uint8).reshape(self.height, -1)
        elif name == "YUYV":
            raw = np.full((self.height, self.width * 2), 128, np.uint8)
            raw[:, 0::2] = image
        else:
            raw = image
        rows = np.zeros((self.height, pad), np.uint8)
        rows[:, : raw.shape[1]] = raw
        return rows.tobytes()

    # --- the kernel side ------------------------------------------------------------------------

    def _set_fmt(self, code: int, width: int, height: int) -> None:
        name = abi.fourcc_str(code)
        name = {"MJPG": "MJPEG"}.get(name, name)
        if name not in self.formats:
            name = next(iter(self.formats))
        sizes = self.formats[name]
        w, h = min(sizes, key=lambda s: abs(s[0] - width) + abs(s[1] - height))
        self.pixelformat, self.width, self.height = pixel_format(name).fourcc, w, h
        bpp = pixel_format(name).bytes_per_pixel
        self.bytesperline = (w * bpp + 15) // 16 * 16 if bpp else 0  # rows padded to 16 bytes
        self.sizeimage = self.bytesperline * h if bpp else w * h + 4096

    def ioctl(self, request: int, arg) -> None:
        name = abi.IOCTL_NAMES.get(request)
        self.log.append(name)
        if self.gone:
            raise _oserror(errno.ENODEV)
        handler = getattr(self, f"_{name[7:].lower()}", None) if name else None
        if handler is None:
            raise _oserror(errno.ENOTTY)
        with self.cond:
            handler(arg)

    def _querycap(self, a) -> None:
        a.driver, a.card, a.capabilities, a.device_caps = (
            b"fake",
            b"Fake camera",
            self.caps | abi.CAP_DEVICE_CAPS,
            self.caps,
        )

    def _enum_fmt(self, a) -> None:
        names = list(self.formats)
        if a.index >= len(names):
            raise _oserror(errno.EINVAL)
        a.pixelformat = pixel_format(names[a.index]).fourcc

    def _enum_framesizes(self, a) -> None:
        sizes = [s for n, v in self.formats.items() if pixel_format(n).fourcc == a.pixel_format for s in v]
        if a.index >= len(sizes):
            raise _oserror(errno.EINVAL)
        a.type, (a.discrete.width, a.discrete.height) = abi.FRMSIZE_TYPE_DISCRETE, sizes[a.index]

    def _enum_frameintervals(self, a) -> None:
        if a.index >= len(self.rates):
            raise _oserror(errno.EINVAL)
        a.type, a.discrete.numerator, a.discrete.denominator = (
            abi.FRMIVAL_TYPE_DISCRETE,
            1,
            self.rates[a.index],
        )

    def _g_fmt(self, a) -> None:
        p = a.fmt.pix
        p.width, p.height, p.pixelformat, p.field = self.width, self.height, self.pixelformat, abi.FIELD_NONE
        p.bytesperline, p.sizeimage = self.bytesperline, self.sizeimage

    def _s_fmt(self, a) -> None:
        if self.buffers:
            raise _oserror(errno.EBUSY)
        self._set_fmt(a.fmt.pix.pixelformat, a.fmt.pix.width, a.fmt.pix.height)
        self._g_fmt(a)

    def _g_parm(self, a) -> None:
        a.parm.capture.capability = abi.CAP_TIMEPERFRAME
        a.parm.capture.timeperframe.numerator, a.parm.capture.timeperframe.denominator = (
            1000,
            round(self.fps * 1000),
        )

    def _s_parm(self, a) -> None:
        tpf = a.parm.capture.timeperframe
        self.fps = float(min(self.rates, key=lambda r: abs(r - tpf.denominator / tpf.numerator)))
        self._g_parm(a)

    def _s_input(self, a) -> None:
        if a.value != 0:
            raise _oserror(errno.EINVAL)

    def _reqbufs(self, a) -> None:
        if self.streaming:
            raise _oserror(errno.EBUSY)
        size = (self.sizeimage + PAGE - 1) // PAGE * PAGE
        self.buffers = [mmap.mmap(-1, size) for _ in range(min(a.count, 32))]
        self.queued.clear()
        self.done.clear()
        a.count = len(self.buffers)

    def _querybuf(self, a) -> None:
        if a.index >= len(self.buffers):
            raise _oserror(errno.EINVAL)
        a.length, a.m.offset = len(self.buffers[a.index]), a.index * len(self.buffers[0])

    def _qbuf(self, a) -> None:
        if a.index >= len(self.buffers) or a.index in self.queued:
            raise _oserror(errno.EINVAL)
        self.queued.append(a.index)
        ctypes.memset(ctypes.addressof(a), 0, ctypes.sizeof(a))  # the kernel rewrites the struct: no metadata
        a.flags = abi.BUF_FLAG_QUEUED | abi.BUF_FLAG_MAPPED

    def _dqbuf(self, a) -> None:
        if not self.done:
            raise _oserror(errno.EAGAIN)
        index, used, seq, t_ns, flags = self.done.popleft()
        a.index, a.bytesused, a.sequence, a.flags, a.field = index, used, seq, flags | abi.BUF_FLAG_DONE, 1
        a.timestamp.tv_sec, a.timestamp.tv_usec = divmod(t_ns // 1000, 1_000_000)

    def _streamon(self, a) -> None:
        self.streaming, self.sequence = True, 0

    def _streamoff(self, a) -> None:
        self.streaming = False
        self.queued.clear()
        self.done.clear()

    def _next_control(self, cid: int) -> FakeControl:
        if cid & abi.CTRL_FLAG_NEXT_CTRL:
            later = sorted(i for i in self.controls if i > cid & abi.CTRL_ID_MASK)
            if not later:
                raise _oserror(errno.EINVAL)
            return self.controls[later[0]]
        if cid not in self.controls:
            raise _oserror(errno.EINVAL)
        return self.controls[cid]

    def _query_ext_ctrl(self, a) -> None:
        if not self.ext_ctrls:
            raise _oserror(errno.ENOTTY)
        self._queryctrl(a)

    def _queryctrl(self, a) -> None:
        c = self._next_control(a.id)
        a.id, a.type, a.name, a.flags = c.id, c.type, c.label.encode(), c.flags
        a.minimum, a.maximum, a.step, a.default_value = c.minimum, c.maximum, c.step, c.default

    def _querymenu(self, a) -> None:
        c = self.controls.get(a.id)
        if c is None or a.index not in c.menu:
            raise _oserror(errno.EINVAL)
        a.name = c.menu[a.index].encode()

    def _g_ctrl(self, a) -> None:
        a.value = self._control(a.id).value

    def _s_ctrl(self, a) -> None:
        c = self._control(a.id)
        if c.type == abi.CTRL_TYPE_BUTTON:
            c.presses += 1
            return
        if c.flags & abi.CTRL_FLAG_READ_ONLY:
            raise _oserror(errno.EACCES)
        if not c.minimum <= a.value <= c.maximum or (c.menu and a.value not in c.menu):
            raise _oserror(errno.ERANGE)
        c.value = a.value

    def _g_ext_ctrls(self, a) -> None:
        a.controls[0].value64 = self._control(a.controls[0].id).value

    def _s_ext_ctrls(self, a) -> None:
        self._control(a.controls[0].id).value = a.controls[0].value64

    def _control(self, cid: int) -> FakeControl:
        if cid not in self.controls:
            raise _oserror(errno.EINVAL)
        return self.controls[cid]


class FakeKernel(Kernel):
    """The Kernel chokepoint over fake devices, by path."""

    def __init__(self, devices: dict[str, FakeDevice]) -> None:
        self.devices = devices
        self._fds: dict[int, FakeDevice] = {}
        self._next_fd = 1000

    def open(self, path: str, flags: int = 0) -> int:
        device = self.devices.get(path)
        if device is None:
            raise _oserror(errno.ENOENT)
        if device.gone:
            raise _oserror(errno.ENODEV)
        self._next_fd += 1
        self._fds[self._next_fd] = device
        return self._next_fd

    def close(self, fd: int) -> None:
        device = self._fds.pop(fd)
        if not any(d is device for d in self._fds.values()):
            device.streaming = False
            device.buffers = []

    def _device(self, fd: int) -> FakeDevice:
        if fd not in self._fds:
            raise _oserror(errno.EBADF)
        return self._fds[fd]

    def ioctl(self, fd: int, request: int, arg) -> None:
        self._device(fd).ioctl(request, arg)

    def mmap(self, fd: int, length: int, offset: int) -> mmap.mmap:
        device = self._device(fd)
        return device.buffers[offset // len(device.buffers[0])]

    def poll(self, fd: int, timeout_s: float) -> int:
        device = self._device(fd)
        with device.cond:
            device.cond.wait_for(lambda: device.done or device.gone, timeout=timeout_s)
            if device.gone:
                return select.POLLERR | select.POLLHUP
            return select.POLLIN if device.done else 0
