"""Image prefilters for matching real camera pairs: clipped horizontal Sobel (StereoBM-style), and
a locally normalised horizontal Sobel.

Why: on real stereo pairs the raw-intensity (Z)SSD is dominated by the few strongest edges in
a window (gradients are heavy-tailed: on the Middlebury motorcycle pair the Sobel RMS is 97 DN
but its median 14), and those are where the two cameras differ most (blur, response curve,
highlights, depth edges). Clipping the horizontal derivative equalises every pixel's weight.
Measured by tools/bench-core (real-imagery section): ZSSD + cancellation goes from worse than
OpenCV StereoBM to better on the Middlebury pair with cap 15. On clean renders the clipping
discards sub-pixel information (textured RMS 0.008 -> 0.05 px), so it is a per-installation
choice (`pipeline.prefilter`), applied to both images before `match_point`: the pipeline filters
only the rectified patches its right matches use (`Rectifier.xsobel_patch`).

Integer: the 3x3 Sobel x kernel [-1 0 1] x [1 2 1]^T on uint8 fits int16 (|s| <= 1020);
clip to [-cap, cap] and offset by cap gives uint8 in [0, 2 cap]. Borders reflect (OpenCV's
BORDER_REFLECT_101), so it equals cv2.Sobel(..., CV_16S, 1, 0, ksize=3) + clip.

`xsobel_normalised` (measured in tools/bench-core: on Middlebury better than the clip, 0.185 vs
0.209 px, and on renders it loses less, 0.020 vs 0.048 px): v = 127 S / (|S| + K mean|S| + E)
with mean|S| over the 7x7 neighbourhood. A soft,
local version of the clip: a pixel's weight no longer grows with the square of its edge strength
but saturates relative to its surroundings, so a window's few strongest edges no longer decide
where in the window the disparity is measured (tools/bench-core, real section: on Middlebury the
raw matcher's error correlates 0.83 with the ground-truth disparity averaged with Ix^2 weights,
i.e. it measures the disparity at the strongest edge, not at the window centre). Unlike the
clip it keeps the sign and ordering of every gradient, so less sub-pixel information is lost.
Integer: S int32 (|S| <= 1020), A = 7x7 box sum of |S| (< 2^16), v = round(127 N S / (N |S| + K A
+ N E)) with N = 49 (numerator < 2^23), rounded half away from zero, offset by 128 to uint8 in
[1, 255]; `xsobel_normalised_float` is its float64 reference (equal up to 1 DN at rounding ties).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

DEFAULT_CAP = 15
# camera noise sigma n becomes sqrt(1+4+1 + 1+4+1) n = sqrt(12) n in the Sobel output (before
# clipping, which only lowers it): the noise to give `match_point` for its predicted sigma
NOISE_GAIN = math.sqrt(12.0)

NORM_BOX = 7          # neighbourhood of the local gradient level (px, square)
NORM_K = 1            # weight of the local mean |S| in the denominator
NORM_FLOOR = 4        # E: Sobel units (~ 1 DN/px), keeps flat noise from being amplified to full scale


def xsobel(image: np.ndarray, cap: int = DEFAULT_CAP) -> np.ndarray:
    """Clipped horizontal Sobel of an 8-bit grey image, offset to uint8 [0, 2*cap]."""
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 2:
        raise ValueError("xsobel needs a 2-D uint8 image")
    if not 1 <= cap <= 127:
        raise ValueError(f"cap must be in 1..127, got {cap}")
    p = np.pad(image.astype(np.int16), 1, mode="reflect")
    cols = p[:-2] + 2 * p[1:-1] + p[2:]                     # vertical [1 2 1]
    s = cols[:, 2:] - cols[:, :-2]                          # horizontal [-1 0 1]
    return (np.clip(s, -cap, cap) + cap).astype(np.uint8)


def _sobel_x(image: np.ndarray) -> np.ndarray:
    """3x3 Sobel x of a 2-D uint8 array, int32, borders reflected (BORDER_REFLECT_101); exact."""
    return cv2.Sobel(image, cv2.CV_16S, 1, 0, ksize=3, borderType=cv2.BORDER_REFLECT_101).astype(np.int32)


def _box_sum(values: np.ndarray, size: int) -> np.ndarray:
    """Sum over the size x size neighbourhood of every element (borders reflected). Exact for
    integer values whose sums stay below 2^24 (float32 holds them), as here (< 2^16)."""
    box = cv2.boxFilter(values.astype(np.float32), -1, (size, size), normalize=False,
                        borderType=cv2.BORDER_REFLECT_101)
    return box.astype(np.int32)


def _check(image: np.ndarray) -> None:
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 2:
        raise ValueError("the prefilter needs a 2-D uint8 image")
    if min(image.shape) < 2:
        raise ValueError("the prefilter needs at least 2 rows and columns")


def xsobel_normalised(image: np.ndarray) -> np.ndarray:
    """Locally normalised horizontal Sobel of an 8-bit grey image, uint8 (128 = zero); integer."""
    _check(image)
    s = _sobel_x(image)
    a = np.abs(s)
    n = NORM_BOX * NORM_BOX
    den = n * a + NORM_K * _box_sum(a, NORM_BOX) + n * NORM_FLOOR       # > 0
    mag = (2 * 127 * n * a + den) // (2 * den)                          # round half up of |v|
    return (128 + np.where(s < 0, -mag, mag)).astype(np.uint8)


def xsobel_normalised_float(image: np.ndarray) -> np.ndarray:
    """Float64 reference of `xsobel_normalised` (the same formula, a float box mean)."""
    _check(image)
    s = _sobel_x(image).astype(np.float64)
    a = np.abs(s)
    p = np.pad(a, NORM_BOX // 2, mode="reflect")            # numpy's "reflect" is REFLECT_101
    windows = np.lib.stride_tricks.sliding_window_view(p, (NORM_BOX, NORM_BOX))
    v = 127.0 * s / (a + NORM_K * windows.mean(axis=(2, 3)) + NORM_FLOOR)
    return (128 + np.sign(v) * np.floor(np.abs(v) + 0.5)).astype(np.uint8)
