"""The horizon as a straight line found in one image, without a calibration: the strongest long edge.

Why: a camera without a calibration (a new site, a public webcam used for evaluation) still
needs the line where the sea ends: the detector levels the image along it and tests a ship's
waterline against it. The sea horizon, or the waterline of a far coast, is the longest
straight brightness step across the image; clouds, waves and buildings give strong edges too,
but not the same straight line in most column bands.

Method: the image shrunk to about WORK_WIDTH columns (area average); the vertical gradient of
a vertically smoothed copy; in each of BANDS column bands, the row where the band's mean
|gradient| peaks (a horizon tilted by a few rows over a band still adds up); a Theil-Sen line
through the band peaks (the median of the pairwise slopes and then of the intercepts: half
the bands may be wrong), then a least-squares refit on the bands within INLIER_PX of it.
Returns the line as two image points (x = 0 and x = width - 1), full-resolution rows.
"""

from __future__ import annotations

import cv2
import numpy as np

WORK_WIDTH = 480  # columns of the shrunk image the search runs on
BANDS = 24  # column bands with one peak each
INLIER_PX = 2.0  # shrunk-image rows from the Theil-Sen line that count as on it
MIN_INLIERS = 8  # bands that must agree, else no horizon
MIN_GRADIENT = 8.0  # a band's peak mean |Sobel| at least this (a 2 DN step) and twice its median


def band_peaks(image: np.ndarray, row_range: tuple[float, float] | None = None
               ) -> tuple[np.ndarray, np.ndarray, float]:
    """(x, y) of each band's strongest mean vertical gradient in the shrunk image, and its scale
    (full-resolution px per shrunk px). `row_range` limits the search (full-resolution rows)."""
    if not isinstance(image, np.ndarray) or image.ndim != 2 or image.dtype != np.uint8:
        raise ValueError("the horizon finder needs a 2-D uint8 image")
    h, w = image.shape
    scale = max(1.0, w / WORK_WIDTH)
    ws, hs = max(BANDS, int(round(w / scale))), max(8, int(round(h / scale)))
    small = cv2.resize(image, (ws, hs), interpolation=cv2.INTER_AREA)
    grad = np.abs(cv2.Sobel(cv2.GaussianBlur(small, (1, 5), 0), cv2.CV_32F, 0, 1, ksize=3))
    lo, hi = 2, hs - 2
    if row_range is not None:
        lo = max(lo, int(row_range[0] / scale))
        hi = min(hi, int(np.ceil(row_range[1] / scale)))
    if hi - lo < 3:
        return np.empty(0), np.empty(0), scale
    xs, ys = [], []
    for band in np.array_split(np.arange(ws), BANDS):
        profile = grad[lo:hi, band].mean(axis=1)
        best = int(np.argmax(profile))
        if profile[best] < max(MIN_GRADIENT, 2.0 * float(np.median(profile))):
            continue  # no step in this band
        frac = 0.0
        if 0 < best < len(profile) - 1:
            c_m, c_0, c_p = profile[best - 1:best + 2]
            den = c_m - 2.0 * c_0 + c_p
            frac = 0.5 * (c_m - c_p) / den if den < 0 else 0.0
        xs.append(float(band.mean()))
        ys.append(lo + best + frac)
    return np.array(xs), np.array(ys), scale


def theil_sen(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Slope and intercept: the median of the pairwise slopes, then the median of y - slope x."""
    i, j = np.triu_indices(len(x), 1)
    dx = x[j] - x[i]
    ok = dx != 0
    slope = float(np.median((y[j] - y[i])[ok] / dx[ok])) if ok.any() else 0.0
    return slope, float(np.median(y - slope * x))


def find_horizon(image: np.ndarray, row_range: tuple[float, float] | None = None
                 ) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """Two points ((0, y0), (w - 1, y1)) of the horizon line, full resolution; None if no line."""
    xs, ys, scale = band_peaks(image, row_range)
    if len(xs) < MIN_INLIERS:
        return None
    slope, icpt = theil_sen(xs, ys)
    inl = np.abs(ys - (slope * xs + icpt)) <= INLIER_PX
    if int(inl.sum()) < MIN_INLIERS:
        return None
    slope, icpt = (float(v) for v in np.polyfit(xs[inl], ys[inl], 1))
    w = image.shape[1]

    def row_at(x_full: float) -> float:  # shrunk pixel centres: x_s = (x + 0.5) / scale - 0.5
        x_s = (x_full + 0.5) / scale - 0.5
        return (slope * x_s + icpt + 0.5) * scale - 0.5

    return (0.0, row_at(0.0)), (float(w - 1), row_at(float(w - 1)))
