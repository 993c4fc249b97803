"""Sea-clutter CFAR: a compact body against the local texture of the sea, both polarities, integer.

Why: on real seas the texture is not stationary down a row band. Sun glitter, whitecaps and
the wind's cat's-paws are local: bright, many and short, with quiet water a few hull lengths
away. A threshold from the spread of a whole row band (today's `Detector`) is set by the worst
of it, and small boats sink below it. Radar solved the same problem with CFAR (constant false
alarm rate): compare each cell with the mean of a ring of reference cells around it, and scale
the threshold by the clutter level measured in that ring. Here the ring is horizontal, on the
cell's own rows: after levelling, the sky, the haze and the sea's texture change with the row
(range), not along it; the horizon step and a far coastline are constant along a levelled row.

At one scale, for an 8-bit image I:

    cell    rows [y, y + CELL_H), columns [x, x + CELL_W)                    (n_c = CELL_W CELL_H)
    ring    the same rows, RING columns each side beyond a guard of GUARD  (n_r = 2 RING CELL_H)
    d       = (n_r / n_c) S_cell - S_ring = n_r (mean_cell - mean_ring)    (signed: both polarities)
    a       = min(|d| >> A_SHIFT, 255)     the contrast in quarters of a DN, clipped at 63.75 DN
    clutter = sum of a over the ring (the same guard and ring, the cell's rows), n_r values
    hit     : 4 a n_r > K4 sum(a over ring)  and  a >= 4 floor_dn

so a hit is a cell whose contrast is K4 / 4 times the mean contrast of the cells beside it: the
false-alarm rate is set by K4 whatever the glitter level (the clipping at 63.75 DN keeps a few
saturated glints from deciding the ring's level, a robust mean). Ships of 8 to 200+ px are seen
by one cell shape on an image pyramid (`detect_levels` in edge.measure.seadetect): a hull fills a
4 x 2 cell at the level where it is 4 to 16 px long.

Integer: box sums from one int32 integral image (exact); a from a shift and a clip; the clutter
sum from the integral of a (uint8, exact). The comparison is cross-multiplied: no division.
`cfar_hits_float` is the float64 reference (means and a ratio, no quantisation): the two agree
except within the quantisation of a (1/4 DN) of the threshold (tests/edge/core/test_seaclutter.py).
"""

from __future__ import annotations

import cv2
import numpy as np

CELL_W = 4  # cell columns
CELL_H = 2  # cell rows
GUARD = 4  # columns left out either side of the cell (a hull's ends, its wake's start)
RING = 16  # reference columns either side beyond the guard
N_CELL = CELL_W * CELL_H  # 8
N_RING = 2 * RING * CELL_H  # 64
A_SHIFT = 4  # |d| = 64 |mean difference|: >> 4 gives quarters of a DN
A_MAX = 255
MARGIN = CELL_W + GUARD + RING  # columns of replicated border either side


def _band_cumsum(image: np.ndarray) -> np.ndarray:
    """Horizontal cumulative sums of CELL_H-row bands: out[y, x] = sum of image[y:y+CELL_H, :x].
    Shape (h - CELL_H + 1, w + 1), int32, from OpenCV's integral image (exact)."""
    integral = cv2.integral(image, sdepth=cv2.CV_32S)
    return integral[CELL_H:] - integral[:-CELL_H]


def _cell_and_ring(cum: np.ndarray, w: int, x0: int) -> tuple[np.ndarray, np.ndarray]:
    """Cell sums and ring sums for cells starting at columns x0 .. x0 + w - 1 of the padded image."""
    c0 = x0
    cell = cum[:, c0 + CELL_W:c0 + CELL_W + w] - cum[:, c0:c0 + w]
    left = cum[:, c0 - GUARD:c0 - GUARD + w] - cum[:, c0 - GUARD - RING:c0 - GUARD - RING + w]
    r0 = c0 + CELL_W + GUARD
    right = cum[:, r0 + RING:r0 + RING + w] - cum[:, r0:r0 + w]
    return cell, left + right


def cfar_contrast(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(a, bright): each cell's contrast against its ring in quarters of a DN, clipped to 255,
    uint8; and whether the cell is brighter than its ring (uint8 0/1).

    out[y, x] is the cell with top-left (y, x); rows past h - CELL_H are 0, borders replicate."""
    _check(image)
    h, w = image.shape
    padded = cv2.copyMakeBorder(image, 0, 0, MARGIN, MARGIN, cv2.BORDER_REPLICATE)
    cum = _band_cumsum(padded)
    cell, ring = _cell_and_ring(cum, w, MARGIN)
    d = cell * (N_RING // N_CELL) - ring
    a = np.minimum(np.abs(d) >> A_SHIFT, A_MAX).astype(np.uint8)
    out = np.zeros((h, w), np.uint8)
    out[:h - CELL_H + 1] = a
    bright = np.zeros((h, w), np.uint8)
    bright[:h - CELL_H + 1] = d > 0
    return out, bright


def cfar_hits(image: np.ndarray, k4: int, floor_q: int
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(hit mask uint8 0/1, a, bright, clutter): cells K4/4 times above their ring's mean contrast
    and >= floor_q quarters of a DN; clutter is the sum of a over the ring (N_RING cells), int32.
    Integer throughout."""
    a, bright = cfar_contrast(image)
    h, w = a.shape
    padded = cv2.copyMakeBorder(a, 0, 0, MARGIN, MARGIN, cv2.BORDER_REPLICATE)
    cum = _band_cumsum(padded)
    _, clutter = _cell_and_ring(cum, w, MARGIN)
    a_band = a[:h - CELL_H + 1].astype(np.int32)
    hit = (a_band * (4 * N_RING) > k4 * clutter) & (a_band >= floor_q)
    out = np.zeros((h, w), np.uint8)
    out[:h - CELL_H + 1] = hit
    ring = np.zeros((h, w), np.int32)
    ring[:h - CELL_H + 1] = clutter
    return out, a, bright, ring


def cfar_hits_float(image: np.ndarray, k: float, floor_dn: float) -> tuple[np.ndarray, np.ndarray]:
    """Float64 reference of `cfar_hits`: (hit mask bool, contrast in DN), by explicit windows."""
    _check(image)
    h, w = image.shape
    p = np.pad(image.astype(np.float64), ((0, 0), (MARGIN, MARGIN)), mode="edge")

    def window_mean(values: np.ndarray, start: int, width: int) -> np.ndarray:
        rows = values.shape[0] - CELL_H + 1
        out = np.zeros((rows, w))
        for dy in range(CELL_H):
            for dx in range(width):
                out += values[dy:dy + rows, MARGIN + start + dx:MARGIN + start + dx + w]
        return out / (CELL_H * width)

    def ring_mean(values: np.ndarray) -> np.ndarray:
        left = window_mean(values, -GUARD - RING, RING)
        right = window_mean(values, CELL_W + GUARD, RING)
        return 0.5 * (left + right)

    contrast = np.minimum(np.abs(window_mean(p, 0, CELL_W) - ring_mean(p)), A_MAX / 4.0)
    full = np.zeros((h, w))
    full[:h - CELL_H + 1] = contrast
    clutter = ring_mean(np.pad(full, ((0, 0), (MARGIN, MARGIN)), mode="edge"))
    hit = (contrast > k * clutter) & (contrast >= floor_dn)
    mask = np.zeros((h, w), bool)
    mask[:h - CELL_H + 1] = hit
    return mask, full


def _check(image: np.ndarray) -> None:
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 2:
        raise ValueError("the sea-clutter CFAR needs a 2-D uint8 image")
    if image.shape[0] < CELL_H or image.shape[1] < 1:
        raise ValueError(f"the sea-clutter CFAR needs at least {CELL_H} rows")
