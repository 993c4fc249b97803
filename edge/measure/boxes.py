"""Ship-box geometry for the track table's association: how much boxes coincide, whether a box holds
a point, whether its waterline lies in a site mask.

Boxes are rectified left-image [x0, y0, x1, y1] in pixels (columns x0 <= u < x1, rows y0 <= v < y1).
All tracks against all detections in one array operation: a Python loop over the pairs cost about
1 ms per detection pass with 30 of each, a fifth of a 720x480 pair.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from edge.core.rectify import Rectifier


def overlaps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """How much ship boxes coincide, every box of `a` (n, 4) with every box of `b` (m, 4), as an
    (n, m) array: the IoU of their column spans, 0 unless their rows are within one box height of
    each other. Ships move across the image, rarely up or down it, and a box's height jumps with
    what the detector saw of the hull; its columns are what is stable."""
    a0, a1, a2, a3 = (a[:, k, None] for k in range(4))
    b0, b1, b2, b3 = (b[None, :, k] for k in range(4))
    inter = np.minimum(a2, b2) - np.maximum(a0, b0)
    apart = np.abs((a1 + a3) - (b1 + b3)) > (a3 - a1) + (b3 - b1) + 4.0
    with np.errstate(divide="ignore", invalid="ignore"):
        iou = inter / (np.maximum(a2, b2) - np.minimum(a0, b0))
    return np.where((inter <= 0) | apart, 0.0, iou)


def inside(boxes: np.ndarray, u: np.ndarray | Sequence[float], v: np.ndarray | Sequence[float]) -> np.ndarray:
    """Whether each point (u[i], v[i]) lies in each box of `boxes` (m, 4): an (n, m) array."""
    u, v = np.asarray(u, float)[:, None], np.asarray(v, float)[:, None]
    return (boxes[:, 0] <= u) & (u < boxes[:, 2]) & (boxes[:, 1] <= v) & (v < boxes[:, 3])


def waterline_masked(mask: np.ndarray, rect: Rectifier, box: np.ndarray) -> bool:
    """Whether a rectified box's waterline (its bottom row's centre) lies in a site mask (`mask`: the
    raw left image, True where detection may run; edge.core.masks)."""
    raw = rect.rect_to_raw(np.array([0.5 * (box[0] + box[2]), box[3] - 1.0]), 0)
    if not np.isfinite(raw).all():
        return True
    h, w = mask.shape
    u, v = min(w - 1, max(0, int(round(raw[0])))), min(h - 1, max(0, int(round(raw[1]))))
    return not bool(mask[v, u])


def contains(box: np.ndarray, u: float, v: float) -> bool:
    """Whether one box holds the point (u, v) (`inside` for one box and point)."""
    return bool(box[0] <= u < box[2] and box[1] <= v < box[3])
