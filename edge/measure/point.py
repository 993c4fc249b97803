"""One track's measurement chain: reference point, left follow, right match, disparity filter.

Everything here works in rectified left-image pixels (`edge.core.rectify`):
rows are epipolar lines and disparity d = u_left - u_right gives Z = f L_B / d.

- Reference point (`edge.measure.anchor.reference_points`): the best-textured window in
  the upper part of the ship's box — the superstructure, the thesis's bridge; the window spans a
  small far ship on a quiet background (`edge.measure.anchor.ship_window`, chosen at birth, or later when
  a ship shrinks into it: `TrackTable._resize_window`).
- Left follow: the core's sub-pixel point tracker (`edge.core.follow_point`,
  ZSSD 2-D search with cancellation-free parabola fits here for speed) finds a
  template kept for up to a second around the position the point's image motion
  predicts (re-taking it every pair would add each pair's error to the point).
  Where it finds no sure match (flat, ambiguous) the point is carried on its
  motion for a few pairs; a match too bad or off the motion means something
  passed in front, and the point is searched for (see `TrackPoint`). A newborn
  (no motion of its own yet) and a point whose predicted follow failed search
  where the detector's box moved (`_guided_follow`): at 1 fps a near ship
  crosses tens of pixels per pair.
- Right match: `edge.core.match_point` on two rectified patches of the same rows and
  columns (prefilter "xsobel": both clipped x-Sobel, edge.core.prefilter), the search narrowed
  to the disparity filter's prediction once it runs (a full search at birth and after a restart);
  sub-pixel by the six-pass Gaussian cancellation (the most accurate default in the pipeline:
  docs/decisions.md).
- Filter: `edge.measure.pointfilter.PointFilter` (the base of `TrackPoint`). The left point's column is
  smoothed by a least-squares line over the last second of follows: its slope is the image motion
  that predicts the next position and gives the bearing rate.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Generator
from dataclasses import replace

import numpy as np

from edge.core.linefit import line_fit, median
from edge.core.match import Match
from edge.core.rectify import Rectifier
from edge.core.refpoint import FollowResult
from edge.core.shipmotion import MAX_SHIP_ACCEL_MPS2, MAX_SHIP_SPEED_MPS
from edge.measure.aliascheck import AliasCheck, check_window
from edge.measure.batch import (
    Checks,
    Follow,
    MatchSettings,
    Request,
    Steps,
    StereoMatch,
    follow_settings,
    match_settings,
    run_one,
    stereo_request,
)
from edge.measure.depthcheck import OFFSETS, SUB_WINDOW, DepthCheck, depth_every
from edge.measure.filter_designs import Designs
from edge.measure.pointfilter import NOISE_WINDOW, PointFilter
from edge.measure.settings import PointSettings

COLUMN_FIT_S = 1.0  # the image motion is the slope of a line through this much of the point's track
REJECTS_TO_SEARCH = 5  # valid matches in a row that the filter's gate refuses: the point is on something else
OCCLUSION_COST_FACTOR = 4.0  # a follow this much worse than the track's typical one: something in front
OCCLUSION_COST_FLOOR = 20.0  # DN^2 per pixel, so a near-perfect typical match does not trip on noise
MIXED_COST_FACTOR = 3.0  # a right match this much worse than the track's typical one is mixed
MIXED_COST_FLOOR_DN2 = 10.0  # plus this residual variance (DN^2), so noise alone never trips it
TEMPLATE_REFRESH_S = 1.0  # the followed template is re-taken this often (or when it matches 2x worse)
FOLLOW_MARGIN_PX = 5  # the core point tracker's margin beyond window and search (half-pixel passes)
FOLLOW_MAX_SIGMA_PX = 1.0  # texture the follow needs in x and y (looser than for ranging)
FOLLOW_FAILURES_TO_SEARCH = 5  # pairs without a sure follow before the point is searched for
FOLLOW_GATE_PX = 1.5  # a follow this far from the predicted motion jumped to something else


class TrackPoint(PointFilter):
    """The measured point of one track: position in the rectified left image, disparity, filters.

    States: *following* (the template is followed from pair to pair and matched in the right
    image) and *searching* (the follow failed, matched too badly or off the track's motion — a
    ship passing in front — or the filter refused REJECTS_TO_SEARCH valid matches in a row: the
    point slid onto another object). While searching the point and the filters coast; the table
    offers other points on the ship, and one whose disparity fits the prediction resumes
    following. The filters are kept: the track cannot adopt another ship's range."""

    def __init__(self, u: float, v: float, settings: PointSettings, designs: Designs,
                 window: int | None = None) -> None:
        # a track's own window (edge.measure.anchor.ship_window) rides in its copy of the settings
        super().__init__(settings if window in (None, settings.window) else replace(settings, window=window),
                         designs)
        self.u, self.v = u, v
        self.follow_settings = follow_settings(self.s, FOLLOW_MAX_SIGMA_PX)  # the core requests' knobs, kept
        self.match_settings = match_settings(self.s)
        self._near_settings: dict[int, tuple[PointSettings, MatchSettings]] = {}  # _near_request's by window
        self.template: np.ndarray | None = None  # window around template_at in the last image
        self.template_at = (0, 0, 0.0, 0.0)  # its patch origin, and the point (u, v) then
        self.template_reach = 0.0  # px the point may move before the patch is too small
        self.template_age = 0  # pairs since it was taken
        self.last_left: np.ndarray | None = None
        self.last_left_frame = -1  # the pair last_left is from
        self.box_step_px: float | None = None  # this pair's column step from the detector (TrackTable)
        self.searching = False
        self.search_frames = 0
        self.follow_failures = 0  # pairs in a row the core tracker found no sure match
        self.jumped = (0.0, 0.0)  # (du, dv) of a move to another point of the ship in this pair
        self.followed = False  # the point tracker measured the point in this pair
        self.rejects = 0
        self.u_filtered: float | None = None
        self.u_rate_pxps = 0.0
        self.follow_costs: deque[float] = deque(maxlen=NOISE_WINDOW)  # SSD per pixel of good follows
        self.match_costs: deque[float] = deque(maxlen=NOISE_WINDOW)  # matcher costs of clean matches
        self.columns: deque[tuple[int, float]] = deque(maxlen=max(3, int(round(COLUMN_FIT_S * settings.fps))))
        self._last_request: StereoMatch | None = None
        self.alias = AliasCheck()  # small-window cross-check of the right match (settings.alias_check)
        self.depth = DepthCheck()  # sub-window cross-check (settings.depth_check)

    @property
    def alias_sigma_px(self) -> float:
        """The additive disparity sigma for aliasing bias (edge.measure.aliascheck); 0 when off."""
        return self.alias.sigma_px()

    @property
    def depth_sigma_px(self) -> float:
        """The additive disparity sigma for the depth the window spans (edge.measure.depthcheck); 0
        while the alias check finds aliasing, which biases the small sub-windows more (sharp optics)."""
        return 0.0 if self.alias.sigma_px() > 0.0 else self.depth.sigma_px()

    def reanchor(self, u: float, v: float) -> None:
        """Start over at a new point on the same ship: new template, the filters restart."""
        self.u, self.v = u, v
        self.template = None
        self.searching, self.search_frames, self.rejects = False, 0, 0
        self.follow_costs.clear()
        self.match_costs.clear()
        self.columns.clear()
        self.alias.clear()
        self.depth.clear()
        self._reset_filters()

    def set_window(self, window: int, rect: Rectifier) -> None:
        """Match with another window side from now on (edge.measure.anchor.ship_window for the ship's size
        now), at the same point: its template is re-taken from the last image, the filters go on."""
        self.s = replace(self.s, window=window)
        self.follow_settings = follow_settings(self.s, FOLLOW_MAX_SIGMA_PX)
        self.match_settings = match_settings(self.s)
        self._near_settings = {}
        self.match_costs.clear()  # costs scale with the window's area
        self.alias.clear()  # and the check's window changes with it
        self.depth.clear()
        if self.last_left is not None:
            self._take_template(self.last_left, rect)
        else:
            self.template = None

    @property
    def moved(self) -> bool:
        """u_rate_pxps has been measured: a column line through >= 3 follows has been fitted."""
        return self.u_filtered is not None

    # ------------------------------------------------------------ per pair
    def step(self, left: np.ndarray, right: np.ndarray, rect: Rectifier, skipped: int = 0,
             candidates: Callable[[], list[tuple[float, float]]] | None = None) -> bool:
        """Follow the point into this pair and measure its disparity; False once the point is lost
        for good (off the image, or searched for longer than reacquire_s).

        `skipped` pairs were missing since the last call (the filters coast through them).
        `candidates()` lists other points on the ship to try while searching. Runs `steps` with the
        per-point core functions; `edge.measure.batch.step_points` runs many points' `steps` batched."""
        return run_one(self.steps(left, right, rect, skipped, candidates))

    def steps(self, left: np.ndarray, right: np.ndarray, rect: Rectifier, skipped: int = 0,
              candidates: Callable[[], list[tuple[float, float]]] | None = None) -> Steps:
        """`step` as a generator that yields its core requests (edge.measure.batch) and is sent the
        answers."""
        for _ in range(skipped):
            self._coast()
        self.frame += 1
        self.match = None
        self.jumped = (0.0, 0.0)
        self.followed = False
        hint, self.box_step_px = self.box_step_px, None
        if not self.searching and self.template is not None and len(self.columns) >= 3 and \
                self.frame - self.columns[-1][0] < self.s.follow_every:
            self.u += self.u_rate_pxps / self.s.fps  # between follows the image motion carries it
        elif not self.searching and self.template is not None:
            own = self.u_rate_pxps / self.s.fps  # the step the point's own motion predicts
            guided = self._guided_follow(left, rect, hint) if hint is not None and not self.moved else None
            if guided is None:
                pu = self.u + own
                if abs(pu - self.template_at[2]) > self.template_reach:
                    assert self.last_left is not None  # a template is taken only after a measured pair
                    self._take_template(self.last_left, rect)  # moved too far for the kept patch
                found, origin = (yield self._follow(left, rect, pu)), self.template_at[:2]
                assert isinstance(found, FollowResult)  # the answer to a Follow
                if not found.valid and hint is not None and abs(hint - own) > FOLLOW_GATE_PX:
                    guided = self._guided_follow(left, rect, hint)  # the motion changed: where the box went
            if guided is not None:
                assert hint is not None  # a guided follow searches around the box's step
                pu = self.u + hint
                found, origin = (yield guided[0]), guided[1]
            assert isinstance(found, FollowResult)  # the answer to a Follow
            if not found.valid:  # no sure match (flat, ambiguous): carry the point on its motion
                self.follow_failures += 1
                self.u = pu
                if self.follow_failures > FOLLOW_FAILURES_TO_SEARCH:
                    self.searching = True
            elif self._off_track(found, pu, origin, guided is not None, hint):
                self.searching = True
            else:
                self.follow_failures = 0
                self.followed = True
                self.follow_costs.append(found.cost / self.s.window**4)  # ZSSD -> DN^2 per pixel
                self.u, self.v = found.x_px + origin[0], found.y_px + origin[1]
        if self.searching:
            for u, v in candidates() if candidates is not None else []:
                if (yield from self._try(u, v, left, right, rect)):
                    return True
            self._coast()
            self.search_frames += 1
            return self._in_image(rect) and self.search_frames <= self.s.reacquire_s * self.s.fps
        if not self._in_image(rect):
            self._coast()
            return False
        yield from self._measure(left, right, rect)
        return True

    def _try(self, u: float, v: float, left: np.ndarray, right: np.ndarray, rect: Rectifier) -> Steps:
        """Resume following at (u, v) if its disparity fits the filter's prediction (at once when
        there is no prediction)."""
        prediction = self.prediction()
        if (prediction is None and self.s.filter != "none") or not self._in_image(rect, round(u), round(v)):
            return False  # without a prediction any point would do: better lose the track than jump
        pred = None if prediction is None else prediction[0]
        m = yield stereo_request(self.s, left, right, rect, u, v, pred, self.match_settings)
        assert isinstance(m, Match)  # the answer to a StereoMatch
        if prediction is not None:
            tolerance = self.s.gate_sigma * math.hypot(prediction[1], self.noise_px)
            if not (m.valid and abs(m.disparity_px - prediction[0]) <= tolerance):
                return False
        self.jumped = (u - self.u, v - self.v)
        self.u, self.v = u, v
        self.searching, self.search_frames, self.rejects, self.follow_failures = False, 0, 0, 0
        self.follow_costs.clear()
        self.columns.clear()  # another point of the ship: keep the rate, restart the line fit
        self._take_template(left, rect)
        self.match = m
        self._filter(m.disparity_px if m.valid else None)
        self._fit_column()
        return True

    # ------------------------------------------------------------ internals
    def _in_image(self, rect: Rectifier, ui: int | None = None, vi: int | None = None) -> bool:
        h = self.s.window // 2
        ui = int(round(self.u)) if ui is None else ui
        vi = int(round(self.v)) if vi is None else vi
        return h + 2 <= ui < rect.rig.width - h - 2 and h + 1 <= vi < rect.rig.height - h - 1

    def _coast(self) -> None:
        """A pair without a measurement: the point moves with the image motion, filters coast."""
        self.u += self.u_rate_pxps / self.s.fps
        self._filter(None)

    def _follow(self, left: np.ndarray, rect: Rectifier, pu: float) -> Follow:
        """Find the kept template's point in this pair with the core's sub-pixel point tracker
        (`edge.core.follow_point`), searched around the predicted column `pu`."""
        x0, y0, tx, ty = self.template_at
        assert self.template is not None  # only followed with a template
        h_patch, w_patch = self.template.shape
        current = rect.patch(left, 0, x0, y0, w_patch, h_patch)
        return Follow(self.template, current, tx - x0, ty - y0, pu - tx, self.follow_settings)

    def _guided_follow(self, left: np.ndarray, rect: Rectifier,
                       step_px: float) -> tuple[Follow, tuple[int, int]] | None:
        """A follow of the point's window in the previous pair, searched around where the detector's
        box says it went (`step_px` columns, `TrackTable` measures it), and the patches' origin; None
        without the previous pair's image.

        Why: the point's own motion needs three follows, and at 1 fps (photo mode) a ship at 500 m
        crosses 30 px per pair, far beyond the search radius around a newborn's zero motion; a
        turning ship's image motion changes by more than the radius from one pair to the next. The
        box's motion is a prediction the same radius can search around (tools/evaluate
        approach-2048, 0-1 km)."""
        if self.last_left is None or self.last_left_frame != self.frame - 1:
            return None
        h, r = self.s.window // 2, self.s.follow_radius_px
        ui, vi = int(round(self.u)), int(round(self.v))
        mx, my = h + r + FOLLOW_MARGIN_PX + abs(int(round(step_px))), h + r + FOLLOW_MARGIN_PX
        prev = rect.patch(self.last_left, 0, ui - mx, vi - my, 2 * mx + 1, 2 * my + 1)
        cur = rect.patch(left, 0, ui - mx, vi - my, 2 * mx + 1, 2 * my + 1)
        return Follow(prev, cur, self.u - (ui - mx), self.v - (vi - my), step_px, self.follow_settings), \
            (ui - mx, vi - my)

    def _off_track(self, found: FollowResult, pu: float, origin: tuple[int, int], guided: bool,
                   box_step_px: float | None) -> bool:
        """The template matched too badly (something in front of it), or too far from where the
        track's own motion puts it and from where the detector's box does (the match jumped to
        another object; a turning ship at 1 fps leaves its own motion by pixels in a pair, and the
        box follows it). Not asked of a guided follow, whose prediction is the box's."""
        cost = found.cost / self.s.window**4
        if len(self.follow_costs) >= 5:
            typical = median(self.follow_costs)
            if cost > OCCLUSION_COST_FACTOR * typical + OCCLUSION_COST_FLOOR:
                return True
        x, y = found.x_px + origin[0], found.y_px + origin[1]
        jump = math.hypot(x - pu, y - self.v)
        if box_step_px is not None and abs(box_step_px - (pu - self.u)) > FOLLOW_GATE_PX:
            # the box says the motion changed (self.u is still the previous pair's position)
            jump = min(jump, math.hypot(x - self.u - box_step_px, y - self.v))
        return not guided and len(self.columns) >= 3 and jump > FOLLOW_GATE_PX + self._motion_lag_px()

    def _motion_lag_px(self) -> float:
        """How far a ship accelerating at MAX_SHIP_ACCEL_MPS2 across the view leaves the step the
        column line predicts: the line's slope is the mean image motion of its n follows, n/2 pairs
        before the coming step's, so the step is off by a_img n T^2 / 2 with a_img = d a / L_B (the
        image acceleration, as |u'| <= d v / L_B). A few hundredths of a pixel at 10 fps; at 1 fps a
        turning ship at 500 m is pixels off, which is no jump to another object."""
        d = self.disparity if self.disparity is not None else self.raw_disparity
        if d is None or not d > 0 or self.s.baseline_m <= 0:
            return 0.0
        return 0.5 * len(self.columns) * d * MAX_SHIP_ACCEL_MPS2 / self.s.baseline_m / self.s.fps**2

    def _take_template(self, left: np.ndarray, rect: Rectifier) -> None:
        """Keep the rectified patch around the point: the core tracker searches it again in later
        pairs, so it spans the window, the search square, the tracker's margins and the motion
        expected while the template is kept."""
        h, r = self.s.window // 2, self.s.follow_radius_px
        ui, vi = int(round(self.u)), int(round(self.v))
        motion = int(math.ceil(abs(self.u_rate_pxps) * TEMPLATE_REFRESH_S)) + 2
        mx, my = h + r + FOLLOW_MARGIN_PX + motion, h + r + FOLLOW_MARGIN_PX + 2
        self.template = rect.patch(left, 0, ui - mx, vi - my, 2 * mx + 1, 2 * my + 1).copy()
        self.template_at = (ui - mx, vi - my, self.u, self.v)  # patch origin, and the point then
        self.template_reach = float(motion)
        self.template_age = 0
        self.follow_costs.clear()

    def _measure(self, left: np.ndarray, right: np.ndarray, rect: Rectifier
                 ) -> Generator[Request, FollowResult | Match | list[Match], None]:
        self.last_left, self.last_left_frame = left, self.frame
        # keep following the same template for a while: re-taking it every pair would add each
        # pair's sub-pixel follow error to the point (a random walk, and a drift where the window
        # straddles the ship's outline); its appearance changes slowly, so refresh it now and then
        self.template_age += 1
        costs = self.follow_costs
        worse = len(costs) >= 2 and costs[-1] > 2.0 * min(costs)
        if self.template is None or self.template_age >= TEMPLATE_REFRESH_S * self.s.fps or worse:
            self._take_template(left, rect)
        self._last_request = stereo_request(self.s, left, right, rect, self.u, self.v,
                                            self.predicted_disparity(), self.match_settings)
        m = yield self._last_request
        assert isinstance(m, Match)  # the answer to a StereoMatch
        self.match = m
        # the cross-checks of a valid match, asked together (each depends on the main match alone)
        alias = self.s.alias_check and m.valid
        depth = self.s.depth_check and m.valid and self.frame % depth_every(self.s.fps) == 0
        if alias or depth:
            near = [self._near_request(m, left, right, rect, check_window(self.s.window))] if alias else []
            if depth:
                near += [self._near_request(m, left, right, rect, SUB_WINDOW, du, dv) for du, dv in OFFSETS]
            checks = yield Checks(tuple(near))
            assert isinstance(checks, list)  # the answer to Checks
            if alias:
                self.alias.add(m, checks[0])
            if depth:
                for k, sub in enumerate(checks[1:] if alias else checks):
                    self.depth.add(k, m, sub)
        clean = m.valid and not self._mixed(m.cost)
        self._filter(m.disparity_px if clean else None)
        if not self.accepted and self.kalman is not None and self.kalman.running:
            # a valid match refused (or mixed): the point is on something else; no match at all for
            # twice as long: it no longer gives this ship's range either
            self.rejects += 2 if m.valid else 1
            if self.rejects >= 2 * REJECTS_TO_SEARCH:
                self.searching = True
        else:
            self.rejects = 0
            if clean:
                self.match_costs.append(m.cost)
        if self.followed or self.template_age == 0:
            self._fit_column()  # only positions the tracker measured enter the motion fit

    def _near_request(self, m: Match, left: np.ndarray, right: np.ndarray, rect: Rectifier, window: int,
                      du: int = 0, dv: int = 0) -> StereoMatch:
        """A cross-check of the main match: the point moved by (du, dv) px, matched with another
        window, searched +-2 px around the main match (the alias check's smaller window,
        edge.measure.aliascheck; the depth check's sub-windows, edge.measure.depthcheck)."""
        near = self._near_settings.get(window)
        if near is None:  # the track's settings with that window, made once (dataclass replace is slow)
            near = (replace(self.s, window=window),
                    replace(self.match_settings, window=window, search_radius=2))
            self._near_settings[window] = near
        return stereo_request(near[0], left, right, rect, self.u + du, self.v + dv, m.disparity_px, near[1],
                              self._last_request)

    def _mixed(self, cost: float) -> bool:
        """A match much worse than this track's typical one: the window holds two objects at
        different ranges (a ship passing in front), which pulls the disparity between theirs."""
        if len(self.match_costs) < 5:
            return False
        n2 = float(self.s.window**2) ** 2  # ZSSD costs are N sum D^2 - (sum D)^2: N^2 x the variance
        typical = median(self.match_costs)
        return cost > MIXED_COST_FACTOR * typical + MIXED_COST_FLOOR_DN2 * n2

    def _fit_column(self) -> None:
        """Least-squares line through the recent (frame, column) follows: smoothed u and its rate (the
        image motion that predicts the next follow)."""
        self.columns.append((self.frame, self.u))
        n = len(self.columns)
        if n < 3:
            return
        intercept, slope = line_fit(self.columns)
        rate = slope * self.s.fps
        if self.disparity is not None and self.disparity > 0 and self.s.baseline_m > 0:
            limit = self.disparity * MAX_SHIP_SPEED_MPS / self.s.baseline_m  # |u'| <= f v / Z = d v / L_B
            rate = min(max(rate, -limit), limit)
        self.u_filtered, self.u_rate_pxps = float(intercept), rate
