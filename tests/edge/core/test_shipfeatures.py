"""Candidate features on hand-made scenes with known answers: a dark hull on flat water, a bright
glint, a hull with a bright wake under it, the perspective ratios."""

from __future__ import annotations

import math

import cv2
import numpy as np

from edge.core.seaclutter import cfar_hits
from edge.core.shipfeatures import FEATURES, N_FEATURES, component_features

F = {name: i for i, name in enumerate(FEATURES)}


def _features(image: np.ndarray, *, scale_px: float = 1.0, horizon_row: float = 0.0,
              at: tuple[slice, slice] | None = None) -> np.ndarray:
    """The features of the one component (or of the one with most cells in the region `at`)."""
    hits, a, bright, clutter = cfar_hits(image, 16, 24)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(hits, connectivity=8)
    if at is None:
        assert n == 2, f"{n - 1} components"
        i = 1
    else:
        inside = labels[at][labels[at] > 0]
        assert inside.size
        i = int(np.bincount(inside).argmax())
    return component_features(image, a, bright, clutter, labels, stats[i], i, scale_px=scale_px,
                              horizon_row=horizon_row, image_height_px=200.0, level=0)


def _water(seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.clip(np.round(100.0 + rng.normal(0.0, 1.0, (120, 200))), 0, 255).astype(np.uint8)


def test_a_dark_hull_is_dark_compact_and_scaled_by_its_row() -> None:
    img = _water()
    img[60:64, 95:105] = 40  # 10 x 4 px hull, 60 DN darker (a 4 x 2 cell level sees 4-16 px bodies)
    f = _features(img, scale_px=2.0, horizon_row=20.0)
    assert f.shape == (N_FEATURES,)
    assert f[F["dark_share"]] == 1.0 and f[F["bright_share"]] == 0.0
    assert f[F["bright_sigma"]] < 2.0 < f[F["dark_sigma"]]
    # 60 DN against 1 DN noise: far above the ring's contrast; contrast clipped at 63.75 DN
    assert f[F["contrast_log2"]] > math.log2(40.0)
    assert f[F["cfar_log2"]] > 2.5  # over 5.6 times the ring's mean contrast (the candidate test is 4)
    # the component of cells: length and height near the hull's, in full-resolution px (scale 2)
    length = 2.0 ** f[F["length_log2"]]
    assert 2 * 6 <= length <= 2 * 14
    depth = 2.0 ** (f[F["depth_log2"]]) * 200.0
    assert abs(depth - 2.0 * (64 - 20)) <= 2.0 * 3
    assert math.isclose(f[F["length_rel_log2"]], math.log2(length / depth), abs_tol=1e-9)
    assert f[F["levels_seen"]] == 1.0 and f[F["level"]] == 0.0
    assert 0.5 < f[F["fill"]] <= 1.0


def test_a_glint_is_bright_only_and_a_wake_shows_under_a_hull() -> None:
    img = _water()
    img[60:62, 100:104] = 220
    f = _features(img)
    assert f[F["bright_share"]] == 1.0 and f[F["dark_share"]] == 0.0
    img = _water()
    img[60:64, 95:105] = 40
    img[64:68, 93:107] = 180  # the wake under and behind it
    f = _features(img, at=(slice(58, 63), slice(90, 104)))
    assert f[F["dark_share"]] == 1.0
    assert f[F["below_sigma"]] > 10.0 > f[F["above_sigma"]]


def test_vertical_edges_of_a_post_against_a_flat_streak() -> None:
    post = _water()
    post[50:66, 100:103] = 40  # tall and thin: edges along x
    streak = _water()
    streak[60:62, 94:106] = 150  # a crest: long and flat, edges along y
    assert _features(post)[F["edges_log2"]] > 0.5
    assert _features(streak)[F["edges_log2"]] < -0.5
