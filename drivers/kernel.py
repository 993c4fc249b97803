"""The one place where drivers talk to device nodes: open, close, ioctl, mmap, poll.

V4L2 capture (`drivers.camera.v4l2`) and the GPIO trigger (`drivers.trigger.gpio`)
do every system call on their device through a `Kernel` object, so tests can
hand them a fake device at exactly this chokepoint (the fake implements the
same five methods) and exercise the real driver code above it: struct
layouts, ioctl sequencing, error mapping. `LINUX` is the real thing.

Requests are built with `ioc()` from the kernel's `_IOC` encoding (asm-generic,
as on x86_64 and arm64). `ioctl()` passes a ctypes structure by reference and
the kernel writes its results into it (the `_IOWR` convention), so a caller
reads its fields after the call. Errors surface as `OSError` with the errno.
"""

from __future__ import annotations

import ctypes
import fcntl
import mmap
import os
import select

_IOC_NRBITS, _IOC_TYPEBITS, _IOC_SIZEBITS = 8, 8, 14
_IOC_NRSHIFT = 0
_IOC_TYPESHIFT = _IOC_NRSHIFT + _IOC_NRBITS
_IOC_SIZESHIFT = _IOC_TYPESHIFT + _IOC_TYPEBITS
_IOC_DIRSHIFT = _IOC_SIZESHIFT + _IOC_SIZEBITS
IOC_NONE, IOC_WRITE, IOC_READ = 0, 1, 2


def ioc(direction: int, kind: int | str, nr: int, struct: type | None = None) -> int:
    """The ioctl request number `_IOC(direction, kind, nr, sizeof(struct))`."""
    kind_value = ord(kind) if isinstance(kind, str) else kind
    size = ctypes.sizeof(struct) if struct is not None else 0
    return (
        (direction << _IOC_DIRSHIFT)
        | (kind_value << _IOC_TYPESHIFT)
        | (nr << _IOC_NRSHIFT)
        | (size << _IOC_SIZESHIFT)
    )


def ior(kind: int | str, nr: int, struct: type) -> int:
    return ioc(IOC_READ, kind, nr, struct)


def iow(kind: int | str, nr: int, struct: type) -> int:
    return ioc(IOC_WRITE, kind, nr, struct)


def iowr(kind: int | str, nr: int, struct: type) -> int:
    return ioc(IOC_READ | IOC_WRITE, kind, nr, struct)


class Kernel:
    """System calls on device nodes. Subclass or duck-type it to fake a device."""

    def open(self, path: str, flags: int = os.O_RDWR | os.O_NONBLOCK | os.O_CLOEXEC) -> int:
        return os.open(path, flags)

    def close(self, fd: int) -> None:
        os.close(fd)

    def ioctl(self, fd: int, request: int, arg: ctypes.Structure | ctypes.c_int) -> None:
        """`ioctl(fd, request, &arg)`: the kernel reads and rewrites `arg` in place."""
        fcntl.ioctl(fd, request, arg, True)

    def mmap(self, fd: int, length: int, offset: int) -> mmap.mmap:
        """A shared read/write mapping of `length` bytes of the device at `offset`."""
        return mmap.mmap(fd, length, mmap.MAP_SHARED, mmap.PROT_READ | mmap.PROT_WRITE, offset=offset)

    def poll(self, fd: int, timeout_s: float) -> int:
        """poll(2) for input: the returned event mask (0 on timeout). POLLERR/POLLHUP are reported."""
        poller = select.poll()
        poller.register(fd, select.POLLIN | select.POLLPRI | select.POLLERR | select.POLLHUP)
        events = poller.poll(max(0, round(timeout_s * 1000)))
        return events[0][1] if events else 0

    def read(self, fd: int, size: int) -> bytes:
        return os.read(fd, size)


LINUX = Kernel()
