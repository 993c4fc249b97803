"""Ship detection in the left image: compact local-contrast blobs on the sea, at or below the horizon.

Runs every k-th pair on an image shrunk by `decimation` (INTER_AREA), so it
costs a few milliseconds even at 2048 x 1536:

1. Horizon. Predicted from the calibration and the site height (the dip of
   the horizon, `geo.horizon_dip_rad`, mapped through the left camera model
   column by column), then refined from the image: the strongest mean vertical
   gradient near the prediction in each of several column bands, the median
   offset over the bands (so a ship on the horizon cannot pull it), clamped to
   a few pixels of the prediction and smoothed over time.
2. Levelling. Each column is moved up by its horizon's offset from the
   median horizon row, by a fraction of a row (linear between rows): a rolled
   camera tilts the horizon, the lens curves it, and whole-row shifts would
   leave up to half a row of it, which where the brightness changes fast down
   the rows (the horizon step, the haze under it) is a residual as strong as a
   hull along every run of columns on the wrong side of the rounding.
3. Contrast. The residual against the row's median (the sky and sea gradients
   and the horizon step are constant along a levelled row), averaged over a
   small box: noise drops by the square root of its area, a solid hull does
   not. Both polarities count (bright superstructure, dark hulls).
4. Threshold per row, from the robust spread (median + k MAD) of the residual:
   one level for the sky, and on the sea levels from row bands interpolated
   between the bands' centre rows. The sea's texture grows steadily toward the
   camera (the same waves seen nearer and steeper: their image scale and
   contrast rise with the depression angle), so a level held constant over a
   band is the band's average texture and the near edge of every band passes
   as long, flat "wave band" blobs; a level that follows the rows does not.
5. Blobs: a horizontal closing joins hull and superstructure, connected
   components with stats, nearby boxes merged. Kept when at least
   `min_ship_px` long (eq. 3.12 sets that length), tall enough to be a body
   rather than a wave crest, their bottom at or below the horizon (on the sea,
   or hull-down beyond it), and standing at least `MIN_HEIGHT_M` tall at the
   sea range of their waterline. Glints (a few pixels) fail the size test;
   what still slips through must persist and match in stereo at the sea range
   of its waterline before it becomes a track (tracking.py).

Cost: the work images are kept between calls (fresh multi-megabyte arrays cost
page faults), the horizon gradient is taken on the search strip only, and the
labelling runs inside the bounding box of the set pixels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from edge.core.geo import horizon_dip_rad, sea_range_m
from edge.core.rectify import Rectifier

HORIZON_SEARCH_DEG = 0.6  # refinement searches this far either side of the predicted horizon
HORIZON_BANDS = 8  # column bands for the horizon refinement
HORIZON_SMOOTHING = 0.3  # weight of a new horizon offset against the running one
THRESHOLD_K = 6.0  # threshold = median + k * 1.4826 MAD of the contrast, per row band
MIN_CONTRAST_DN = 6.0  # never below this: sensor noise and quantisation
ROW_BANDS = 6  # row bands for the thresholds below the horizon
MIN_HEIGHT_RATIO = 0.08  # a ship's silhouette is at least this tall for its length (crests are flatter)
MIN_HEIGHT_M = 2.0  # a 10 m boat stands 2.2 m above the water; a wave band at 500 m is ~1 m
MIN_HEIGHT_PX = 2.0  # and at least this many full-resolution rows (a 70 m coaster at 3 km: 3 rows)
MIN_LENGTH_SHARE = 0.7  # a blob may look this much shorter than the ship (threshold eats faint ends)
BACKGROUND_STEP = 2  # every n-th column (at least) enters the row medians and the thresholds
BACKGROUND_COLUMNS = 160  # ... and no more columns than this (the medians are the detector's main cost)


@dataclass(frozen=True, slots=True)
class Blob:
    """A candidate ship in full-resolution raw left-image pixels; the box is [x0, x1) x [y0, y1)."""

    x0: int
    y0: int
    x1: int
    y1: int
    area_px: int  # full-resolution pixels above threshold
    contrast_dn: float  # mean top-hat response inside the blob

    @property
    def width(self) -> int:
        return self.x1 - self.x0

    @property
    def height(self) -> int:
        return self.y1 - self.y0

    @property
    def centre(self) -> tuple[float, float]:
        return 0.5 * (self.x0 + self.x1 - 1), 0.5 * (self.y0 + self.y1 - 1)

    def iou(self, other: Blob) -> float:
        ix = max(0, min(self.x1, other.x1) - max(self.x0, other.x0))
        iy = max(0, min(self.y1, other.y1) - max(self.y0, other.y0))
        inter = ix * iy
        union = self.width * self.height + other.width * other.height - inter
        return inter / union if union > 0 else 0.0


class Detector:
    """Finds ship blobs in left images of one rig; keeps the refined horizon between calls."""

    def __init__(self, rectifier: Rectifier, site_height_m: float, *, decimation: int = 2,
                 min_ship_px: int = 20) -> None:
        self.rect = rectifier
        self.site_height_m = site_height_m
        self.dip_rad = horizon_dip_rad(site_height_m)
        self.decimation = max(1, int(decimation))
        self.min_ship_px = int(min_ship_px)
        rig = rectifier.rig
        self.width, self.height = rig.width, rig.height
        self.horizon_raw = self._predicted_horizon(site_height_m)  # (width,) raw left rows, full res
        self.horizon_offset_px = 0.0  # refinement, full-resolution rows
        # the last pass's offset per band found, full-resolution rows from the prediction itself
        # (tools/horizon-offset). The smoothed `horizon_offset_px` the detection levels with is taken
        # from the prediction's rounded rows (up to a decimated row of rounding in it, which steps as
        # the prediction moves): within that it splits sky from sea as well, and from the prediction
        # itself it moved akashi-crossing's coaster's re-birth (an id switch)
        self.horizon_bands_px = np.empty(0)
        self.search_px = max(3.0, rectifier.f_px * math.tan(math.radians(HORIZON_SEARCH_DEG)))
        self._buf: dict[str, np.ndarray] | None = None  # work images, `_buffers`

    def _predicted_horizon(self, site_height_m: float) -> np.ndarray:
        """Row of the sea horizon in each raw left column: the dip mapped through the camera model."""
        t = math.tan(horizon_dip_rad(site_height_m))
        u_rect = np.linspace(-0.25 * self.width, 1.25 * self.width, 64)
        x = self.rect.rect_to_normalised(np.stack([u_rect, np.full_like(u_rect, self.rect.cy)], -1))[:, 0]
        # the horizon is a cone of constant dip: y = tan(dip) * sqrt(1 + x^2) on the normalised plane
        rect = self.rect.normalised_to_rect(np.stack([x, t * np.sqrt(1.0 + x * x)], -1))
        raw = self.rect.rect_to_raw(rect, 0)
        ok = np.isfinite(raw).all(axis=1)
        order = np.argsort(raw[ok, 0])
        return np.interp(np.arange(self.width), raw[ok, 0][order], raw[ok, 1][order])

    @property
    def horizon_row(self) -> np.ndarray:
        """Current (refined) horizon row per raw left column, full resolution."""
        return self.horizon_raw + self.horizon_offset_px

    def _refine_horizon(self, small: np.ndarray) -> np.ndarray:
        dec = self.decimation
        hs, ws = small.shape
        pred = self.horizon_raw[::dec][:ws] / dec + 0.5 / dec - 0.5
        radius = int(math.ceil(self.search_px / dec)) + 1
        rows_all = np.round(pred).astype(int)
        # the vertical gradient of the strip the search covers only (one row of margin for the kernel)
        lo = max(0, int(rows_all.min()) - radius - 1)
        hi = min(hs, int(rows_all.max()) + radius + 2)
        grad = cv2.Sobel(small[lo:hi], cv2.CV_32F, 0, 1, ksize=3) if hi - lo >= 3 else None
        offsets, measured = [], []  # per band: from the prediction's rounded rows / from the prediction
        for band in np.array_split(np.arange(ws), HORIZON_BANDS):
            rows = rows_all[band]
            k = np.arange(-radius, radius + 1)
            idx = rows[None, :] + k[:, None]
            if grad is None or idx.min() < 1 or idx.max() >= hs - 1:
                continue
            profile = np.abs(grad[idx - lo, band[None, :]].mean(axis=1))
            best = int(np.argmax(profile))
            if 0 < best < len(k) - 1 and profile[best] > 2.0 * np.median(profile):
                c_m, c_0, c_p = profile[best - 1:best + 2]
                den = c_m - 2.0 * c_0 + c_p
                frac = 0.5 * (c_m - c_p) / den if den < 0 else 0.0
                offsets.append((k[best] + frac) * dec)
                measured.append((k[best] + frac + float(np.mean(rows - pred[band]))) * dec)
        self.horizon_bands_px = np.array(measured)
        if len(offsets) >= max(2, HORIZON_BANDS // 2):
            new = float(np.clip(np.median(offsets), -self.search_px, self.search_px))
            self.horizon_offset_px += HORIZON_SMOOTHING * (new - self.horizon_offset_px)
        return self.horizon_row[::dec][:ws] / dec

    def detect(self, left: np.ndarray) -> list[Blob]:
        """Candidate ships in one left image (grey uint8, full resolution), left to right."""
        dec = self.decimation
        hs, ws = self.height // dec, self.width // dec
        buf = self._buffers(hs, ws)
        small = left if dec == 1 else cv2.resize(left, (ws, hs), dst=buf["small"],
                                                 interpolation=cv2.INTER_AREA)
        horizon = self._refine_horizon(small)
        level_row = float(np.median(horizon))
        shifts = (horizon - level_row).astype(np.float32)  # rows, fractional
        flat = self._level(small, shifts, buf)
        step = max(BACKGROUND_STEP, ws // BACKGROUND_COLUMNS)
        background = _row_median(flat[:, ::step], buf["sorted"])
        # signed residual, averaged over a small box: noise drops by its sqrt(area), a solid hull does not
        box_w, box_h = max(3, (self.min_ship_px // (4 * dec)) | 1), 3 if dec == 1 else 1
        flat -= background[:, None]
        # the box mean as two 1-D passes (cv2.blur on float32 is several times slower; same result)
        residual = cv2.sepFilter2D(flat, cv2.CV_32F, np.full(box_w, 1.0 / box_w, np.float32),
                                   np.full(box_h, 1.0 / box_h, np.float32), dst=buf["residual"])
        np.abs(residual, out=residual)
        levels = self._levels(residual, int(round(level_row)))
        mask = np.greater(residual, levels[:, None], out=buf["above"]).view(np.uint8)
        if dec == 1:  # single-row streaks are crests (at dec >= 2 one row is already two)
            mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_RECT, (1, 2)))
        close_w = max(3, int(round(self.min_ship_px / (4 * dec))) | 1)
        closing = cv2.getStructuringElement(cv2.MORPH_RECT, (close_w, 3))
        mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, closing, dst=buf["closed"])
        # components inside the box that holds every set pixel (the same components, a fraction of the
        # image), by Grana's block-based labelling (its statistics pass is the cheap one in OpenCV)
        bx, by, bw, bh = cv2.boundingRect(mask)
        if bw == 0 or bh == 0:
            return []
        labels = buf["labels"].reshape(-1)[:bw * bh].reshape(bh, bw)
        n, labels, stats, _ = cv2.connectedComponentsWithStatsWithAlgorithm(
            mask[by:by + bh, bx:bx + bw], 8, cv2.CV_32S, cv2.CCL_GRANA, labels=labels)
        boxes = [[int(x) + bx, int(y) + by, int(x + w) + bx, int(y + h) + by, int(a), i]
                 for i, (x, y, w, h, a) in enumerate(stats[1:], start=1) if w * dec >= self.min_ship_px // 2]
        blobs = []
        for x0, y0, x1, y1, area, labs in _merge(boxes, gap=close_w):
            if (x1 - x0) * dec < MIN_LENGTH_SHARE * self.min_ship_px:  # a faint hull's ends sink in noise
                continue
            sel = np.isin(labels[y0 - by:y1 - by, x0 - bx:x1 - bx], labs)
            resp = float(residual[y0:y1, x0:x1][sel].mean())
            dy = shifts[x0:x1]  # back from horizon-level rows to image rows
            top, bottom = y0 + math.floor(dy.min() + 0.5), y1 + math.floor(dy.max() + 0.5)
            blob = Blob(x0 * dec, top * dec, x1 * dec, bottom * dec, area * dec * dec, resp)
            if self._plausible(blob, horizon):
                blobs.append(blob)
        return blobs

    def _buffers(self, hs: int, ws: int) -> dict[str, np.ndarray]:
        """Work images kept between calls: a fresh multi-megabyte array per step costs the kernel's
        page faults and zeroing on first touch, as much again as the arithmetic at 2048 x 1536."""
        if self._buf is None or self._buf["flat"].shape != (hs, ws):
            step = max(BACKGROUND_STEP, ws // BACKGROUND_COLUMNS)
            self._buf = {"small": np.empty((hs, ws), np.uint8), "padded": np.empty((hs + 8, ws), np.float32),
                         "flat": np.empty((hs, ws), np.float32), "residual": np.empty((hs, ws), np.float32),
                         "sorted": np.empty((hs, len(range(0, ws, step))), np.float32),
                         "above": np.empty((hs, ws), np.bool_), "closed": np.empty((hs, ws), np.uint8),
                         "labels": np.empty((hs, ws), np.int32)}
        return self._buf

    def _level(self, small: np.ndarray, shifts: np.ndarray, buf: dict[str, np.ndarray]) -> np.ndarray:
        """The image with each column moved up by its (fractional) shift, so the horizon is one row:
        float32, linear between rows. Whole-row shifts would leave up to half a row of tilt, and
        where the brightness changes fast down the rows (the horizon step, the haze near it) half a
        row of it is a residual as strong as a hull, along every column run on the wrong side."""
        hs = small.shape[0]
        out = buf["flat"]
        if not shifts.any():
            np.copyto(out, small)
            return out
        whole = np.floor(shifts).astype(np.intp)
        frac = shifts - whole
        pad = int(np.abs(whole).max()) + 1
        if buf["padded"].shape[0] < hs + 2 * pad:
            buf["padded"] = np.empty((hs + 2 * pad, small.shape[1]), np.float32)
        src = buf["padded"][:hs + 2 * pad]
        np.copyto(src[pad:pad + hs], small)
        src[:pad] = src[pad]  # rows past the edges repeat them
        src[pad + hs:] = src[pad + hs - 1]
        # runs of columns with the same whole-row shift (a few: the shift changes slowly along the horizon)
        edges = [0, *(np.flatnonzero(np.diff(whole)) + 1).tolist(), len(whole)]
        for c0, c1 in zip(edges[:-1], edges[1:], strict=True):
            r0 = pad + int(whole[c0])
            upper, lower = src[r0:r0 + hs, c0:c1], src[r0 + 1:r0 + 1 + hs, c0:c1]
            np.multiply(lower - upper, frac[None, c0:c1], out=out[:, c0:c1])
            out[:, c0:c1] += upper
        return out

    def _levels(self, residual: np.ndarray, horizon_row: int) -> np.ndarray:
        """Threshold per row: median + k MAD of |residual| over the sky, and over each sea row band,
        interpolated between the bands' centre rows (held beyond the first and last centres)."""
        hs = residual.shape[0]
        levels = np.empty(hs, np.float32)
        sample = residual[::2, ::max(BACKGROUND_STEP, residual.shape[1] // BACKGROUND_COLUMNS)]
        top = int(np.clip(horizon_row, 1, hs - 1))
        split = np.array_split(np.arange(top, hs), ROW_BANDS)
        bands = [(0, top)] + [(b[0], b[-1] + 1) for b in split if len(b)]
        for r0, r1 in bands:
            levels[r0:r1] = _robust_level(sample[r0 // 2:(r1 + 1) // 2])
        sea = bands[1:]
        if len(sea) >= 2:
            centres = np.array([0.5 * (r0 + r1 - 1) for r0, r1 in sea])
            values = np.array([levels[r0] for r0, _ in sea])
            levels[top:] = np.interp(np.arange(top, hs), centres, values)
        return levels

    def _plausible(self, blob: Blob, horizon: np.ndarray) -> bool:
        """Shape and sea/sky context: a body on the sea, not a crest, a glint or something in the sky."""
        dec = self.decimation
        if blob.height < max(MIN_HEIGHT_PX, MIN_HEIGHT_RATIO * blob.width):
            return False
        cols = np.arange(blob.x0 // dec, max(blob.x0 // dec + 1, blob.x1 // dec))
        h_row = float(np.median(horizon[np.clip(cols, 0, len(horizon) - 1)])) * dec
        # the waterline is on or below the horizon (within a little refraction and refinement slack)
        h_row = min(h_row, float(np.median(self.horizon_raw[np.clip(cols * dec, 0, self.width - 1)])))
        if blob.y1 < h_row - max(2.0 * dec, 0.1 * blob.height):
            return False
        # metric height at the sea range of the waterline: crests and troughs are flat streaks. The
        # waterline's depression is the dip plus its rows below the predicted horizon (small angles:
        # cheaper than mapping every candidate through the lens model, and as good for this test)
        centre = min(self.width - 1, max(0, (blob.x0 + blob.x1) // 2))
        depression = self.dip_rad + (blob.y1 - 0.5 - self.horizon_raw[centre]) / self.rect.f_px
        range_m = float(sea_range_m(depression, self.site_height_m))
        return blob.height * range_m / self.rect.f_px >= MIN_HEIGHT_M


def sea_range_at(rect: Rectifier, site_height_m: float, u: float, v: float) -> float:
    """Horizontal range where the ray through rectified pixel (u, v) meets the sea (inf above the horizon)."""
    x, y = rect.rect_to_normalised(np.array([u, v]))
    return float(sea_range_m(math.atan2(y, math.hypot(1.0, x)), site_height_m))


def _row_median(values: np.ndarray, work: np.ndarray) -> np.ndarray:
    """np.median(values, axis=1), by one in-place sort in `work` (numpy's per-row partition is ten
    times slower here)."""
    np.copyto(work, values)
    work.sort(axis=1)
    ordered = work
    n = ordered.shape[1]
    return 0.5 * (ordered[:, (n - 1) // 2] + ordered[:, n // 2])


def _robust_level(values: np.ndarray) -> float:
    if values.size == 0:
        return 255.0
    med = float(np.median(values))
    mad = float(np.median(np.abs(values - med)))
    return max(MIN_CONTRAST_DN, med + THRESHOLD_K * 1.4826 * mad)


def _merge(boxes: list[list], gap: int) -> list[tuple[int, int, int, int, int, list[int]]]:
    """Union of boxes that overlap once grown by `gap` horizontally and 1 row vertically (one ship)."""
    merged = [(b[0], b[1], b[2], b[3], b[4], [b[5]]) for b in sorted(boxes)]
    changed = True
    while changed:
        changed = False
        out: list[tuple[int, int, int, int, int, list[int]]] = []
        for b in merged:
            for j, a in enumerate(out):
                if b[0] <= a[2] + gap and a[0] <= b[2] + gap and b[1] <= a[3] + 1 and a[1] <= b[3] + 1:
                    out[j] = (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3]),
                              a[4] + b[4], a[5] + b[5])
                    changed = True
                    break
            else:
                out.append(b)
        merged = out
    return merged
