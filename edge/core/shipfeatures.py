"""Features of a sea-clutter candidate that tell a hull from glitter, whitecaps and wave crests.

Why: a single CFAR test (edge.core.seaclutter) loose enough to see every small boat also passes
the brightest whitecaps and glints, and one tight enough to stop them loses the faint hulls
(issue 24: at 0.2 false alarms per image no single threshold kept more than ~20 % of the
vessels). A maritime vision engineer separates the two by more than contrast: a hull is a
compact body with a dark part (the hull or its shadow) at a waterline, often bright on top
(superstructure, a sail) or behind (a wake); it has vertical edges (bow, stern, mast) where a
crest is a flat streak; it stands out at more than one scale; and at its image row, under the
perspective of a camera at height h looking at a flat sea, its length in pixels is set by its
length in metres over h (L_px / rows below the horizon = L_m / h, small angles). Each of these
is one number per candidate here; `edge.core.shipscore` weighs them.

Per candidate (a connected component of CFAR hits on one pyramid level, in that level's
levelled pixels; `body` is the union of its cells, the `ring` is the reference columns of the
CFAR either side on the same rows):

    cfar_log2       log2 of the strongest cell's contrast over its ring's mean contrast
    contrast_log2   log2 of that cell's contrast, DN
    dark_share      strongest darker-than-ring cell / strongest cell (0: all bright)
    bright_share    strongest brighter-than-ring cell / strongest cell
    dark_sigma      (ring mean - darkest body pixel) / ring sigma, log2(1 + max(0, .))
    bright_sigma    (brightest body pixel - ring mean) / ring sigma, log2(1 + max(0, .))
    fill            hit cells / component box area
    aspect_log2     log2(length / height) of the component box
    length_rel_log2 log2(length / rows below the horizon), full resolution (~ L_m / camera height)
    height_rel_log2 log2(height / rows below the horizon)
    depth_log2      log2(rows below the horizon / image height)
    length_log2     log2(length, full-resolution px)
    edges_log2      log2((sum |dI/dx| + 1) / (sum |dI/dy| + 1)) in the body: vertical edges over
                    horizontal ones (a hull's ends and masts vs a crest's flat streak)
    below_sigma     (mean of the rows under the body - ring mean) / ring sigma (a wake: > 0)
    above_sigma     (mean of the rows over the body - ring mean) / ring sigma
    clutter_log2    log2 of the ring's mean contrast, DN (how rough the sea is there)
    level           the pyramid level (0: working resolution)
    dark_row        where in the body's height the darkest row lies (0 top, 1 bottom)
    levels_seen     on how many pyramid levels a candidate overlaps this one (filled in by the
                    composition, edge.measure.seadetect; 1 here)

Float64 per candidate (a few hundred per image, not per pixel): the per-pixel work stays in the
integer CFAR.
"""

from __future__ import annotations

import math

import numpy as np

from edge.core.seaclutter import CELL_H, CELL_W, GUARD, N_RING, RING

FEATURES = ("cfar_log2", "contrast_log2", "dark_share", "bright_share", "dark_sigma", "bright_sigma",
            "fill", "aspect_log2", "length_rel_log2", "height_rel_log2", "depth_log2", "length_log2",
            "edges_log2", "below_sigma", "above_sigma", "clutter_log2", "level", "dark_row",
            "levels_seen")
N_FEATURES = len(FEATURES)
SIGMA_FLOOR_DN = 1.0  # a ring flatter than this (sky, calm water) counts as this rough


def component_features(image: np.ndarray, a: np.ndarray, bright: np.ndarray, clutter: np.ndarray,
                       labels: np.ndarray, stat: np.ndarray, index: int, *, scale_px: float,
                       horizon_row: float, image_height_px: float, level: int) -> np.ndarray:
    """The feature row (FEATURES order) of component `index` (stat = its x, y, w, h, area).

    image, a, bright, clutter, labels: one pyramid level's levelled image, the CFAR's contrast
    (quarters of a DN), polarity, ring sums (edge.core.seaclutter.cfar_hits) and the component
    labels; scale_px: full-resolution px per level px; horizon_row: the horizon's row in this
    level's pixels (the same levelled rows); image_height_px: full-resolution image height."""
    x, y, w, h, area = (int(v) for v in stat[:5])
    hh, ww = image.shape
    sel = labels[y:y + h, x:x + w] == index
    av = a[y:y + h, x:x + w][sel].astype(np.float64)
    br = bright[y:y + h, x:x + w][sel]
    ring_sum = np.maximum(clutter[y:y + h, x:x + w][sel].astype(np.float64), 1.0)
    ratio = av * N_RING / ring_sum
    peak = max(float(av.max()), 1.0)
    dark = av[br == 0]
    light = av[br == 1]
    # body: the union of the component's cells; ring: the CFAR's reference columns on those rows
    bx0, bx1 = x, min(ww, x + w + CELL_W - 1)
    by0, by1 = y, min(hh, y + h + CELL_H - 1)
    body = image[by0:by1, bx0:bx1].astype(np.float64)
    left = image[by0:by1, max(0, bx0 - GUARD - RING):max(0, bx0 - GUARD)]
    right = image[by0:by1, min(ww, bx1 + GUARD):min(ww, bx1 + GUARD + RING)]
    ring = np.concatenate([left.ravel(), right.ravel()]).astype(np.float64)
    if ring.size == 0:
        ring = body.ravel()
    mean, sigma = float(ring.mean()), max(SIGMA_FLOOR_DN, float(ring.std()))
    bh = by1 - by0
    below = image[by1:min(hh, by1 + bh), bx0:bx1]
    above = image[max(0, by0 - bh):by0, bx0:bx1]
    below_sigma = (float(below.mean()) - mean) / sigma if below.size else 0.0
    above_sigma = (float(above.mean()) - mean) / sigma if above.size else 0.0
    gx = float(np.abs(np.diff(body, axis=1)).sum()) if body.shape[1] > 1 else 0.0
    gy = float(np.abs(np.diff(body, axis=0)).sum()) if body.shape[0] > 1 else 0.0
    rows = body.mean(axis=1)
    dark_row = float(np.argmin(rows)) / max(1, len(rows) - 1)
    length_px = max(1.0, w * scale_px)
    height_px = max(1.0, h * scale_px)
    depth_px = max(1.0, (y + h + 0.5 * CELL_H - horizon_row) * scale_px)
    return np.array([
        math.log2(max(float(ratio.max()), 1e-3)),
        math.log2(peak / 4.0),
        float(dark.max()) / peak if dark.size else 0.0,
        float(light.max()) / peak if light.size else 0.0,
        math.log2(1.0 + max(0.0, (mean - float(body.min())) / sigma)),
        math.log2(1.0 + max(0.0, (float(body.max()) - mean) / sigma)),
        area / float(w * h),
        math.log2(w / h),
        math.log2(length_px / depth_px),
        math.log2(height_px / depth_px),
        math.log2(depth_px / image_height_px),
        math.log2(length_px),
        math.log2((gx + 1.0) / (gy + 1.0)),
        below_sigma,
        above_sigma,
        math.log2(max(float(ring_sum.mean()) / (4.0 * N_RING), 1e-2)),
        float(level),
        dark_row,
        1.0,
    ])
