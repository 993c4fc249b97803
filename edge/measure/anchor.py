"""Where a track anchors on a ship: the best-textured points in the upper part of its box.

`reference_points` ranks window centres by the summed squared horizontal
gradient of the window (what sets the matcher's sigma, research note §1.4),
best first and at least half a window apart. The upper part of the box is the
superstructure, the thesis's bridge, mostly seen against the sky, so the window
holds little sea at another range.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from edge.core.rectify import Rectifier

UPPER_SHARE = 0.6  # the reference point is searched in this top share of the ship's box
SHIP_WINDOW_MARGIN_PX = 6  # a small ship's window spans its box plus this (both outlines inside)
BACKGROUND_SHARE = 0.25  # ... if the background around it has at most this share of the ship's texture
GLINT_SPARE = 4  # extra candidates ranked, so those with glints can go last
CLIPPED_DN = 250  # a window holding a pixel this bright holds a clipped sun glint


def ship_window(patch: np.ndarray, origin: tuple[int, int], box: tuple[float, float, float, float],
                window: int) -> int:
    """The matching window for a ship in `box` (rectified px): the configured `window`, or for a
    ship up to two windows wide on a quiet background a window spanning the whole box (odd, at
    most 2 window - 1). `patch` holds the rectified left image from `origin` (x, y) and covers
    the box plus `window` px on each side.

    A far ship is a low-contrast blob a few px wider than the window; most of its horizontal
    texture (what sets the disparity's sigma, research note §1.4) is its two outlines against
    sky and sea. A window on one outline sees half of it; one spanning the ship sees both
    (docs/decisions.md). The wider window also takes in more background, whose texture
    pulls the disparity towards the background's: so only where the background around the
    box has at most BACKGROUND_SHARE of the ship's gradient energy per pixel (far sea and sky
    are smooth; the sea around a boat at a few hundred metres is not). A ship wider than two
    windows has enough texture inside one."""
    w = spanning_width(box[2] - box[0], window)
    if w == window:
        return window
    g = patch.astype(np.float32)
    gx2 = np.zeros_like(g)
    gx2[:, 1:-1] = (g[:, 2:] - g[:, :-2]) ** 2
    ox, oy = origin
    x0, y0 = int(math.floor(box[0])) - ox, int(math.floor(box[1])) - oy
    x1, y1 = int(math.ceil(box[2])) - ox, int(math.ceil(box[3])) - oy
    h = w // 2
    around = gx2[max(0, y0 - h):y1 + h, max(1, x0 - h):min(gx2.shape[1] - 1, x1 + h)]
    inside = gx2[y0:y1, x0:x1]
    ship = float(inside.mean()) if inside.size else 0.0
    background = (float(around.sum()) - float(inside.sum())) / max(1, around.size - inside.size)
    return w if background <= BACKGROUND_SHARE * ship else window


def spanning_width(box_w: float, window: int) -> int:
    """The side of a window spanning a ship box_w px wide (`ship_window`), or `window` for a ship too
    narrow to need one or wider than two windows."""
    width = int(math.ceil(box_w)) + SHIP_WINDOW_MARGIN_PX
    if width <= window or box_w > 2 * window:
        return window
    return min(width | 1, 2 * window - 1)


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
    out: list[tuple[float, float]] = []
    for _ in range(count):
        iy, ix = np.unravel_index(int(np.argmax(sub)), sub.shape)
        if out and sub[iy, ix] <= 0.0:
            break
        out.append((float(x0 + ix), float(y0 + iy)))
        h = window // 2
        sub[max(0, iy - h):iy + h + 1, max(0, ix - h):ix + h + 1] = -1.0
    return out


def ship_points(rect: Rectifier, left: np.ndarray, box: np.ndarray, window: int, count: int) -> list:
    """The best-textured points in the upper part of a (rectified) ship box, best first, for
    `window` (the configured one or a track's own, `ship_window`), from the left image.

    Two kinds of window are avoided: (1) one across the bow or stern outline holds the sea
    behind the ship, at another range, and its disparity is a mix of the two (a ship wider
    than a window keeps its centres half a window inside its ends); (2) one holding clipped
    pixels: a sun glint, the brightest texture there is, seen by one camera only and gone
    within a few pairs (such windows come after all others, so a ship that is all glare
    still gets a point)."""
    h = window // 2
    x0, y0 = int(math.floor(box[0])), int(math.floor(box[1]))
    x1, y1 = max(x0 + 1, int(math.ceil(box[2]))), max(y0 + 1, int(math.ceil(box[3])))
    ox, oy = x0 - h - 1, y0 - h - 1
    patch = rect.patch(left, 0, ox, oy, x1 - x0 + 2 * h + 2, y1 - y0 + 2 * h + 2)
    cx0, cx1 = (x0 + h, x1 - h) if x1 - x0 > 2 * h + 1 else (x0, x1)
    clipped = patch >= CLIPPED_DN
    if not clipped.any():
        return reference_points(patch, (cx0, y0, cx1, y1), (ox, oy), window, count)
    points = reference_points(patch, (cx0, y0, cx1, y1), (ox, oy), window, count + GLINT_SPARE)
    glare = [bool(clipped[int(v) - oy - h:int(v) - oy + h + 1, int(u) - ox - h:int(u) - ox + h + 1].any())
             for u, v in points]
    ranked = [p for p, g in zip(points, glare, strict=True) if not g] + \
        [p for p, g in zip(points, glare, strict=True) if g]
    return ranked[:count]
