"""An open V4L2 device node (video or sub-device): errors, what it offers, its controls by name.

`Node(path)` opens the node through the `Kernel` chokepoint (drivers/kernel.py)
and maps errno to this driver's errors, each carrying the device path:

- `DeviceError`: the node cannot be opened or refuses an ioctl;
- `FormatError` (a DeviceError): the requested format/size/rate is not offered;
  its message lists what the device offers instead;
- `ControlError` (a DeviceError): an unknown control, or a value it does not take;
- `CameraGone` (a DeviceError): ENODEV/EIO/ENXIO/ESHUTDOWN: the device went away
  or the driver reset it. The caller closes and reopens it (v4l2_pair does, with backoff).

Controls are found by name the way v4l2-ctl prints them (`normalise_name`:
lowercase, every run of non-alphanumerics one '_', none at either end), by
enumerating with VIDIOC_QUERY_EXT_CTRL | NEXT_CTRL (falling back to QUERYCTRL on
old kernels), never by hard-coded vendor ids: Alvium's trigger controls sit in
the camera class range and may collide with future mainline ids. The same code
works on `/dev/videoN` and on `/dev/v4l-subdevN` (Alvium on media-controller
platforms exposes its trigger controls on the sensor's sub-device). Menus take
an item name (matched after normalisation) or an index; booleans take
true/false/on/off/1/0; buttons are pressed by setting any value.
"""

from __future__ import annotations

import ctypes
import errno
import re
from dataclasses import dataclass, field

from drivers.camera import v4l2_abi as abi
from drivers.kernel import LINUX, Kernel

GONE_ERRNOS = frozenset({errno.ENODEV, errno.EIO, errno.ENXIO, errno.ESHUTDOWN})


class DeviceError(Exception):
    """A V4L2 device failed or refused a request; `path` names the node."""

    def __init__(self, path: str, message: str, errno_: int | None = None) -> None:
        self.path, self.errno = path, errno_
        super().__init__(f"{path}: {message}")


class FormatError(DeviceError):
    """The requested pixel format, size or frame rate is not offered (the message lists what is)."""


class ControlError(DeviceError):
    """No such control, or a value the control does not accept."""


class CameraGone(DeviceError):
    """The device disappeared or was reset mid-stream (ENODEV, EIO): close it and reopen it."""


def normalise_name(name: str) -> str:
    """A control name as v4l2-ctl spells it: 'Trigger Activation' -> 'trigger_activation'."""
    return "_".join(re.findall(r"[a-z0-9]+", name.lower()))


@dataclass(frozen=True)
class Control:
    """One control as the driver describes it (VIDIOC_QUERY_EXT_CTRL), with its menu items."""

    id: int
    name: str  # normalised, as used to address it
    label: str  # the driver's own name
    type: int
    minimum: int
    maximum: int
    step: int
    default: int
    flags: int
    menu: dict[int, str | int] = field(default_factory=dict)  # index -> item name (or integer-menu value)

    @property
    def type_name(self) -> str:
        return abi.CTRL_TYPE_NAMES.get(self.type, str(self.type))

    @property
    def read_only(self) -> bool:
        return bool(self.flags & abi.CTRL_FLAG_READ_ONLY)

    @property
    def write_only(self) -> bool:
        return bool(self.flags & abi.CTRL_FLAG_WRITE_ONLY)

    def describe(self) -> str:
        if self.menu:
            items = ", ".join(f"{i}: {v}" for i, v in self.menu.items())
            return f"{self.name} ({self.type_name}: {items})"
        if self.type in (abi.CTRL_TYPE_INTEGER, abi.CTRL_TYPE_INTEGER64):
            return f"{self.name} (int {self.minimum}..{self.maximum} step {self.step})"
        return f"{self.name} ({self.type_name})"


class Node:
    """An open device node: ioctls with errors mapped to this driver's exceptions, and its controls."""

    def __init__(self, path: str, *, kernel: Kernel = LINUX) -> None:
        self.path, self.kernel = str(path), kernel
        self._controls: dict[str, Control] | None = None
        try:
            self.fd: int | None = kernel.open(self.path)
        except OSError as exc:
            raise DeviceError(self.path, f"cannot open ({exc.strerror})", exc.errno) from None

    def close(self) -> None:
        if self.fd is not None:
            fd, self.fd = self.fd, None
            try:
                self.kernel.close(fd)
            except OSError:
                pass  # a vanished device may refuse even close; the fd is released regardless

    @property
    def closed(self) -> bool:
        return self.fd is None

    @property
    def open_fd(self) -> int:
        """The descriptor of the open node; DeviceError once it is closed."""
        if self.fd is None:
            raise DeviceError(self.path, "device is closed")
        return self.fd

    def ioctl(self, request: int, arg, what: str | None = None) -> None:
        """The ioctl, raising CameraGone for a vanished device and DeviceError for other refusals."""
        if self.fd is None:
            raise DeviceError(self.path, "device is closed")
        try:
            self.kernel.ioctl(self.fd, request, arg)
        except OSError as exc:
            name = what or abi.IOCTL_NAMES.get(request, hex(request))
            cls = CameraGone if exc.errno in GONE_ERRNOS else DeviceError
            raise cls(self.path, f"{name} failed ({exc.strerror or exc})", exc.errno) from None

    def try_ioctl(self, request: int, arg) -> int:
        """The ioctl; 0 on success, else the errno (CameraGone still raised: the device is gone)."""
        try:
            self.ioctl(request, arg)
        except CameraGone:
            raise
        except DeviceError as exc:
            return exc.errno or -1
        return 0

    def try_ioctl_quiet(self, request: int, arg) -> int:
        """The ioctl with every failure swallowed (teardown of a device that may be gone); the errno or 0."""
        try:
            return self.try_ioctl(request, arg)
        except CameraGone as exc:
            return exc.errno or -1

    # --- formats --------------------------------------------------------------------------------

    def offered_formats(self) -> dict[str, list[str]]:
        """Pixel format -> its frame sizes ('WxH', or 'WxH..WxH' ranges): ENUM_FMT, ENUM_FRAMESIZES."""
        out: dict[str, list[str]] = {}
        for index in range(64):
            desc = abi.v4l2_fmtdesc(index=index, type=abi.BUF_TYPE_VIDEO_CAPTURE)
            if self.try_ioctl(abi.VIDIOC_ENUM_FMT, desc):
                break
            out[abi.fourcc_str(desc.pixelformat)] = self._sizes(desc.pixelformat)
        return out

    def _sizes(self, code: int) -> list[str]:
        sizes = []
        for index in range(256):
            fs = abi.v4l2_frmsizeenum(index=index, pixel_format=code)
            if self.try_ioctl(abi.VIDIOC_ENUM_FRAMESIZES, fs):
                break
            if fs.type == abi.FRMSIZE_TYPE_DISCRETE:
                sizes.append(f"{fs.discrete.width}x{fs.discrete.height}")
            else:
                s = fs.stepwise
                sizes.append(f"{s.min_width}x{s.min_height}..{s.max_width}x{s.max_height}")
                break
        return sizes

    def offered_rates(self, code: int, width: int, height: int) -> str:
        """The frame rates offered for a format and size (ENUM_FRAMEINTERVALS), as text."""
        rates = []
        for index in range(64):
            fi = abi.v4l2_frmivalenum(index=index, pixel_format=code, width=width, height=height)
            if self.try_ioctl(abi.VIDIOC_ENUM_FRAMEINTERVALS, fi):
                break
            if fi.type != abi.FRMIVAL_TYPE_DISCRETE:
                lo, hi = fi.stepwise.max, fi.stepwise.min
                rates.append(f"{lo.denominator / lo.numerator:g}..{hi.denominator / hi.numerator:g} fps")
                break
            rates.append(f"{fi.discrete.denominator / fi.discrete.numerator:g} fps")
        return ", ".join(rates) or "nothing enumerated"

    # --- controls -------------------------------------------------------------------------------

    @property
    def controls(self) -> dict[str, Control]:
        """Every control of the node by normalised name (enumerated once, on first use)."""
        if self._controls is None:
            self._controls = {c.name: c for c in self._enumerate()}
        return self._controls

    def _enumerate(self) -> list[Control]:
        found: list[Control] = []
        q: abi.v4l2_query_ext_ctrl | abi.v4l2_queryctrl
        q = abi.v4l2_query_ext_ctrl(id=abi.CTRL_FLAG_NEXT_CTRL)
        ext = self.try_ioctl(abi.VIDIOC_QUERY_EXT_CTRL, q) == 0
        if not ext:
            q = abi.v4l2_queryctrl(id=abi.CTRL_FLAG_NEXT_CTRL)
            if self.try_ioctl(abi.VIDIOC_QUERYCTRL, q) != 0:
                return found
        request = abi.VIDIOC_QUERY_EXT_CTRL if ext else abi.VIDIOC_QUERYCTRL
        while True:
            if q.type != abi.CTRL_TYPE_CTRL_CLASS and not q.flags & abi.CTRL_FLAG_DISABLED:
                label = q.name.decode("utf-8", "replace")
                found.append(
                    Control(
                        q.id,
                        normalise_name(label),
                        label,
                        q.type,
                        q.minimum,
                        q.maximum,
                        q.step,
                        q.default_value,
                        q.flags,
                        self._menu(q),
                    )
                )
            next_id = q.id | abi.CTRL_FLAG_NEXT_CTRL
            q = type(q)(id=next_id)
            if self.try_ioctl(request, q) != 0:
                return found

    def _menu(self, q) -> dict[int, str | int]:
        if q.type not in (abi.CTRL_TYPE_MENU, abi.CTRL_TYPE_INTEGER_MENU):
            return {}
        items: dict[int, str | int] = {}
        for index in range(q.minimum, q.maximum + 1):
            m = abi.v4l2_querymenu(id=q.id, index=index)
            if self.try_ioctl(abi.VIDIOC_QUERYMENU, m) == 0:  # drivers may skip indexes (EINVAL)
                items[index] = (
                    m.value if q.type == abi.CTRL_TYPE_INTEGER_MENU else m.name.decode("utf-8", "replace")
                )
        return items

    def control(self, name: str) -> Control:
        """The control called `name` (any spelling that normalises to it)."""
        key = normalise_name(name)
        try:
            return self.controls[key]
        except KeyError:
            offered = ", ".join(sorted(self.controls)) or "none"
            raise ControlError(self.path, f"no control {key!r} (this device has: {offered})") from None

    def get(self, name: str) -> int:
        """The control's current value (a menu's item index)."""
        c = self.control(name)
        if c.write_only:
            raise ControlError(self.path, f"control {c.name} is write-only")
        if c.type == abi.CTRL_TYPE_INTEGER64:
            return self._ext(abi.VIDIOC_G_EXT_CTRLS, c, 0)
        ctrl = abi.v4l2_control(id=c.id)
        self.ioctl(abi.VIDIOC_G_CTRL, ctrl, f"VIDIOC_G_CTRL {c.name}")
        return ctrl.value

    def get_item(self, name: str) -> str | int:
        """A menu control's current item name (other controls: the value)."""
        c, value = self.control(name), self.get(name)
        return c.menu.get(value, value)

    def set(self, name: str, value: object) -> int:
        """Set the control (menus by item name or index); returns the integer value written."""
        c = self.control(name)
        if c.read_only:
            raise ControlError(self.path, f"control {c.name} is read-only")
        raw = self._coerce(c, value)
        if c.type == abi.CTRL_TYPE_INTEGER64:
            self._ext(abi.VIDIOC_S_EXT_CTRLS, c, raw)
            return raw
        ctrl = abi.v4l2_control(id=c.id, value=raw)
        self.ioctl(abi.VIDIOC_S_CTRL, ctrl, f"VIDIOC_S_CTRL {c.name}={raw}")
        return raw

    def _ext(self, request: int, c: Control, value: int) -> int:
        item = abi.v4l2_ext_control(id=c.id, size=0)
        item.value64 = value
        ctrls = abi.v4l2_ext_controls(which=abi.CTRL_WHICH_CUR_VAL, count=1, controls=ctypes.pointer(item))
        self.ioctl(request, ctrls, f"{abi.IOCTL_NAMES[request]} {c.name}")
        return item.value64

    def _coerce(self, c: Control, value: object) -> int:
        if c.type == abi.CTRL_TYPE_BUTTON:
            return 1
        if c.type == abi.CTRL_TYPE_BOOLEAN:
            flag = _parse_bool(value)
            if flag is None:
                raise ControlError(self.path, f"control {c.name} is a bool; {value!r} is not true/false")
            return int(flag)
        if c.menu:
            return self._menu_index(c, value)
        if isinstance(value, bool) or not isinstance(value, int | str):
            raise ControlError(self.path, f"control {c.name} takes an integer, not {value!r}")
        try:
            number = int(value)
        except ValueError:
            raise ControlError(self.path, f"control {c.name} takes an integer, not {value!r}") from None
        if not c.minimum <= number <= c.maximum:
            raise ControlError(self.path, f"{number} is out of range for {c.describe()}")
        return number

    def _menu_index(self, c: Control, value: object) -> int:
        if isinstance(value, int) and not isinstance(value, bool) and value in c.menu:
            return value
        if isinstance(value, str):
            wanted = normalise_name(value)
            for index, item in c.menu.items():
                if normalise_name(str(item)) == wanted:
                    return index
            if value.strip().isdigit() and int(value) in c.menu:
                return int(value)
        raise ControlError(self.path, f"{value!r} is not an item of {c.describe()}")


def _parse_bool(value: object) -> bool | None:
    if isinstance(value, bool):
        return value
    if isinstance(value, int):
        return bool(value) if value in (0, 1) else None
    if isinstance(value, str):
        return {
            "true": True,
            "on": True,
            "yes": True,
            "1": True,
            "false": False,
            "off": False,
            "no": False,
            "0": False,
        }.get(value.strip().lower())
    return None
