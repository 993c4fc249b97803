"""Levelling: move each image column by a fractional number of rows so a tilted horizon becomes one row.

Why: the sea's statistics change with the row (range) and the horizon is a sharp step; a
detector that compares a cell with its neighbours along the row (edge.core.seaclutter) needs
that row to run along the horizon. A rolled camera tilts it, the lens curves it. Whole-row
shifts leave up to half a row of the tilt, as strong as a hull where brightness changes fast
down the rows (the horizon step), so the shift is fractional: linear between two rows.

Integer: the shift per column is in 1/256 rows (Q8); out = (I[r + s] (256 - f) + I[r + s + 1] f
+ 128) >> 8 in uint16 (at most 255 * 256 + 128 < 2^16); rows beyond the image repeat its edge
rows. `level_columns_float` is the float64 reference (the same interpolation, rounded half up).
"""

from __future__ import annotations

import numpy as np

Q = 256  # shift units per row


def shifts_q8(shift_rows: np.ndarray) -> np.ndarray:
    """Shifts in rows (float) to the Q8 integers `level_columns` takes (rounded to nearest)."""
    return np.round(np.asarray(shift_rows, dtype=np.float64) * Q).astype(np.int64)


def level_columns(image: np.ndarray, shift_q8: np.ndarray) -> np.ndarray:
    """uint8 image with column c read from rows r + shift_q8[c] / 256 (linear between rows)."""
    _check(image, shift_q8)
    h, w = image.shape
    shift = np.asarray(shift_q8, dtype=np.int64)
    if not shift.any():
        return image.copy()
    whole = shift >> 8  # floor
    frac = (shift - (whole << 8)).astype(np.uint16)
    pad = int(np.abs(whole).max()) + 1
    src: np.ndarray = np.empty((h + 2 * pad, w), np.uint16)
    src[pad:pad + h] = image
    src[:pad] = image[0]
    src[pad + h:] = image[-1]
    out = np.empty((h, w), np.uint8)
    edges = [0, *(np.flatnonzero(np.diff(whole)) + 1).tolist(), w]
    for c0, c1 in zip(edges[:-1], edges[1:], strict=True):
        r0 = pad + int(whole[c0])
        f = frac[None, c0:c1]
        acc = src[r0:r0 + h, c0:c1] * (Q - f) + src[r0 + 1:r0 + 1 + h, c0:c1] * f + 128
        out[:, c0:c1] = np.right_shift(acc, 8)
    return out


def level_columns_float(image: np.ndarray, shift_q8: np.ndarray) -> np.ndarray:
    """Float64 reference of `level_columns` (the same shifts; linear interpolation, rounded half up)."""
    _check(image, shift_q8)
    h, w = image.shape
    shift = np.asarray(shift_q8, dtype=np.float64) / Q
    rows = np.arange(h)[:, None] + shift[None, :]
    r0 = np.floor(rows)
    t = rows - r0
    i0 = np.clip(r0.astype(int), 0, h - 1)
    i1 = np.clip(r0.astype(int) + 1, 0, h - 1)
    cols = np.arange(w)[None, :]
    img = image.astype(np.float64)
    value = img[i0, cols] * (1.0 - t) + img[i1, cols] * t
    return np.floor(value + 0.5).astype(np.uint8)


def _check(image: np.ndarray, shift: np.ndarray) -> None:
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 2:
        raise ValueError("levelling needs a 2-D uint8 image")
    if np.shape(shift) != (image.shape[1],):
        raise ValueError(f"levelling needs one shift per column ({image.shape[1]}), got {np.shape(shift)}")
