"""The disparity side of a track's point (`edge.measure.point.TrackPoint` builds on it): the disparity
filter, the noise and acceleration levels of its design, and the last estimate it carries forward.

Why apart from the follow and match: this is the part that decides which measurements a track
believes. The filter is the core's fixed-point CV Kalman with its 3-sigma gate (default; its white
acceleration is what a ship at the track's disparity can do, `edge.measure.filter_designs`), the thesis's
Butterworth (eq. 6.1), or none (the raw whole-pixel / sub-pixel stages that tools/evaluate
compares). The Kalman's measurement noise follows the track's own scatter (a ladder of designs),
its prediction bounds where the point may resume after a search, and a restarting filter must
agree with the last accepted estimate carried forward at a physically possible rate.
"""

from __future__ import annotations

import math
from collections import deque

from edge.core.butterworth import ButterworthQ
from edge.core.kalman import DisparityKalman
from edge.core.linefit import median
from edge.core.match import Match
from edge.core.shipmotion import MAX_SHIP_SPEED_MPS, accel_rung
from edge.measure.filter_designs import Designs
from edge.measure.settings import PointSettings

NOISE_LADDER_PX = (0.04, 0.08, 0.16, 0.32)  # disparity-noise levels of the Kalman designs
MAX_USABLE_NOISE_PX = 0.4  # a point scattering more than this gives no usable range (stays Q / turns L)
MIN_SCATTER_SAMPLES = 6  # raw disparities before the scatter counts
NOISE_WINDOW = 20  # recent raw disparities kept for the track's own noise estimate
MEMORY_S = 10.0  # a restarting filter must agree with the last estimate carried this far forward


class PointFilter:
    """Disparity filter state of one point (a base of `TrackPoint`, which advances `frame`, sets
    `match` and calls `_filter` once per pair)."""

    def __init__(self, settings: PointSettings, designs: Designs) -> None:
        self.s = settings
        self.designs = designs
        self.frame = 0  # pairs seen (and skipped): the time axis of the column fit
        self.match: Match | None = None  # this pair's right match (None: not attempted)
        self.raw_disparity: float | None = None
        self.accepted = False  # this pair's measurement went into the filter
        self.collected = False  # ... or into the samples a (re)starting Kalman starts from
        self.collected_frame = -1  # the last pair that did
        self.noise_px = settings.sigma_meas_px  # the Kalman design level in use
        self.memory: tuple[int, float, float, float] | None = None  # last accepted (frame, d, d', sigma)
        self.recent: deque[float] = deque(maxlen=NOISE_WINDOW)
        self._scatter: tuple[float | None] | None = None  # scatter_px() of `recent` (None: not computed)
        self._reset_filters()

    def _reset_filters(self) -> None:
        s = self.s
        self.accel_pxps2 = s.sigma_accel_pxps2  # the Kalman's white acceleration, see _adapt_accel
        self.kalman = DisparityKalman(self.designs.disparity(self.noise_px)) if s.filter == "kalman" else None
        self.butter = ButterworthQ(s.butterworth_cutoff_hz, s.fps) if s.filter == "butterworth" else None
        self.disparity: float | None = None  # filtered
        self.rate_pxps = 0.0  # filtered d'
        self.sigma_px = math.inf
        self.updates = 0  # accepted disparity measurements since the filter (re)started

    def predicted_disparity(self) -> float | None:
        prediction = self.prediction()
        return None if prediction is None else prediction[0]

    def prediction(self) -> tuple[float, float] | None:
        """(disparity, 1-sigma) expected in this pair: the filter's prediction, or while the filter
        restarts the last accepted estimate carried forward; None when there is neither."""
        if self.s.filter == "none":
            return None
        if self.disparity is not None:
            return self.disparity + self.rate_pxps / self.s.fps, self.sigma_px
        return self._memory_now()

    def _memory_now(self) -> tuple[float, float] | None:
        """(disparity, 1-sigma) of the last accepted estimate carried forward to this pair, with the
        uncertainty grown by what the fastest ship could have done since; None once too old."""
        if self.memory is None:
            return None
        frame, d, rate, sigma = self.memory
        dt_s = (self.frame - frame) / self.s.fps
        if dt_s > MEMORY_S:
            return None
        return d + rate * dt_s, math.hypot(sigma, self._max_rate(d) * dt_s)

    def _fits_memory(self, z: float) -> bool:
        memory = self._memory_now()
        if memory is None:
            return True
        return abs(z - memory[0]) <= self.s.gate_sigma * math.hypot(memory[1], self.noise_px)

    def _max_rate(self, d: float) -> float:
        """|d'| of a ship at MAX_SHIP_SPEED_MPS straight at the rig: d^2 v / (f B), px/s."""
        fb = self.s.focal_px * self.s.baseline_m
        return d * d * MAX_SHIP_SPEED_MPS / fb if fb > 0 else math.inf

    def _plausible_rate(self, d: float, rate: float) -> float:
        limit = self._max_rate(max(d, 0.0))
        return min(max(rate, -limit), limit)

    def scatter_px(self) -> float | None:
        """Robust noise of the recent raw disparities: MAD of successive differences / sqrt(2)
        (differences remove the slow trend of an approaching ship). Computed once per new sample:
        the filter, the table's lifecycle and the fixes all ask for it in a pair."""
        if self._scatter is not None:
            return self._scatter[0]
        scatter = None
        if len(self.recent) >= MIN_SCATTER_SAMPLES:
            r = list(self.recent)
            diff = [b - a for a, b in zip(r, r[1:], strict=False)]
            centre = median(diff)
            scatter = 1.4826 * median([abs(x - centre) for x in diff]) / math.sqrt(2.0)
        self._scatter = (scatter,)
        return scatter

    @property
    def usable(self) -> bool:
        """Is the raw disparity known to be steady enough to range on?"""
        scatter = self.scatter_px()
        return scatter is not None and scatter <= MAX_USABLE_NOISE_PX

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
            self.kalman.design = self.designs.disparity(level, self.accel_pxps2)
        self._adapt_accel()

    def _adapt_accel(self) -> None:
        """The white acceleration of the design: what a ship at this disparity can do
        (edge.core.shipmotion)."""
        if self.disparity is None or self.kalman is None:
            return
        rung = accel_rung(self.disparity, self.s.focal_px * self.s.baseline_m, self.s.sigma_accel_pxps2)
        if rung != self.accel_pxps2:
            self.accel_pxps2 = rung
            self.kalman.design = self.designs.disparity(self.noise_px, rung)

    def _filter(self, z: float | None) -> None:
        self.raw_disparity = z
        if z is not None:
            self.recent.append(z)
            self._scatter = None
            self._adapt_noise()
        if self.kalman is not None:
            if z is not None and not self.kalman.running and not self._fits_memory(z):
                z = None  # a restart must pick up this ship, not whatever the point now sees
            est = self.kalman.update(z)
            if est.valid and est.accepted:
                rate = self._plausible_rate(est.disparity_px, est.rate_pxps)
                self.disparity, self.rate_pxps, self.sigma_px = est.disparity_px, rate, est.sigma_px
                self.updates += 1
                self.memory = (self.frame, est.disparity_px, rate, est.sigma_px)
            elif est.valid and (memory := self._memory_now()) is not None:
                # coasting: carry the last accepted estimate at its (physically bounded) rate; the
                # filter's own state may hold a rate a ramp of mixed windows talked it into
                self.disparity, self.sigma_px = memory[0], max(est.sigma_px, memory[1])
            elif est.valid:
                self.disparity, self.sigma_px = est.disparity_px, est.sigma_px
            else:
                self.disparity, self.sigma_px, self.updates = None, math.inf, 0
            self.accepted = bool(est.valid and est.accepted)
            self.collected = bool(not est.valid and est.accepted)
            if self.collected:
                self.collected_frame = self.frame
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
