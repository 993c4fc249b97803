"""Window cost curves along a row: integer SSD (eq. 3.8/5.1) and zero-mean SSD, with references.

A *band* is the stack of image rows the window covers; candidate k of a curve is the band's
columns k .. k+w-1. Three implementations produce the same curve:

- `cost_curve`: the fast integer path. SSD = sum T^2 - 2 sum T*R + sum R^2 with the box sums
  in int64 and the cross-correlation as one float64 matrix product whose every partial sum is
  an integer below 2**53, hence *exact* (not approximate) integer arithmetic, whatever the
  BLAS summation order. (cv2.matchTemplate(TM_SQDIFF) is float32 and was off by up to 2 DN^2 on
  random 15x15 windows with OpenCV 5.0 in our equality test, so it is not used.)
- `cost_curve_reference`: the plain definition, sum over the window of D = T - R in int64.
- `cost_curve_float`: float64 on mean-subtracted windows, i.e. ZSSD / N; an independent formula
  for the float reference matcher.

ZSSD in integer form is N*sum(D^2) - (sum D)^2 (research note §1.5): invariant to an offset
between the cameras and far less sensitive to gain than SSD. Bit widths for w x w windows of
b-bit data: sum D^2 < w^2 * 2^(2b), so 15x15 SSD fits in int32 (24 bits for 8-bit, 26 for the
9-bit cancellation sums) and ZSSD needs int64 (32 / 34 bits).
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

COSTS = ("zssd", "ssd")


def cost_curve(template: np.ndarray, band: np.ndarray, cost: str = "zssd") -> np.ndarray:
    """Integer cost of `template` against every window of `band` (int64, exact).

    `band` may carry leading batch axes (..., h, W): one curve per band, e.g. the rows of a
    2-D search. All arithmetic is float64 on integers below 2**53 (8/9-bit data, windows up to
    61x61), so every sum and product is exact and converts to int64 without loss."""
    h, w = template.shape
    t = np.asarray(template, dtype=np.float64)
    b = np.asarray(band, dtype=np.float64)
    lead, wb = b.shape[:-2], b.shape[-1]
    n = wb - w + 1
    flat = np.zeros(lead + (w * (wb + 1),))
    np.matmul(t.T, b, out=flat[..., :w * wb].reshape(lead + (w, wb)))   # [k, j] = sum_i T[i,k] B[i,j]
    # flat[k*wb + j] viewed with rows of wb+1 puts prod[k, d+k] at [k, d]: a diagonal sum
    cross = flat.reshape(lead + (w, wb + 1))[..., :n].sum(axis=-2)
    cum = np.zeros((2,) + lead + (wb + 1,))
    np.cumsum(b.sum(axis=-2), axis=-1, out=cum[0, ..., 1:])
    np.cumsum((b * b).sum(axis=-2), axis=-1, out=cum[1, ..., 1:])
    box = cum[..., w:] - cum[..., :-w]                    # per-candidate sum R and sum R^2
    ssd = float((t * t).sum()) - 2.0 * cross + box[1]
    if cost != "ssd":
        diff = float(t.sum()) - box[0]
        ssd = (h * w) * ssd - diff * diff
    return ssd.astype(np.int64)


def cost_curve_reference(template: np.ndarray, band: np.ndarray, cost: str = "zssd") -> np.ndarray:
    """The definition, written plainly in int64: the bit-exact reference of `cost_curve`."""
    h, w = template.shape
    windows = sliding_window_view(band.astype(np.int64), w, axis=1)   # (h, n, w)
    d = template.astype(np.int64)[:, None, :] - windows
    ssd = (d * d).sum(axis=(0, 2))
    if cost == "ssd":
        return ssd
    s = d.sum(axis=(0, 2))
    return h * w * ssd - s * s


def cost_curve_float(template: np.ndarray, band: np.ndarray, cost: str = "zssd") -> np.ndarray:
    """Float64 reference: SSD, or SSD of mean-subtracted windows (= ZSSD / N)."""
    h, w = template.shape
    windows = sliding_window_view(band.astype(np.float64), w, axis=1)  # (h, n, w)
    t = template.astype(np.float64)
    if cost == "ssd":
        return ((t[:, None, :] - windows) ** 2).sum(axis=(0, 2))
    tz = t - t.mean()
    wz = windows - windows.mean(axis=(0, 2), keepdims=True)
    return ((tz[:, None, :] - wz) ** 2).sum(axis=(0, 2))


def gradient_energy(rows: np.ndarray, x0: int, width: int) -> int:
    """sum G^2 with G = I(x+1) - I(x-1) (= 2*Ix) over columns x0 .. x0+width-1 of `rows`.

    Needs columns x0-1 .. x0+width. 15x15 of 8-bit data: < 2^24 (int32)."""
    r = rows.astype(np.int32)
    g = r[:, x0 + 1:x0 + width + 1] - r[:, x0 - 1:x0 + width - 1]
    return int((g * g).sum())
