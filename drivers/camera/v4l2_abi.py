"""The V4L2 kernel ABI we use, as ctypes structures, constants and ioctl numbers (linux/videodev2.h).

Only what capture needs: QUERYCAP, format and frame-size/interval enumeration,
S_FMT/G_FMT, S_PARM/G_PARM, REQBUFS/QUERYBUF/QBUF/DQBUF, STREAMON/OFF, S_INPUT,
and the control ioctls (QUERYCTRL, QUERY_EXT_CTRL, QUERYMENU, G/S_CTRL,
G/S_EXT_CTRLS). Written from the UAPI header, no binding library (linuxpy is
GPL-3.0; this is a dozen structs). Layouts are those of 64-bit userspace
(x86_64, arm64): `struct timeval` of two longs, pointers of 8 bytes; the sizes
are checked against the ioctl numbers the kernel headers give (test_v4l2).
"""

from __future__ import annotations

import ctypes

from drivers.kernel import ior, iow, iowr

u8, u32, s32, s64, u64 = ctypes.c_uint8, ctypes.c_uint32, ctypes.c_int32, ctypes.c_int64, ctypes.c_uint64


def fourcc(code: str) -> int:
    """'YUYV' -> the little-endian u32 V4L2 uses (short codes are space-padded: 'Y16' -> 'Y16 ')."""
    b = code.ljust(4).encode("ascii")
    return b[0] | (b[1] << 8) | (b[2] << 16) | (b[3] << 24)


def fourcc_str(value: int) -> str:
    """The inverse of `fourcc`, trailing spaces removed (big-endian variants keep their '-BE' bit off)."""
    return bytes((value >> s) & 0x7F for s in (0, 8, 16, 24)).decode("ascii", "replace").rstrip()


# capabilities
CAP_VIDEO_CAPTURE = 0x00000001
CAP_VIDEO_CAPTURE_MPLANE = 0x00001000
CAP_STREAMING = 0x04000000
CAP_DEVICE_CAPS = 0x80000000
CAP_TIMEPERFRAME = 0x1000  # v4l2_captureparm.capability

BUF_TYPE_VIDEO_CAPTURE = 1
MEMORY_MMAP = 1
FIELD_ANY, FIELD_NONE = 0, 1

# buffer flags
BUF_FLAG_MAPPED = 0x0001
BUF_FLAG_QUEUED = 0x0002
BUF_FLAG_DONE = 0x0004
BUF_FLAG_ERROR = 0x0040
BUF_FLAG_TIMESTAMP_MASK = 0xE000
BUF_FLAG_TIMESTAMP_UNKNOWN = 0x0000
BUF_FLAG_TIMESTAMP_MONOTONIC = 0x2000
BUF_FLAG_TIMESTAMP_COPY = 0x4000
BUF_FLAG_TSTAMP_SRC_MASK = 0x70000
BUF_FLAG_TSTAMP_SRC_EOF = 0x00000
BUF_FLAG_TSTAMP_SRC_SOE = 0x10000

# frame size / interval enumeration types
FRMSIZE_TYPE_DISCRETE, FRMSIZE_TYPE_CONTINUOUS, FRMSIZE_TYPE_STEPWISE = 1, 2, 3
FRMIVAL_TYPE_DISCRETE, FRMIVAL_TYPE_CONTINUOUS, FRMIVAL_TYPE_STEPWISE = 1, 2, 3

# controls
CTRL_TYPE_INTEGER = 1
CTRL_TYPE_BOOLEAN = 2
CTRL_TYPE_MENU = 3
CTRL_TYPE_BUTTON = 4
CTRL_TYPE_INTEGER64 = 5
CTRL_TYPE_CTRL_CLASS = 6
CTRL_TYPE_STRING = 7
CTRL_TYPE_BITMASK = 8
CTRL_TYPE_INTEGER_MENU = 9
CTRL_TYPE_NAMES = {1: "int", 2: "bool", 3: "menu", 4: "button", 5: "int64", 6: "class", 7: "string",
                   8: "bitmask", 9: "intmenu"}
CTRL_FLAG_DISABLED = 0x0001
CTRL_FLAG_GRABBED = 0x0002
CTRL_FLAG_READ_ONLY = 0x0004
CTRL_FLAG_INACTIVE = 0x0010
CTRL_FLAG_WRITE_ONLY = 0x0040
CTRL_FLAG_VOLATILE = 0x0080
CTRL_FLAG_NEXT_CTRL = 0x80000000
CTRL_FLAG_NEXT_COMPOUND = 0x40000000
CTRL_ID_MASK = 0x0FFFFFFF
CTRL_WHICH_CUR_VAL = 0


class v4l2_capability(ctypes.Structure):
    _fields_ = [("driver", ctypes.c_char * 16), ("card", ctypes.c_char * 32),
                ("bus_info", ctypes.c_char * 32), ("version", u32), ("capabilities", u32),
                ("device_caps", u32), ("reserved", u32 * 3)]


class v4l2_fmtdesc(ctypes.Structure):
    _fields_ = [("index", u32), ("type", u32), ("flags", u32), ("description", ctypes.c_char * 32),
                ("pixelformat", u32), ("mbus_code", u32), ("reserved", u32 * 3)]


class v4l2_frmsize_discrete(ctypes.Structure):
    _fields_ = [("width", u32), ("height", u32)]


class v4l2_frmsize_stepwise(ctypes.Structure):
    _fields_ = [("min_width", u32), ("max_width", u32), ("step_width", u32),
                ("min_height", u32), ("max_height", u32), ("step_height", u32)]


class _frmsize_union(ctypes.Union):
    _fields_ = [("discrete", v4l2_frmsize_discrete), ("stepwise", v4l2_frmsize_stepwise)]


class v4l2_frmsizeenum(ctypes.Structure):
    _anonymous_ = ("u",)
    _fields_ = [("index", u32), ("pixel_format", u32), ("type", u32), ("u", _frmsize_union),
                ("reserved", u32 * 2)]


class v4l2_fract(ctypes.Structure):
    _fields_ = [("numerator", u32), ("denominator", u32)]


class v4l2_frmival_stepwise(ctypes.Structure):
    _fields_ = [("min", v4l2_fract), ("max", v4l2_fract), ("step", v4l2_fract)]


class _frmival_union(ctypes.Union):
    _fields_ = [("discrete", v4l2_fract), ("stepwise", v4l2_frmival_stepwise)]


class v4l2_frmivalenum(ctypes.Structure):
    _anonymous_ = ("u",)
    _fields_ = [("index", u32), ("pixel_format", u32), ("width", u32), ("height", u32), ("type", u32),
                ("u", _frmival_union), ("reserved", u32 * 2)]


class v4l2_pix_format(ctypes.Structure):
    _fields_ = [("width", u32), ("height", u32), ("pixelformat", u32), ("field", u32),
                ("bytesperline", u32), ("sizeimage", u32), ("colorspace", u32), ("priv", u32),
                ("flags", u32), ("ycbcr_enc", u32), ("quantization", u32), ("xfer_func", u32)]


class _format_union(ctypes.Union):
    # v4l2_window holds pointers, which gives the union pointer alignment
    _fields_ = [("pix", v4l2_pix_format), ("raw_data", u8 * 200), ("_align", ctypes.c_void_p)]


class v4l2_format(ctypes.Structure):
    _fields_ = [("type", u32), ("fmt", _format_union)]


class v4l2_captureparm(ctypes.Structure):
    _fields_ = [("capability", u32), ("capturemode", u32), ("timeperframe", v4l2_fract),
                ("extendedmode", u32), ("readbuffers", u32), ("reserved", u32 * 4)]


class _streamparm_union(ctypes.Union):
    _fields_ = [("capture", v4l2_captureparm), ("raw_data", u8 * 200)]


class v4l2_streamparm(ctypes.Structure):
    _fields_ = [("type", u32), ("parm", _streamparm_union)]


class v4l2_requestbuffers(ctypes.Structure):
    _fields_ = [("count", u32), ("type", u32), ("memory", u32), ("capabilities", u32),
                ("flags", u8), ("reserved", u8 * 3)]


class timeval(ctypes.Structure):
    _fields_ = [("tv_sec", ctypes.c_long), ("tv_usec", ctypes.c_long)]


class v4l2_timecode(ctypes.Structure):
    _fields_ = [("type", u32), ("flags", u32), ("frames", u8), ("seconds", u8), ("minutes", u8),
                ("hours", u8), ("userbits", u8 * 4)]


class _buffer_m(ctypes.Union):
    _fields_ = [("offset", u32), ("userptr", ctypes.c_ulong), ("planes", ctypes.c_void_p), ("fd", s32)]


class v4l2_buffer(ctypes.Structure):
    _fields_ = [("index", u32), ("type", u32), ("bytesused", u32), ("flags", u32), ("field", u32),
                ("timestamp", timeval), ("timecode", v4l2_timecode), ("sequence", u32), ("memory", u32),
                ("m", _buffer_m), ("length", u32), ("reserved2", u32), ("request_fd", s32)]


class v4l2_queryctrl(ctypes.Structure):
    _fields_ = [("id", u32), ("type", u32), ("name", ctypes.c_char * 32), ("minimum", s32), ("maximum", s32),
                ("step", s32), ("default_value", s32), ("flags", u32), ("reserved", u32 * 2)]


class v4l2_query_ext_ctrl(ctypes.Structure):
    _fields_ = [("id", u32), ("type", u32), ("name", ctypes.c_char * 32), ("minimum", s64), ("maximum", s64),
                ("step", u64), ("default_value", s64), ("flags", u32), ("elem_size", u32), ("elems", u32),
                ("nr_of_dims", u32), ("dims", u32 * 4), ("reserved", u32 * 32)]


class _querymenu_union(ctypes.Union):
    _pack_ = 1
    _fields_ = [("name", ctypes.c_char * 32), ("value", s64)]


class v4l2_querymenu(ctypes.Structure):
    _pack_ = 1
    _anonymous_ = ("u",)
    _fields_ = [("id", u32), ("index", u32), ("u", _querymenu_union), ("reserved", u32)]


class v4l2_control(ctypes.Structure):
    _fields_ = [("id", u32), ("value", s32)]


class _ext_control_union(ctypes.Union):
    _pack_ = 1
    _fields_ = [("value", s32), ("value64", s64), ("ptr", ctypes.c_void_p)]


class v4l2_ext_control(ctypes.Structure):
    _pack_ = 1
    _anonymous_ = ("u",)
    _fields_ = [("id", u32), ("size", u32), ("reserved2", u32), ("u", _ext_control_union)]


class v4l2_ext_controls(ctypes.Structure):
    _fields_ = [("which", u32), ("count", u32), ("error_idx", u32), ("request_fd", s32), ("reserved", u32),
                ("controls", ctypes.POINTER(v4l2_ext_control))]


VIDIOC_QUERYCAP = ior("V", 0, v4l2_capability)
VIDIOC_ENUM_FMT = iowr("V", 2, v4l2_fmtdesc)
VIDIOC_G_FMT = iowr("V", 4, v4l2_format)
VIDIOC_S_FMT = iowr("V", 5, v4l2_format)
VIDIOC_REQBUFS = iowr("V", 8, v4l2_requestbuffers)
VIDIOC_QUERYBUF = iowr("V", 9, v4l2_buffer)
VIDIOC_QBUF = iowr("V", 15, v4l2_buffer)
VIDIOC_DQBUF = iowr("V", 17, v4l2_buffer)
VIDIOC_STREAMON = iow("V", 18, ctypes.c_int)
VIDIOC_STREAMOFF = iow("V", 19, ctypes.c_int)
VIDIOC_G_PARM = iowr("V", 21, v4l2_streamparm)
VIDIOC_S_PARM = iowr("V", 22, v4l2_streamparm)
VIDIOC_G_CTRL = iowr("V", 27, v4l2_control)
VIDIOC_S_CTRL = iowr("V", 28, v4l2_control)
VIDIOC_QUERYCTRL = iowr("V", 36, v4l2_queryctrl)
VIDIOC_QUERYMENU = iowr("V", 37, v4l2_querymenu)
VIDIOC_G_INPUT = ior("V", 38, ctypes.c_int)
VIDIOC_S_INPUT = iowr("V", 39, ctypes.c_int)
VIDIOC_G_EXT_CTRLS = iowr("V", 71, v4l2_ext_controls)
VIDIOC_S_EXT_CTRLS = iowr("V", 72, v4l2_ext_controls)
VIDIOC_ENUM_FRAMESIZES = iowr("V", 74, v4l2_frmsizeenum)
VIDIOC_ENUM_FRAMEINTERVALS = iowr("V", 75, v4l2_frmivalenum)
VIDIOC_QUERY_EXT_CTRL = iowr("V", 103, v4l2_query_ext_ctrl)

IOCTL_NAMES = {v: k for k, v in globals().items() if k.startswith("VIDIOC_")}
