"""Ship detection for real seas: local sea-clutter CFAR on an image pyramid, both polarities.

`SeaDetector` has the interface of `edge.measure.detect.Detector` (the same constructor, `detect`
returning `Blob`s in raw full-resolution left-image pixels, the same horizon state) and
replaces its contrast and threshold stages; `pipeline.experimental.detector` picks one (edge.config.app).

Why: on real shore-camera imagery the row-band threshold of `Detector` is set by the worst
texture in the band (sun glitter, whitecaps), small boats sink below it and what passes is
mostly clutter (issue 24). Here every cell is compared with the sea beside it on the same
levelled rows (edge.core.seaclutter): glitter raises its own threshold, quiet water keeps a
low one, and a compact hull, bright or dark, stands out from either.

1. Horizon: predicted from the calibration and refined from the image, as `Detector` does
   (the same code: `_refine_horizon`), then each column levelled by a fraction of a row
   (edge.core.level, Q8 fixed point) so the horizon is one row.
2. The search band: the levelled rows from a little above the horizon (a far ship's
   superstructure stands above it) to the bottom.
3. Pyramid: the band at the working resolution (1 / `decimation`) and LEVELS - 1 halvings
   (area average). One 4 x 2 cell shape on every level finds hulls 4-16 level px long, so
   together the levels cover ships from ~8 px to the full width.
4. CFAR on every level (`cfar_hits`): a cell K4 / 4 times brighter or darker than the mean
   contrast of its ring, and at least FLOOR_DN above the ring's mean.
5. Components per level, kept when their length suits the level (a finer level already saw
   a shorter body: up to MAX_LEVEL_LEN level px, no limit on the coarsest), tall enough for
   their length (crests are flat), with their waterline at or below the horizon and inside the
   optional search mask (True = may detect; edge.measure.tracks' site masks pass theirs).
6. Across levels, a box mostly inside a larger one is the same ship seen at a finer level
   (a bow, a bridge): the larger box is kept.

Cost: integer box sums from integral images on a band of about half the image, halved per
level (lab/bench/detect_cost.py: the time per pass at 2048 x 1536 beside StereoBM).
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import yaml

from edge.core.level import level_columns, shifts_q8
from edge.core.rectify import Rectifier
from edge.core.seaclutter import CELL_H, CELL_W, cfar_hits
from edge.core.shipfeatures import FEATURES, N_FEATURES, component_features
from edge.core.shipscore import AdditiveModel, model_from_dict
from edge.measure.detect import Blob, Detector

LEVELS = 5  # pyramid levels: working resolution and four halvings
K4 = 16  # candidate threshold, quarters: a cell 4 times the mean contrast of its ring (loose: the
# verifier decides; at 6 times the faint hulls were lost, issue 24)
FLOOR_DN = 6.0  # and at least this far from the ring's mean (sensor noise, JPEG blocks, swell)
MAX_LEVEL_LEN = 16  # a body longer than this (level px) is left to the next coarser level
MIN_HEIGHT_RATIO = 0.1  # a silhouette at least this tall for its length (crests are flatter)
TOP_MARGIN_SHARE = 1 / 12  # the band starts this share of the image height above the horizon
MIN_TOP_MARGIN_PX = 16
CONTAIN_SHARE = 0.5  # a box with this share of its area inside a larger one is the same ship
MODEL_PATH = Path(__file__).with_name("sea_verifier.yaml")  # fitted by lab/evaluate/detect_train.py
_LEVELS_SEEN = FEATURES.index("levels_seen")


def load_verifier(path: Path = MODEL_PATH) -> AdditiveModel:
    """The verifier's tables from their YAML file (edge.core.shipscore's stored form)."""
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ValueError(f"{path}: {exc}") from exc
    try:
        model = model_from_dict(data)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from exc
    if model.names != FEATURES:
        raise ValueError(f"{path}: features {model.names}, the detector computes {FEATURES}")
    return model


class SeaDetector(Detector):
    """Finds ship blobs against the local sea clutter; keeps the refined horizon between calls.

    `verifier`: the additive model that scores each candidate (default: the fitted tables in
    sea_verifier.yaml beside this module); None reports every candidate (the candidate stage)."""

    def __init__(self, rectifier: Rectifier, site_height_m: float, *, decimation: int = 2,
                 min_ship_px: int = 20, levels: int = LEVELS, k4: int = K4,
                 floor_dn: float = FLOOR_DN, verifier: AdditiveModel | None | str = "default") -> None:
        super().__init__(rectifier, site_height_m, decimation=decimation, min_ship_px=min_ship_px)
        self.levels = max(1, int(levels))
        self.k4 = int(k4)
        self.floor_q = int(round(4 * floor_dn))
        self.verifier = load_verifier() if isinstance(verifier, str) else verifier

    def detect(self, left: np.ndarray, search_mask: np.ndarray | None = None) -> list[Blob]:
        """Candidate ships in one left image (grey uint8, full resolution), left to right.

        `search_mask`: optional boolean array of the image's shape, True where a ship may be
        reported (a blob's waterline centre must fall on True)."""
        blobs, features = self.candidates(left, search_mask)
        if self.verifier is not None and blobs:
            keep = self.verifier.verified(features)
            blobs = [b for b, k in zip(blobs, keep, strict=True) if k]
        return sorted(_suppress_contained(blobs), key=lambda b: (b.x0, b.y0))

    def candidates(self, left: np.ndarray, search_mask: np.ndarray | None = None
                   ) -> tuple[list[Blob], np.ndarray]:
        """Every candidate on the sea before verification: blobs (full-resolution raw pixels) and
        their feature rows (edge.core.shipfeatures.FEATURES), shape (n, N_FEATURES)."""
        if search_mask is not None and search_mask.shape != left.shape:
            raise ValueError(f"search mask is {search_mask.shape}, the image {left.shape}")
        dec = self.decimation
        hs, ws = self.height // dec, self.width // dec
        small = left if dec == 1 else cv2.resize(left, (ws, hs), interpolation=cv2.INTER_AREA)
        horizon = self._refine_horizon(small)  # rows of the working image per column
        level_row = float(np.median(horizon))
        shifts = horizon - level_row
        margin = max(MIN_TOP_MARGIN_PX, int(self.height * TOP_MARGIN_SHARE)) / dec
        top = int(np.clip(math.floor(level_row - margin), 0, hs - 2))
        # level only the band (and the rows its shifts reach)
        reach = int(np.ceil(np.abs(shifts).max())) + 1
        r0 = max(0, top - reach)
        flat = level_columns(small[r0:], shifts_q8(shifts))[top - r0:]
        found: list[tuple[int, int, int, int, float, np.ndarray]] = []
        image = flat
        for k in range(self.levels):
            if image.shape[0] < CELL_H + 1 or image.shape[1] < 2 * CELL_W:
                break
            found += self._level_candidates(image, k, top, (level_row - top) / (1 << k))
            if k + 1 < self.levels:
                image = cv2.resize(image, (image.shape[1] // 2, image.shape[0] // 2),
                                   interpolation=cv2.INTER_AREA)
        blobs, rows = [], []
        for x0, y0, x1, y1, contrast, feats in found:
            c0 = min(max(0, x0), ws - 1)
            c1 = max(c0 + 1, min(ws, x1))
            dy = shifts[c0:c1]  # back from levelled rows to image rows
            top_raw, bottom_raw = y0 + math.floor(dy.min() + 0.5), y1 + math.floor(dy.max() + 0.5)
            blob = Blob(x0 * dec, top_raw * dec, x1 * dec, bottom_raw * dec,
                        (x1 - x0) * (y1 - y0) * dec * dec, contrast)
            if self._on_sea(blob, horizon, search_mask):
                blobs.append(blob)
                rows.append(feats)
        features = np.array(rows).reshape(len(rows), N_FEATURES)
        if len(blobs) > 1:
            features[:, _LEVELS_SEEN] = _levels_seen(blobs, features[:, FEATURES.index("level")])
        return blobs, features

    def _level_candidates(self, image: np.ndarray, k: int, top: int, horizon_row: float
                          ) -> list[tuple[int, int, int, int, float, np.ndarray]]:
        """Components of one level's CFAR hits, as working-resolution boxes (levelled rows), with
        their features (horizon_row: the horizon in this level's rows)."""
        hits, a, bright, clutter = cfar_hits(image, self.k4, self.floor_q)
        n, labels, stats, _ = cv2.connectedComponentsWithStats(hits, connectivity=8)
        scale = 1 << k
        coarsest = k == self.levels - 1
        out = []
        for i in range(1, n):
            x, y, w, h, _area = (int(v) for v in stats[i])
            if w > MAX_LEVEL_LEN and not coarsest:
                continue
            if w * scale * self.decimation < self.min_ship_px:
                continue
            if h < MIN_HEIGHT_RATIO * w:
                continue
            if y + h >= image.shape[0] - CELL_H:
                continue  # cells cut by the image's bottom edge: the nearest, steepest waves
            # the cells' union overshoots the body by about half a cell on each side
            x0 = int(round((x + 0.5 * (CELL_W - 1)) * scale))
            y0 = int(round((y + 0.5 * (CELL_H - 1)) * scale)) + top
            sel = labels[y:y + h, x:x + w] == i
            peak = float(a[y:y + h, x:x + w][sel].max()) / 4.0
            feats = component_features(image, a, bright, clutter, labels, stats[i], i,
                                       scale_px=float(scale * self.decimation),
                                       horizon_row=horizon_row, image_height_px=float(self.height),
                                       level=k)
            out.append((x0, y0, x0 + w * scale, y0 + h * scale, peak, feats))
        return out

    def _on_sea(self, blob: Blob, horizon: np.ndarray, search_mask: np.ndarray | None) -> bool:
        """The waterline at or below the horizon (a little slack) and inside the search mask."""
        dec = self.decimation
        if blob.height < 2:
            return False
        cols = np.arange(blob.x0 // dec, max(blob.x0 // dec + 1, blob.x1 // dec))
        h_row = float(np.median(horizon[np.clip(cols, 0, len(horizon) - 1)])) * dec
        if blob.y1 < h_row - max(2.0 * dec, 0.1 * blob.height):
            return False
        if search_mask is not None:
            cx = min(self.width - 1, max(0, (blob.x0 + blob.x1) // 2))
            cy = min(self.height - 1, max(0, blob.y1 - 1))
            if not search_mask[cy, cx]:
                return False
        return True


def _levels_seen(blobs: list[Blob], level: np.ndarray) -> np.ndarray:
    """For each blob, the number of distinct pyramid levels among the blobs overlapping it (itself
    included): a hull stands out at more than one scale, a glint at one."""
    b = np.array([[x.x0, x.y0, x.x1, x.y1] for x in blobs], np.int64)
    overlap = ((np.minimum(b[:, None, 2], b[None, :, 2]) > np.maximum(b[:, None, 0], b[None, :, 0]))
               & (np.minimum(b[:, None, 3], b[None, :, 3]) > np.maximum(b[:, None, 1], b[None, :, 1])))
    lv = level.astype(np.int64)
    seen = np.zeros((len(blobs), int(lv.max()) + 1), bool)
    rows, cols = np.nonzero(overlap)
    seen[rows, lv[cols]] = True
    return seen.sum(axis=1).astype(np.float64)


def _suppress_contained(blobs: list[Blob]) -> list[Blob]:
    """Largest first; a box with CONTAIN_SHARE of its area inside a kept one is dropped."""
    kept: list[Blob] = []
    for b in sorted(blobs, key=lambda b: b.width * b.height, reverse=True):
        area = max(1, b.width * b.height)
        inside = False
        for a in kept:
            ix = max(0, min(a.x1, b.x1) - max(a.x0, b.x0))
            iy = max(0, min(a.y1, b.y1) - max(a.y0, b.y0))
            if ix * iy >= CONTAIN_SHARE * area:
                inside = True
                break
        if not inside:
            kept.append(b)
    return kept
