"""Image-level helpers of a track's point: where to put it on a ship, and how it moved.

- `reference_points`: the best-textured window centres in the upper part of a
  ship's box (sum of squared horizontal gradients, what sets the matcher's sigma,
  research note §1.4), best first and spread apart. The upper part is the
  superstructure, the thesis's bridge, mostly seen against the sky.
- `follow`: the sub-pixel shift of a template inside a search region, SSD
  (cv2.matchTemplate) with a 2-D quadratic vertex. It stands in for the core's
  sub-pixel point tracker (issue 4) until that lands.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

UPPER_SHARE = 0.6  # the reference point is searched in this top share of the ship's box


def reference_points(patch: np.ndarray, box: tuple[int, int, int, int], origin: tuple[int, int],
                     window: int, count: int = 1) -> list[tuple[float, float]]:
    """The best-textured window centres in the upper part of `box` (rectified px, [x0, x1) x [y0, y1)),
    best first, at least half a window apart.

    `patch` holds the rectified left image from `origin` (x, y) and covers the box plus half a
    window on each side. Ties go to the first (top-left) maximum, so the choice is deterministic."""
    x0, y0, x1, y1 = box
    ox, oy = origin
    g = patch.astype(np.float32)
    gx2 = np.zeros_like(g)
    gx2[:, 1:-1] = (g[:, 2:] - g[:, :-2]) ** 2
    energy = cv2.boxFilter(gx2, -1, (window, window), normalize=False, borderType=cv2.BORDER_CONSTANT)
    r1 = y0 + max(1, int(math.ceil(UPPER_SHARE * (y1 - y0))))
    sub = energy[y0 - oy:r1 - oy, x0 - ox:x1 - ox].copy()
    out = []
    for _ in range(count):
        iy, ix = np.unravel_index(int(np.argmax(sub)), sub.shape)
        if out and sub[iy, ix] <= 0.0:
            break
        out.append((float(x0 + ix), float(y0 + iy)))
        h = window // 2
        sub[max(0, iy - h):iy + h + 1, max(0, ix - h):ix + h + 1] = -1.0
    return out


def follow(previous: np.ndarray, current: np.ndarray) -> tuple[float, float, float] | None:
    """Sub-pixel shift (dx, dy) of the window `previous` inside the larger `current` region,
    relative to the centre of `current`, and the SSD per pixel at the best whole-pixel shift;
    None at the search edge or for a flat cost surface.

    Stand-in for the core's sub-pixel point tracker (issue 4) until it lands: SSD by
    cv2.matchTemplate and a 3-point parabola (eq. 5.2) along each axis."""
    cost = cv2.matchTemplate(current, previous, cv2.TM_SQDIFF)
    iy, ix = np.unravel_index(int(np.argmin(cost)), cost.shape)
    ry, rx = (cost.shape[0] - 1) // 2, (cost.shape[1] - 1) // 2
    if not (0 < ix < cost.shape[1] - 1 and 0 < iy < cost.shape[0] - 1):
        return None
    offset = _vertex_2d(cost[iy - 1:iy + 2, ix - 1:ix + 2].astype(np.float64))
    if offset is None:
        return None
    return ix - rx + offset[0], iy - ry + offset[1], float(cost[iy, ix]) / previous.size


def _vertex_2d(c: np.ndarray) -> tuple[float, float] | None:
    """Minimum of the quadratic through a 3 x 3 cost neighbourhood (gradient and Hessian by central
    differences, cross term included: fitting x and y separately biases y when the texture's
    correlation is tilted and x has a fraction). None unless it is a minimum within half a pixel."""
    gx, gy = 0.5 * (c[1, 2] - c[1, 0]), 0.5 * (c[2, 1] - c[0, 1])
    hxx, hyy = c[1, 2] - 2 * c[1, 1] + c[1, 0], c[2, 1] - 2 * c[1, 1] + c[0, 1]
    hxy = 0.25 * (c[2, 2] - c[2, 0] - c[0, 2] + c[0, 0])
    det = hxx * hyy - hxy * hxy
    if hxx <= 0 or det <= 0:
        return None
    dx, dy = (-hyy * gx + hxy * gy) / det, (hxy * gx - hxx * gy) / det
    if abs(dx) > 0.75 or abs(dy) > 0.75:
        return None
    return float(dx), float(dy)


def median(values) -> float:
    """Median of a short sequence (sorted(); np.median's overhead is ~20 us on a handful of values)."""
    v = sorted(values)
    n = len(v)
    return float(v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2]))
