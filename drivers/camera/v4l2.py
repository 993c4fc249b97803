"""One V4L2 capture camera: open by path, negotiate format/size/rate, mmap streaming, frames with metadata.

Why our own layer: integer-ns kernel timestamps, flag bits, controls on
sub-device nodes and zero-copy frames, with no GPL dependency (linuxpy is
GPL-3.0). Every system call goes through the `Kernel` chokepoint (drivers/kernel.py),
which tests replace with a fake device.

    cam = V4L2Camera(CameraSettings("/dev/mast/cam-left", 2048, 1536, "GREY", fps=10))
    cam.start()
    frame = cam.read(timeout_s=1.0)      # owned grey image, buffer already re-queued
    cam.close()

Open by a udev stable name (/dev/mast/cam-left; systemd/ ships the rules), not
/dev/videoN, whose numbering follows probe order. The device must report
VIDEO_CAPTURE and STREAMING (QUERYCAP). The format is set with S_FMT and read
back: if the driver substitutes another pixel format or size, `FormatError`
lists the formats and sizes it offers (ENUM_FMT, ENUM_FRAMESIZES); likewise a
frame rate S_PARM cannot honour within 1 % lists the intervals it offers.
`fps=None` leaves the rate alone (externally triggered cameras).

Frames, and the copy rule:

- `dequeue(timeout_s)` -> `Frame` whose `image` is a numpy view into the mmap'ed
  buffer (GREY, Y16 and YUYV: no pixel copied; MJPEG: decoded). The view is
  valid only until `requeue(frame)`; after that the driver overwrites it.
- `read(timeout_s)` = dequeue, make the one copy (`to_grey(copy=True)`), requeue:
  the frame owns its pixels. This is what the pair source uses.

Per frame: `sequence`, the kernel timestamp `t_ns` (integer ns), `clock`
("monotonic", "copy" or "unknown" from the timestamp-type flags), `source`
("soe" start of exposure / "eof" end of frame), the raw `flags`, and
`t_dequeued_ns` (CLOCK_MONOTONIC when we got it). All are read from the
dequeued v4l2_buffer before anything re-queues it (QBUF is _IOWR and rewrites
the structure it is given). Frames stamped before STREAMON (stale frames some
drivers keep queued from a previous trigger session) and the first
`skip_frames` are re-queued unseen (`stale`); buffers flagged ERROR are
re-queued and counted (`corrupt`), as are undecodable MJPEG frames.
Sequence gaps count in `dropped` (drivers/camera/pairing.SequenceTracker).
ENODEV/EIO while streaming raise `CameraGone`; POLLERR/POLLHUP with nothing
to dequeue as well.
"""

from __future__ import annotations

import select
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from drivers.camera import v4l2_abi as abi
from drivers.camera.pairing import SequenceTracker
from drivers.camera.v4l2_convert import BY_FOURCC, CorruptFrame, pixel_format, to_grey
from drivers.camera.v4l2_node import CameraGone, ControlError, DeviceError, FormatError, Node
from drivers.kernel import LINUX, Kernel

__all__ = [
    "CameraGone",
    "CameraSettings",
    "ControlError",
    "DeviceError",
    "FormatError",
    "Frame",
    "V4L2Camera",
]

CLOCKS = {abi.BUF_FLAG_TIMESTAMP_MONOTONIC: "monotonic", abi.BUF_FLAG_TIMESTAMP_COPY: "copy"}


@dataclass(frozen=True)
class CameraSettings:
    """What to open and how to configure it (the `cameras:` block's per-camera part)."""

    device: str
    width: int
    height: int
    pixel_format: str = "GREY"
    fps: float | None = None  # None: leave the rate to the driver / the trigger
    buffers: int = 4
    input: int | None = None  # VIDIOC_S_INPUT, if the node has several inputs
    controls: Mapping[str, object] = field(default_factory=dict)  # e.g. {"exposure_time_absolute": 100}
    subdevice: str | None = None  # a /dev/v4l-subdevN whose controls come first (Alvium on i.MX/Jetson)
    skip_frames: int = 0  # frames to throw away after each STREAMON


@dataclass(frozen=True, slots=True)
class Frame:
    image: np.ndarray  # (H, W) uint8 grey: a view until requeue (dequeue) or owned (read)
    sequence: int
    t_ns: int  # the kernel's timestamp
    clock: str  # "monotonic", "copy", "unknown"
    source: str  # "soe" or "eof"
    flags: int
    index: int  # buffer index
    bytesused: int
    t_dequeued_ns: int  # CLOCK_MONOTONIC at DQBUF

    @property
    def monotonic(self) -> bool:
        return self.clock == "monotonic"


class V4L2Camera:
    """An open, configured capture node; `start()` streams, `read()`/`dequeue()` deliver frames."""

    def __init__(
        self,
        settings: CameraSettings,
        *,
        kernel: Kernel = LINUX,
        clock: Callable[[], int] = time.monotonic_ns,
    ) -> None:
        self.settings, self.kernel, self._clock = settings, kernel, clock
        self.path = settings.device
        self.format = pixel_format(settings.pixel_format)
        self.node = Node(self.path, kernel=kernel)
        self.subnode: Node | None = None
        self._maps: list = []
        self._views: list[np.ndarray] = []
        self._queued = 0
        self.streaming = False
        self.t_streamon_ns = 0
        self.tracker = SequenceTracker()
        self.frames = self.corrupt = self.stale = 0
        self._to_skip = 0
        try:
            self._check_caps()
            if settings.input is not None:
                self.node.ioctl(abi.VIDIOC_S_INPUT, abi.ctypes.c_int(settings.input))
            self._set_format()
            self.fps = self._set_rate(settings.fps)
            if settings.subdevice:
                self.subnode = Node(settings.subdevice, kernel=kernel)
            for name, value in settings.controls.items():
                self.set_control(name, value)
        except BaseException:
            self.close()
            raise

    # --- configuration -------------------------------------------------------------------------

    def _check_caps(self) -> None:
        cap = abi.v4l2_capability()
        self.node.ioctl(abi.VIDIOC_QUERYCAP, cap)
        caps = cap.device_caps if cap.capabilities & abi.CAP_DEVICE_CAPS else cap.capabilities
        self.driver, self.card = cap.driver.decode(errors="replace"), cap.card.decode(errors="replace")
        missing = [
            n
            for bit, n in ((abi.CAP_VIDEO_CAPTURE, "video capture"), (abi.CAP_STREAMING, "streaming"))
            if not caps & bit
        ]
        if missing:
            hint = " (multi-planar capture is not supported)" if caps & abi.CAP_VIDEO_CAPTURE_MPLANE else ""
            raise DeviceError(self.path, f"{self.driver} '{self.card}' lacks {' and '.join(missing)}{hint}")

    def offered_formats(self) -> dict[str, list[str]]:
        """Pixel format -> its frame sizes, as the driver enumerates them."""
        return self.node.offered_formats()

    def _describe_offers(self) -> str:
        offers = self.offered_formats()
        return (
            "; ".join(f"{f} {' '.join(s) or '(sizes not enumerated)'}" for f, s in offers.items())
            or "nothing"
        )

    def _set_format(self) -> None:
        s = self.settings
        fmt = abi.v4l2_format(type=abi.BUF_TYPE_VIDEO_CAPTURE)
        pix = fmt.fmt.pix
        pix.width, pix.height, pix.pixelformat, pix.field = (
            s.width,
            s.height,
            self.format.fourcc,
            abi.FIELD_NONE,
        )
        self.node.ioctl(abi.VIDIOC_S_FMT, fmt)
        self.node.ioctl(abi.VIDIOC_G_FMT, fmt)
        got = abi.fourcc_str(pix.pixelformat)
        if pix.pixelformat != self.format.fourcc or (pix.width, pix.height) != (s.width, s.height):
            raise FormatError(
                self.path,
                f"asked for {self.format.name} {s.width}x{s.height}, the driver set "
                f"{got} {pix.width}x{pix.height}; it offers: {self._describe_offers()}",
            )
        self.width, self.height = pix.width, pix.height
        self.bytesperline, self.sizeimage = pix.bytesperline, pix.sizeimage
        if BY_FOURCC[pix.pixelformat].bytes_per_pixel == 0:
            self.bytesperline = 0

    def _set_rate(self, fps: float | None) -> float | None:
        parm = abi.v4l2_streamparm(type=abi.BUF_TYPE_VIDEO_CAPTURE)
        if self.node.try_ioctl(abi.VIDIOC_G_PARM, parm) and fps is None:
            return None
        cp = parm.parm.capture
        if fps is not None:
            if not cp.capability & abi.CAP_TIMEPERFRAME:
                raise FormatError(
                    self.path,
                    f"cannot set {fps} fps: the driver has no frame-rate setting "
                    "(leave fps unset for a triggered camera)",
                )
            interval = Fraction(1 / fps).limit_denominator(100_000)
            cp.timeperframe.numerator, cp.timeperframe.denominator = interval.numerator, interval.denominator
            self.node.ioctl(abi.VIDIOC_S_PARM, parm)
        tpf = cp.timeperframe
        actual = tpf.denominator / tpf.numerator if tpf.numerator else None
        if fps is not None and (actual is None or abs(actual - fps) > 0.01 * fps):
            offers = self.node.offered_rates(self.format.fourcc, self.width, self.height)
            raise FormatError(
                self.path,
                f"asked for {fps} fps, the driver set {actual}; "
                f"it offers at {self.width}x{self.height}: {offers}",
            )
        return actual

    # --- controls -------------------------------------------------------------------------------

    def _control_node(self, name: str) -> Node:
        if self.subnode is not None:
            try:
                self.subnode.control(name)
                return self.subnode
            except ControlError:
                pass
        return self.node

    def set_control(self, name: str, value: object) -> int:
        """Set a control by name, on the sub-device if it has it, else on the video node."""
        return self._control_node(name).set(name, value)

    def get_control(self, name: str) -> int:
        return self._control_node(name).get(name)

    def has_control(self, name: str) -> bool:
        try:
            self._control_node(name).control(name)
        except ControlError:
            return False
        return True

    # --- streaming ------------------------------------------------------------------------------

    def start(self) -> None:
        """REQBUFS + mmap the buffers, queue them all, STREAMON."""
        if self.streaming:
            return
        req = abi.v4l2_requestbuffers(
            count=self.settings.buffers, type=abi.BUF_TYPE_VIDEO_CAPTURE, memory=abi.MEMORY_MMAP
        )
        self.node.ioctl(abi.VIDIOC_REQBUFS, req)
        if req.count < 2:
            raise DeviceError(self.path, f"driver granted {req.count} buffers, need at least 2")
        for index in range(req.count):
            buf = abi.v4l2_buffer(index=index, type=abi.BUF_TYPE_VIDEO_CAPTURE, memory=abi.MEMORY_MMAP)
            self.node.ioctl(abi.VIDIOC_QUERYBUF, buf)
            try:
                mm = self.kernel.mmap(self.node.open_fd, buf.length, buf.m.offset)
            except OSError as exc:
                raise DeviceError(self.path, f"mmap of buffer {index} failed ({exc})", exc.errno) from None
            self._maps.append(mm)
            self._views.append(np.frombuffer(mm, dtype=np.uint8))
        for index in range(req.count):
            self._qbuf(index)
        self.tracker.restart()
        self._to_skip = self.settings.skip_frames
        self.t_streamon_ns = self._clock()
        self.node.ioctl(abi.VIDIOC_STREAMON, abi.ctypes.c_int(abi.BUF_TYPE_VIDEO_CAPTURE))
        self.streaming = True

    def _qbuf(self, index: int) -> None:
        buf = abi.v4l2_buffer(index=index, type=abi.BUF_TYPE_VIDEO_CAPTURE, memory=abi.MEMORY_MMAP)
        self.node.ioctl(abi.VIDIOC_QBUF, buf)
        self._queued += 1

    def requeue(self, frame: Frame) -> None:
        """Give the frame's buffer back to the driver; its `image` view must not be used afterwards."""
        if self.streaming:
            self._qbuf(frame.index)

    def dequeue(self, timeout_s: float) -> Frame | None:
        """The next frame as a view into its buffer (see the module doc), or None after `timeout_s`."""
        if not self.streaming:
            raise DeviceError(self.path, "not streaming (call start())")
        deadline = self._clock() + round(timeout_s * 1e9)
        while True:
            frame = self._dequeue_one(max(0.0, (deadline - self._clock()) / 1e9))
            if frame is None or self._accept(frame):
                return frame
            self.requeue(frame)

    def _dequeue_one(self, timeout_s: float) -> Frame | None:
        if self._queued == 0:
            raise DeviceError(self.path, "every buffer is held by the caller: requeue() frames")
        events = self.kernel.poll(self.node.open_fd, timeout_s)
        if not events:
            return None
        buf = abi.v4l2_buffer(type=abi.BUF_TYPE_VIDEO_CAPTURE, memory=abi.MEMORY_MMAP)
        err = self.node.try_ioctl(abi.VIDIOC_DQBUF, buf)
        if err:
            if events & (select.POLLERR | select.POLLHUP):
                raise CameraGone(self.path, f"poll reported an error and DQBUF failed (errno {err})", err)
            return None  # EAGAIN: woken without a buffer
        self._queued -= 1
        # everything we need from the buffer, before any QBUF can rewrite a v4l2_buffer
        seq, flags, index, used = buf.sequence, buf.flags, buf.index, buf.bytesused
        t_ns = buf.timestamp.tv_sec * 1_000_000_000 + buf.timestamp.tv_usec * 1000
        clock = CLOCKS.get(flags & abi.BUF_FLAG_TIMESTAMP_MASK, "unknown")
        source = "soe" if flags & abi.BUF_FLAG_TSTAMP_SRC_MASK == abi.BUF_FLAG_TSTAMP_SRC_SOE else "eof"
        data = self._views[index][:used]
        try:
            image = (
                None
                if flags & abi.BUF_FLAG_ERROR
                else to_grey(data, self.format, self.width, self.height, self.bytesperline)
            )
        except CorruptFrame:
            image = None
        empty = np.empty((0, 0), np.uint8)
        return Frame(
            empty if image is None else image, seq, t_ns, clock, source, flags, index, used, self._clock()
        )

    def _accept(self, frame: Frame) -> bool:
        self.tracker.update(frame.sequence)
        if frame.monotonic and frame.t_ns < self.t_streamon_ns:
            self.stale += 1  # exposed before this STREAMON: left over from an earlier session
            return False
        if self._to_skip > 0:
            self._to_skip -= 1
            self.stale += 1
            return False
        if frame.image.size == 0:
            self.corrupt += 1
            return False
        self.frames += 1
        return True

    def read(self, timeout_s: float) -> Frame | None:
        """The next frame with its own copy of the pixels, buffer already re-queued; None on timeout."""
        frame = self.dequeue(timeout_s)
        if frame is None:
            return None
        if frame.image.base is None or frame.image.size == 0:  # MJPEG owns its decode; a corrupt frame
            image = frame.image
        else:  # the one copy, made from the buffer (v4l2_convert: Y16 and YUYV at about a memcpy's cost)
            image = to_grey(self._views[frame.index][:frame.bytesused], self.format, self.width, self.height,
                            self.bytesperline, copy=True)
        self.requeue(frame)
        return Frame(
            image,
            frame.sequence,
            frame.t_ns,
            frame.clock,
            frame.source,
            frame.flags,
            frame.index,
            frame.bytesused,
            frame.t_dequeued_ns,
        )

    @property
    def dropped(self) -> int:
        """Frames the driver's sequence numbers say were lost, since open."""
        return self.tracker.drops

    def stop(self) -> None:
        """STREAMOFF and release the buffers (errors ignored: the device may be gone)."""
        if self.streaming and not self.node.closed:
            self.node.try_ioctl_quiet(abi.VIDIOC_STREAMOFF, abi.ctypes.c_int(abi.BUF_TYPE_VIDEO_CAPTURE))
        self.streaming, self._queued = False, 0
        self._views.clear()
        for mm in self._maps:
            try:
                mm.close()
            except BufferError:
                pass  # a caller still holds a view: the mapping lives until that view is gone
        self._maps.clear()
        if not self.node.closed:
            self.node.try_ioctl_quiet(
                abi.VIDIOC_REQBUFS,
                abi.v4l2_requestbuffers(count=0, type=abi.BUF_TYPE_VIDEO_CAPTURE, memory=abi.MEMORY_MMAP),
            )

    def close(self) -> None:
        self.stop()
        for node in (self.subnode, self.node):
            if node is not None:
                node.close()

    def __enter__(self) -> V4L2Camera:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
