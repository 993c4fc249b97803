"""One track's measurement chain: reference point, left follow, right match, disparity filter.

Everything here works in rectified left-image pixels (`edge.core.rectify`):
rows are epipolar lines and disparity d = u_left - u_right gives Z = f L_B / d.

- Reference point: where the window's summed squared horizontal gradient
  (sum Ix^2, what sets the matcher's sigma, research note §1.4) is largest in
  the upper part of the ship's box — the superstructure, the thesis's bridge,
  mostly seen against the sky, so the window holds little sea at another range.
- Left follow: the point is followed from pair to pair at sub-pixel precision
  (the thesis left it at whole pixels), around the position its image-motion
  filter predicts.
- Right match: `edge.core.match_point` on two rectified patches of the same
  rows and columns, the search narrowed to the disparity filter's prediction
  once it runs (a full search at birth and after a restart).
- Filter: the core's fixed-point CV Kalman with its 3-sigma gate (default),
  the thesis's Butterworth (eq. 6.1), or none (the raw whole-pixel / sub-pixel
  stages that tools/evaluate compares). A second Kalman smooths the left
  point's column for the bearing rate.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import cv2
import numpy as np

from edge.core.butterworth import ButterworthQ
from edge.core.kalman import DisparityKalman, KalmanDesign, design_kalman
from edge.core.match import Match, match_point
from edge.core.rectify import Rectifier

SUBPIXELS = ("cancel", "parabola", "none")
FILTERS = ("kalman", "butterworth", "none")
UPPER_SHARE = 0.6  # the reference point is searched in this top share of the ship's box
U_SIGMA_PX = 0.05  # left-follow noise for the image-motion filter
U_ACCEL_PXPS2 = 2.0  # image acceleration of a turning or approaching ship
NOISE_LADDER_PX = (0.04, 0.08, 0.16, 0.32, 0.64)  # disparity-noise levels of the Kalman designs
NOISE_WINDOW = 20  # recent raw disparities kept for the track's own noise estimate


@dataclass(frozen=True)
class PointSettings:
    """Matching and filtering knobs of every track (built by the pipeline from its configuration)."""

    fps: float = 10.0
    window: int = 15
    max_disparity: int = 128
    cost: str = "zssd"
    subpixel: str = "cancel"
    filter: str = "kalman"
    butterworth_cutoff_hz: float = 0.5
    gate_sigma: float = 3.0
    reacquire_s: float = 3.0
    noise_dn: float = 2.0  # camera noise for the matcher's predicted sigma
    max_sigma_px: float = 0.5  # matches predicted worse than this are rejected (too little texture)
    sigma_meas_px: float = 0.08  # the Kalman's measurement noise until the track has measured its own
    sigma_accel_pxps2: float = 0.05  # the Kalman's white acceleration (max d'' of a ship)
    search_radius_px: int = 4  # disparity search around the prediction
    follow_radius_px: int = 4  # left-follow search around the predicted position


class Designs:
    """The Kalman tables of one setting, computed once (lazily per noise level) and shared by all tracks.

    The measurement noise of a track is not known in advance: a textured bridge at 1 km
    matches to a few hundredths of a pixel, a small hull in fog to half a pixel. Each track
    measures its own scatter and uses the design of the matching rung of NOISE_LADDER_PX
    (factors of 2), so the gate and the reported sigma fit the data actually seen."""

    def __init__(self, s: PointSettings) -> None:
        self.s = s
        self._disparity: dict[float, KalmanDesign] = {}
        self.column: KalmanDesign = design_kalman(s.fps, U_SIGMA_PX, U_ACCEL_PXPS2, gate_sigma=5.0,
                                                  reacquire_s=s.reacquire_s, init_samples=3)

    def disparity(self, sigma_meas_px: float) -> KalmanDesign:
        if sigma_meas_px not in self._disparity:
            s = self.s
            self._disparity[sigma_meas_px] = design_kalman(s.fps, sigma_meas_px, s.sigma_accel_pxps2,
                                                           gate_sigma=s.gate_sigma, reacquire_s=s.reacquire_s)
        return self._disparity[sigma_meas_px]


def reference_point(patch: np.ndarray, box: tuple[int, int, int, int], origin: tuple[int, int],
                    window: int) -> tuple[float, float]:
    """The best-textured window centre in the upper part of `box` (rectified pixels, [x0, x1) x [y0, y1)).

    `patch` holds the rectified left image from `origin` (x, y) and covers the box plus half a
    window on each side. Ties go to the first (top-left) maximum, so the choice is deterministic."""
    x0, y0, x1, y1 = box
    ox, oy = origin
    g = patch.astype(np.float32)
    gx2 = np.zeros_like(g)
    gx2[:, 1:-1] = (g[:, 2:] - g[:, :-2]) ** 2
    energy = cv2.boxFilter(gx2, -1, (window, window), normalize=False, borderType=cv2.BORDER_CONSTANT)
    r1 = y0 + max(1, int(math.ceil(UPPER_SHARE * (y1 - y0))))
    sub = energy[y0 - oy:r1 - oy, x0 - ox:x1 - ox]
    iy, ix = np.unravel_index(int(np.argmax(sub)), sub.shape)
    return float(x0 + ix), float(y0 + iy)


def follow(previous: np.ndarray, current: np.ndarray) -> tuple[float, float] | None:
    """Sub-pixel shift (dx, dy) of the window `previous` inside the larger `current` region,
    relative to the centre of `current`; None at the search edge or for a flat cost surface.

    Stand-in for the core's sub-pixel point tracker (issue 4) until it lands: SSD by
    cv2.matchTemplate and a 3-point parabola (eq. 5.2) along each axis."""
    cost = cv2.matchTemplate(current, previous, cv2.TM_SQDIFF)
    iy, ix = np.unravel_index(int(np.argmin(cost)), cost.shape)
    ry, rx = (cost.shape[0] - 1) // 2, (cost.shape[1] - 1) // 2
    if not (0 < ix < cost.shape[1] - 1 and 0 < iy < cost.shape[0] - 1):
        return None
    fx = _vertex(cost[iy, ix - 1], cost[iy, ix], cost[iy, ix + 1])
    fy = _vertex(cost[iy - 1, ix], cost[iy, ix], cost[iy + 1, ix])
    if fx is None or fy is None:
        return None
    return ix - rx + fx, iy - ry + fy


def _vertex(cm: float, c0: float, cp: float) -> float | None:
    den = 2.0 * (float(cm) - 2.0 * float(c0) + float(cp))
    return None if den <= 0.0 else (float(cm) - float(cp)) / den


class TrackPoint:
    """The measured point of one track: position in the rectified left image, disparity, filters."""

    def __init__(self, u: float, v: float, settings: PointSettings, designs: Designs) -> None:
        self.s = settings
        self.designs = designs
        self.u, self.v = u, v
        self.template: np.ndarray | None = None  # window around (round(u), round(v)) in the last image
        self.match: Match | None = None  # this pair's right match (None: not attempted)
        self.raw_disparity: float | None = None
        self.disparity: float | None = None  # filtered
        self.rate_pxps = 0.0  # filtered d'
        self.sigma_px = math.inf
        self.u_filtered: float | None = None
        self.u_rate_pxps = 0.0
        self.updates = 0  # accepted disparity measurements since the filter (re)started
        self.accepted = False  # this pair's measurement went into the filter
        self.noise_px = settings.sigma_meas_px  # the Kalman design level in use
        self.recent: deque[float] = deque(maxlen=NOISE_WINDOW)
        self._reset_filters()

    def _reset_filters(self) -> None:
        s = self.s
        self.kalman = DisparityKalman(self.designs.disparity(self.noise_px)) if s.filter == "kalman" else None
        self.butter = ButterworthQ(s.butterworth_cutoff_hz, s.fps) if s.filter == "butterworth" else None
        self.column = DisparityKalman(self.designs.column)
        self.disparity, self.sigma_px, self.updates = None, math.inf, 0

    def scatter_px(self) -> float | None:
        """Robust noise of the recent raw disparities: MAD of successive differences / sqrt(2)
        (differences remove the slow trend of an approaching ship)."""
        if len(self.recent) < NOISE_WINDOW // 2:
            return None
        diff = np.diff(np.fromiter(self.recent, float))
        return float(1.4826 * np.median(np.abs(diff - np.median(diff))) / math.sqrt(2.0))

    def _adapt_noise(self) -> None:
        """Move the Kalman design one rung up or down the noise ladder when the scatter says so."""
        scatter = self.scatter_px()
        if scatter is None or self.kalman is None:
            return
        level = next((n for n in NOISE_LADDER_PX if n >= 1.25 * scatter), NOISE_LADDER_PX[-1])
        if (level > self.noise_px and scatter > 1.2 * self.noise_px) or \
                (level < self.noise_px and scatter < 0.4 * self.noise_px):
            # same state, the gains, gate and variances of the new level from the next update on
            self.noise_px = level
            self.kalman.design = self.designs.disparity(level)

    def reanchor(self, u: float, v: float) -> None:
        """Move to a new reference point on the same ship: new template, filters restart."""
        self.u, self.v = u, v
        self.template = None
        self._reset_filters()

    # ------------------------------------------------------------ per pair
    def step(self, left: np.ndarray, right: np.ndarray, rect: Rectifier, skipped: int = 0) -> bool:
        """Follow the point into this pair and measure its disparity; False if the point is lost.

        `skipped` pairs were missing since the last call (the filters coast through them)."""
        for _ in range(skipped):
            self._filter(None)
            self.u += self.u_rate_pxps / self.s.fps
        h = self.s.window // 2
        if self.template is not None:
            r = self.s.follow_radius_px
            pu = self.u + self.u_rate_pxps / self.s.fps
            cu, cv = int(round(pu)), int(round(self.v))
            region = rect.patch(left, 0, cu - h - r, cv - h - r, 2 * (h + r) + 1, 2 * (h + r) + 1)
            shift = follow(self.template, region)
            if shift is None:
                self._filter(None)
                self.match = None
                return False
            # the template was centred on the rounded old point; the texture moved by `shift`
            self.u += cu + shift[0] - round(self.u)
            self.v += cv + shift[1] - round(self.v)
        ui, vi = int(round(self.u)), int(round(self.v))
        if not (h + 2 <= ui < rect.rig.width - h - 2 and h + 1 <= vi < rect.rig.height - h - 1):
            self._filter(None)
            self.match = None
            return False
        self.template = rect.patch(left, 0, ui - h, vi - h, 2 * h + 1, 2 * h + 1).copy()
        self.match = self._match(left, right, rect, ui, vi)
        self._filter(self.match.disparity_px if self.match.valid else None)
        column = self.column.update(self.u)
        if column.valid:
            self.u_filtered, self.u_rate_pxps = column.disparity_px, column.rate_pxps
        return True

    def _match(self, left: np.ndarray, right: np.ndarray, rect: Rectifier, ui: int, vi: int) -> Match:
        s, h = self.s, self.s.window // 2
        predicted = self.disparity if (self.disparity is not None and self.s.filter != "none") else None
        if predicted is not None:
            pred = predicted + self.rate_pxps / s.fps
            d_hi = min(s.max_disparity, int(math.ceil(pred)) + s.search_radius_px + 1)
        else:
            pred, d_hi = None, s.max_disparity
        d_hi = max(d_hi, 4)
        x0, width = ui - h - d_hi - 4, 2 * h + d_hi + 9
        lp = rect.patch(left, 0, x0, vi - h, width, 2 * h + 1)
        rp = rect.patch(right, 1, x0, vi - h, width, 2 * h + 1)
        m = match_point(lp, rp, self.u - x0, self.v - (vi - h), window=s.window, max_disparity=d_hi,
                        predicted_disparity=pred,
                        search_radius=s.search_radius_px if pred is not None else None,
                        cost=s.cost, subpixel=s.subpixel, noise_dn=s.noise_dn, max_sigma_px=s.max_sigma_px)
        return m

    def _filter(self, z: float | None) -> None:
        self.raw_disparity = z
        if z is not None:
            self.recent.append(z)
            self._adapt_noise()
        if self.kalman is not None:
            est = self.kalman.update(z)
            if est.valid:
                self.disparity, self.rate_pxps, self.sigma_px = est.disparity_px, est.rate_pxps, est.sigma_px
                self.updates += int(est.accepted)
            else:
                self.disparity, self.sigma_px, self.updates = None, math.inf, 0
            self.accepted = bool(est.valid and est.accepted)
            return
        self.accepted = z is not None
        if z is None:
            return
        self.updates += 1
        m = self.match
        self.sigma_px = m.sigma_px if m is not None and math.isfinite(m.sigma_px) else 0.5
        if self.butter is not None:
            prev = self.disparity
            self.disparity = self.butter.update_px(z)
            if prev is not None:
                self.rate_pxps = (self.disparity - prev) * self.s.fps
        else:
            self.disparity = z
