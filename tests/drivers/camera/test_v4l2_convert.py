"""to_grey's copies against the definition (every other byte of each line, the padding cropped): the
reshape and 16-bit-word paths that make a copy at about a memcpy's cost give the same pixels, for
padded lines and for buffers that end without the last line's padding."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.camera.v4l2_convert import FORMATS, to_grey


@settings(max_examples=80, deadline=None)
@given(st.sampled_from(["GREY", "Y16", "YUYV"]), st.integers(1, 40), st.integers(1, 12), st.integers(0, 9),
       st.booleans(), st.integers(0, 2**32 - 1))
def test_the_copy_is_the_bytes_the_format_defines(name: str, width: int, height: int, pad: int,
                                                 last_padded: bool, seed: int) -> None:
    fmt = FORMATS[name]
    row = width * fmt.bytes_per_pixel
    stride = row + pad
    size = stride * height if last_padded else stride * (height - 1) + row
    data = np.random.default_rng(seed).integers(0, 256, size, dtype=np.uint8)
    lines = [data[k * stride:k * stride + row] for k in range(height)]
    want = np.array([line if name == "GREY" else line[1::2] if name == "Y16" else line[0::2]
                     for line in lines])
    got = to_grey(data, fmt, width, height, stride, copy=True)
    assert got.flags.c_contiguous and got.dtype == np.uint8
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(to_grey(data, fmt, width, height, stride), want)  # the view alike
