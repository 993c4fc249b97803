"""Captured buffer bytes -> an 8-bit grey image, for the pixel formats the appliance takes.

| format | bytes/pixel | grey image                                               | copy      |
|--------|-------------|----------------------------------------------------------|-----------|
| GREY   | 1           | the rows, cropped to width                               | none      |
| Y16    | 2           | the high byte of each little-endian sample (= value >> 8) | none      |
| YUYV   | 2           | the Y bytes (every other byte)                           | none      |
| MJPEG  | -           | cv2.imdecode(IMREAD_GRAYSCALE)                           | the decode|

For the first three the result is a strided numpy *view* of the buffer (no
pixel is touched): valid only as long as the buffer is, i.e. until the V4L2
buffer is re-queued. `to_grey(..., copy=True)` makes the one copy that
outlives it (C-contiguous; Y16 and YUYV at about a memcpy's cost, `_word_bytes`).
MJPEG decodes into a new array either way. Rows may be padded (`bytesperline` > width x bytes
per pixel); the padding is cropped.
A buffer too short for the negotiated format, or a JPEG that does not decode
to the negotiated size, raises `CorruptFrame`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drivers.camera.v4l2_abi import fourcc


class CorruptFrame(ValueError):
    """The buffer does not hold a valid image of the negotiated format."""


@dataclass(frozen=True)
class PixelFormat:
    name: str  # as in the config: GREY, Y16, YUYV, MJPEG
    fourcc: int
    bytes_per_pixel: int  # 0 for compressed formats


FORMATS = {
    "GREY": PixelFormat("GREY", fourcc("GREY"), 1),
    "Y16": PixelFormat("Y16", fourcc("Y16 "), 2),
    "YUYV": PixelFormat("YUYV", fourcc("YUYV"), 2),
    "MJPEG": PixelFormat("MJPEG", fourcc("MJPG"), 0),
}
BY_FOURCC = {f.fourcc: f for f in FORMATS.values()}
ALIASES = {"GRAY": "GREY", "Y8": "GREY", "Y16 ": "Y16", "MJPG": "MJPEG", "YUY2": "YUYV"}


def pixel_format(name: str) -> PixelFormat:
    """The PixelFormat for a config name (GREY, Y16, YUYV, MJPEG; MJPG/GRAY/YUY2 accepted)."""
    key = name.strip().upper()
    key = ALIASES.get(key, key)
    if key not in FORMATS:
        raise ValueError(f"pixel format {name!r} is not supported (supported: {', '.join(FORMATS)})")
    return FORMATS[key]


def to_grey(
    data: np.ndarray, fmt: PixelFormat, width: int, height: int, bytesperline: int, *, copy: bool = False
) -> np.ndarray:
    """The (height, width) uint8 grey image in `data` (uint8, the buffer's used bytes)."""
    if fmt.bytes_per_pixel == 0:
        import cv2  # only MJPEG needs it; importing it costs ~10 s under the test VM's emulation

        image = cv2.imdecode(data, cv2.IMREAD_GRAYSCALE) if data.size else None
        if image is None or image.shape != (height, width):
            got = "nothing" if image is None else f"{image.shape[1]}x{image.shape[0]}"
            raise CorruptFrame(f"MJPEG frame of {data.size} bytes decoded to {got}, not {width}x{height}")
        return image
    row = width * fmt.bytes_per_pixel
    stride = max(bytesperline, row)
    needed = stride * (height - 1) + row
    if data.size < needed:
        raise CorruptFrame(f"{fmt.name} frame has {data.size} bytes, {width}x{height} needs {needed}")
    # rows as a strided view over the buffer, without the padding at the ends of rows (a reshape where
    # the buffer holds the last row's padding too: as_strided costs ~10 us a call, a frame's copy 10-20)
    if data.size >= stride * height and data.flags.c_contiguous:
        rows = data[:stride * height].reshape(height, stride)[:, :row]
    else:
        rows = np.lib.stride_tricks.as_strided(data, shape=(height, row), strides=(stride, 1),
                                               writeable=False)
    if fmt.name == "GREY":
        image = rows
    elif copy:  # Y16 and YUYV into an image of our own: `_word_bytes`
        return _word_bytes(data, rows, width, stride, "<u2" if fmt.name == "YUYV" else ">u2")
    elif fmt.name == "Y16":
        image = rows[:, 1::2]  # little-endian: the high byte of each sample is value >> 8
    else:  # YUYV: Y0 U Y1 V
        image = rows[:, 0::2]
    return image.copy() if copy else image  # copy() always copies (ascontiguousarray may not)


def _word_bytes(data: np.ndarray, rows: np.ndarray, width: int, stride: int, order: str) -> np.ndarray:
    """One byte of each 16-bit word of the lines `rows` of `data` as a new C-contiguous image, at about
    the cost of a memcpy of the buffer (tools/bench-capture): the words read with the byte order that
    puts the wanted byte low ("<u2": the first byte, YUYV's Y; ">u2": the second, Y16's high byte),
    narrowed to 8 bits by NumPy's vectorised cast (a cast to uint8 keeps the low byte). Copying every
    other byte with a strided slice cost 5.3x the memcpy at 720x480 (a byte-by-byte loop)."""
    if stride % 2 or not data.flags.c_contiguous:  # 16-bit words need even row starts (V4L2's are)
        return rows[:, (0 if order == "<u2" else 1)::2].copy()
    height = rows.shape[0]
    if data.size >= stride * height:
        pairs = data[:stride * height].view(order).reshape(height, stride // 2)[:, :width]
    else:  # the last row without its padding
        words = data[:stride * (height - 1) + 2 * width].view(order)
        pairs = np.lib.stride_tricks.as_strided(words, shape=(height, width), strides=(stride, 2),
                                                writeable=False)
    return pairs.astype(np.uint8)
