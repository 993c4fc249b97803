"""TrackTable: ship tracks from detections and per-pair measurements, with the Q/T/L lifecycle.

Every pair, each live track follows its reference point and measures its
disparity (`edge.measure.point`). On detection pairs (every k-th), detections
are associated to tracks by the Hungarian method
(`scipy.optimize.linear_sum_assignment`) on 1 - overlap of the detection's
box and the track's box carried along with its point (`edge.measure.boxes.overlaps`: the IoU of
their column spans, for boxes in the same rows), gated at a minimum overlap
(or the point inside the box). Then:

- an associated detection *confirms* its track; when the ship's measured
  disparity disagrees with the sea range of the box's bottom row (the
  waterline, `geo.sea_range_m`) it does not: a glint matched to the wrong
  place, a reflection, or an object that is not on the sea;
- an unassociated detection that overlaps no track is born as a new track
  (ACQUIRING, Q) with a fresh id — ids are never reused — if there is room
  and its first match (when valid) passes the same waterline check;
- Q becomes TRACKING (T) after `confirm_n` of the last `confirm_m`
  detection passes confirmed it and its filter has taken `min_updates`
  measurements (as many as the Kalman's start takes: the sigma of a filter
  one or two updates old rests on a noise level chosen from a handful of
  samples, and a far ship's first samples can agree by chance); a Q track
  that can no longer reach that is dropped (glints and wave crests do not
  persist);
- T becomes LOST (L) when no measurement was accepted for `coast_s`, or no
  detection confirmed it for `unconfirmed_s`; L turns back to T when both
  resume, and is dropped `drop_s` after it turned L (later while its restarting filter takes
  its start samples, `_drop_after_s`).

On detection pairs each track's point is also told how far its box moved (`_box_steps`): at 1 fps
a newborn has no image motion of its own yet while a near ship crosses tens of pixels per pair.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from edge.core.calibsigma import Pointing
from edge.core.geo import height_above_sea_m
from edge.core.linefit import median
from edge.core.match import Match
from edge.core.rectify import Rectifier
from edge.core.triangulation import triangulate_normalised
from edge.fix import TrackStatus
from edge.measure.anchor import ship_points, ship_window, spanning_width
from edge.measure.batch import answer_all, step_points, stereo_request
from edge.measure.boxes import contains, inside, overlaps, waterline_masked
from edge.measure.candidates import CandidatePool
from edge.measure.detect import sea_range_at
from edge.measure.filter_designs import Designs
from edge.measure.oneship import Held, duplicates
from edge.measure.point import TrackPoint
from edge.measure.settings import PointSettings

MIN_OVERLAP = 0.2  # association gate (`boxes.overlaps`), or the track's point inside the detection's box
BIRTH_SLOPE_SHARE = 0.6  # a candidate whose disparity grows this fast down its rows is sea: no birth
VERTICAL_SHARE = 0.25  # a ship's disparity changes by less than this share of the sea's per row
SLOPE_ROWS = 4  # rows above and below the point for that test
ROW_SIGMA_PX = 0.5  # row uncertainty (height above the sea) when the calibration gives no standard errors
SEARCH_CANDIDATES = 6  # points offered to a track that lost its point on the ship
WINDOW_VOTES = 3  # detection passes in a row that must call for another window before it changes
CONFIDENCE_S = 10.0  # a track's confidence is its measured share of the pairs of this long


@dataclass(frozen=True)
class TableSettings:
    confirm_n: int = 3
    confirm_m: int = 5
    coast_s: float = 3.0
    unconfirmed_s: float = 10.0
    drop_s: float = 5.0
    max_tracks: int = 32
    waterline_tol_px: float = 4.0  # rows of slack in the waterline check (detection box bottom)
    max_ship_length_m: float = 400.0  # the point may be this much farther than the waterline's nearest
    min_height_m: float = 1.0  # a track's point must stand this far above the sea to become T
    min_updates: int = 5  # ... and its filter have taken this many measurements since it (re)started
    candidate_hits: int = 3  # a weak detection is born once seen in this many of the last ...
    candidate_passes: int = 5  # ... detection passes (edge.measure.candidates)


class Track:
    """One ship: id, lifecycle and box; the measurement chain lives in `point`."""

    def __init__(self, track_id: int, t_ns: int, point: TrackPoint, box: np.ndarray, confirm_m: int,
                 confidence_pairs: int = 1) -> None:
        self.id = track_id
        self.born_ns = t_ns
        self.status = TrackStatus.ACQUIRING
        self.point = point
        self.box_rel = box - np.array([point.u, point.v, point.u, point.v])  # box relative to the point
        self.confirmations: deque[bool] = deque([True], maxlen=confirm_m)
        self.slopes: list[float] = []  # disparity change per row across the point (acquiring only)
        self.last_measured_ns = t_ns
        self.last_confirmed_ns = t_ns
        self.lost_since_ns: int | None = None
        self.window_votes = 0  # detection passes in a row whose box calls for another window
        self.alive = True
        self.det_box = np.asarray(box, float)  # the last detection box associated to the track ...
        self.det_frame = point.frame  # ... and the point's pair it is from
        self.measured: deque[bool] = deque([True], maxlen=confidence_pairs)  # per pair: measured, not coasted

    @property
    def box(self) -> np.ndarray:
        return self.box_rel + np.array([self.point.u, self.point.v, self.point.u, self.point.v])

    def age_s(self, t_ns: int) -> float:
        return (t_ns - self.born_ns) / 1e9

    @property
    def confidence(self) -> float:
        """The share of the last CONFIDENCE_S of pairs (fewer since birth) in which the track was
        measured rather than coasted: skipped pairs and refused or failed matches count as coasted."""
        return sum(self.measured) / len(self.measured)


class TrackTable:
    """All live tracks of one rig; `step` once per pair, with the detections on detection pairs."""

    def __init__(self, rect: Rectifier, site_height_m: float, point_settings: PointSettings,
                 settings: TableSettings) -> None:
        self.rect = rect
        self.site_height_m = site_height_m
        self.ps = point_settings
        self.s = settings
        self.designs = Designs(point_settings)
        self.pointing: Pointing | None = None  # the calibration's standard errors (Pipeline sets it)
        self.search_mask: np.ndarray | None = None  # raw left image, True: may detect (site masks; Pipeline)
        self.candidates = CandidatePool(settings.candidate_hits, settings.candidate_passes, MIN_OVERLAP)
        self.tracks: list[Track] = []
        self.next_id = 1
        self.births = 0
        self.drops = 0

    # ------------------------------------------------------------ per pair
    def step(self, left: np.ndarray, right: np.ndarray, t_ns: int, skipped: int = 0,
             boxes: list[np.ndarray] | None = None, weak: list[bool] | None = None) -> list[Track]:
        """Advance every track into this pair; associate and give birth when `boxes` (rectified
        [x0, y0, x1, y1] of this pair's detections) are given (`weak` ones: the candidate pool first).
        Returns the live tracks."""
        if boxes:
            self._box_steps(boxes, skipped)
        # every track's follow and match of this pair batched (edge.measure.batch; = point.step per track)
        # the lambda's default binds each track (mypy cannot infer a lambda with a default)
        steps = [t.point.steps(left, right, self.rect, skipped,
                               lambda t=t: self._candidates(left, t.box, window=t.point.s.window))  # type: ignore[misc]
                 for t in self.tracks]
        for track, alive in zip(self.tracks, step_points(steps), strict=True):
            du, dv = track.point.jumped
            if du or dv:  # the point moved to another part of the ship: the ship's box did not
                track.box_rel -= np.array([du, dv, du, dv])
            track.measured.extend([False] * skipped)
            if track.point.accepted or (track.status is TrackStatus.ACQUIRING and track.point.collected):
                # a newborn's filter takes init_samples pairs to start (4 s at 1 fps): its samples count
                track.last_measured_ns = t_ns
                track.measured.append(True)
            else:
                track.measured.append(False)
            if not alive:  # the point is gone for good: a tentative track ends, a confirmed one is lost
                if track.status is TrackStatus.ACQUIRING:
                    self._drop(track)
                elif track.status is TrackStatus.TRACKING:
                    track.status, track.lost_since_ns = TrackStatus.LOST, t_ns
        if boxes is not None:
            self._associate(left, right, t_ns, boxes, weak or [False] * len(boxes))
            self._drop_duplicates()  # one track per ship (edge.measure.oneship)
        for track in self.tracks:
            if track.alive:
                self._lifecycle(track, t_ns)
        self.tracks = [t for t in self.tracks if t.alive]
        return self.tracks

    def _box_steps(self, boxes: list[np.ndarray], skipped: int) -> None:
        """Tell each track's point how far the detector's box moved it since the box last associated
        to it (columns per pair, `TrackPoint.box_step_px`): the displacement of the box's two ends,
        interpolated at the point's place along the box (a turning ship's ends move apart), over the
        pairs between the two boxes. The box is the one overlapping the track's box most (the
        association's gate); its follow searches there when the point's own motion is not known yet
        or failed."""
        if not self.tracks:
            return
        shares = overlaps(np.array([t.box for t in self.tracks]), np.array(boxes, float))
        for track, row in zip(self.tracks, shares, strict=True):
            p = track.point
            pairs = p.frame + skipped + 1 - track.det_frame
            j = int(np.argmax(row))
            if pairs <= 0 or row[j] < MIN_OVERLAP:
                continue
            old, new = track.det_box, boxes[j]
            share = min(max((p.u - old[0]) / max(old[2] - old[0], 1.0), 0.0), 1.0)
            p.box_step_px = float((new[0] - old[0]) * (1.0 - share) + (new[2] - old[2]) * share) / pairs

    def _associate(self, left: np.ndarray, right: np.ndarray, t_ns: int, boxes: list[np.ndarray],
                   weak: list[bool]) -> None:
        tracks = self.tracks
        confirmed = [False] * len(tracks)
        taken = [False] * len(boxes)
        if tracks and boxes:
            det = np.array(boxes, float)
            overlap = overlaps(np.array([t.box for t in tracks]), det)
            held = inside(det, [t.point.u for t in tracks], [t.point.v for t in tracks])
            cost = np.where((overlap >= MIN_OVERLAP) | held, 1.0 - overlap, 1.0)
            rows, cols = linear_sum_assignment(cost)
            pairs = [(i, j) for i, j in zip(rows.tolist(), cols.tolist(), strict=True)
                     if cost[i, j] < 1.0 or held[i, j]]
            # each pair's confirmation in two halves around its slope test, whose matches (two per
            # tentative track) are answered together: the tracks share no state, so the same results
            wants = [self._confirm_start(tracks[i], boxes[j], left) for i, j in pairs]
            slopes = iter(self._slopes([tracks[i].point for (i, _), w in zip(pairs, wants, strict=True) if w],
                                       left, right))
            for (i, j), want in zip(pairs, wants, strict=True):
                taken[j] = True
                confirmed[i] = self._confirm_end(tracks[i], boxes[j], next(slopes) if want else None, t_ns)
        for i, track in enumerate(tracks):
            # ships in line merge into one blob: it confirms every track whose point it covers
            if not confirmed[i] and any(contains(db, track.point.u, track.point.v) for db in boxes):
                confirmed[i] = True
                track.last_confirmed_ns = t_ns
            track.confirmations.append(confirmed[i])
        waiting = []  # weak boxes for the candidate pool
        for j, db in enumerate(boxes):
            if taken[j] or tracks and (
                    bool((overlaps(np.array([t.box for t in tracks]), db[None]) > 0).any())
                    or any(contains(db, t.point.u, t.point.v) for t in tracks)):
                continue
            if weak[j]:
                waiting.append(db)
            elif len(self.tracks) < self.s.max_tracks:
                self._birth(left, right, t_ns, db)
        for db in self.candidates.step(waiting):  # weak ones that persisted (every pass ages the pool)
            if len(self.tracks) < self.s.max_tracks:
                self._birth(left, right, t_ns, db)

    def _drop_duplicates(self) -> None:
        settled = [t for t in self.tracks if t.point.disparity is not None and t.point.disparity > 0.0
                   and t.point.updates >= self.s.min_updates and t.point.sigma_px <= self.ps.max_sigma_px]
        held = [Held(t.box, t.point.u, t.point.v, float(t.point.disparity or 0.0), t.point.sigma_px,
                     t.point.s.window, (sum(t.confirmations), -t.born_ns, -t.id)) for t in settled]
        for i in sorted(duplicates(held, self.rect.f_px, self.rect.f_px * self.rect.rig.baseline_m)):
            self._drop(settled[i])

    def _confirm_start(self, track: Track, box: np.ndarray, left: np.ndarray) -> bool:
        """The first half of a track's confirmation by its box (`_associate` runs the halves for all
        its tracks, their slope tests answered together between them); whether it wants the slope
        test."""
        p = track.point
        if p.prediction() is None and (p.searching or not contains(box, p.u, p.v)):
            # a point without a range history that is off the ship, or lost what it followed (a
            # glint gone): start over on the ship, as a searching point with a prediction cannot
            # (one with a history stays: it gets candidates from this box next pair)
            p.reanchor(*self._reference(left, box, p.s.window))
        track.box_rel = box - np.array([p.u, p.v, p.u, p.v])
        self._resize_window(track, box, left)
        track.det_box, track.det_frame = np.asarray(box, float), p.frame
        return track.status is TrackStatus.ACQUIRING and not p.searching

    def _confirm_end(self, track: Track, box: np.ndarray, slope: float | None, t_ns: int) -> bool:
        """The second half, with the slope test's result (None: not run or no slope): confirmed?"""
        p = track.point
        if slope is not None:
            track.slopes.append(slope)
        d = p.disparity if p.disparity is not None else p.raw_disparity
        if d is not None and not self._on_the_sea(d, box):
            return False
        track.last_confirmed_ns = t_ns
        return True

    def _resize_window(self, track: Track, box: np.ndarray, left: np.ndarray) -> None:
        """A track on the configured window takes the window spanning its ship (`_ship_window`)
        once the ship has shrunk into it (receding, or born near): once WINDOW_VOTES detection
        passes in a row call for it, so a box edge that jitters by a pixel or two does not switch
        it back and forth. A spanning window is kept as the ship grows (as one chosen at birth
        always was): switching back to the configured one lost far more than it gained
        (docs/decisions.md)."""
        p = track.point
        if p.searching or p.s.window != self.ps.window:
            return
        wants = spanning_width(box[2] - box[0], p.s.window) != p.s.window  # the box alone: cheap
        track.window_votes = track.window_votes + 1 if wants else 0
        if track.window_votes >= WINDOW_VOTES:
            track.window_votes = 0
            window = self._ship_window(left, box)  # and the quiet background it needs
            if window != p.s.window:
                p.set_window(window, self.rect)

    def _ship_window(self, left: np.ndarray, box: np.ndarray) -> int:
        """edge.measure.anchor.ship_window for a ship in `box` (rectified) in this left image."""
        m = self.ps.window
        if spanning_width(box[2] - box[0], m) == m:
            return m  # no spanning window for a ship this wide: no patch needed
        bx0, by0 = int(math.floor(box[0])) - m, int(math.floor(box[1])) - m
        bx1, by1 = int(math.ceil(box[2])) + m, int(math.ceil(box[3])) + m
        patch = self.rect.patch(left, 0, bx0, by0, bx1 - bx0, by1 - by0)
        return ship_window(patch, (bx0, by0), tuple(box), m)

    def _birth(self, left: np.ndarray, right: np.ndarray, t_ns: int, box: np.ndarray) -> None:
        if self.search_mask is not None and waterline_masked(self.search_mask, self.rect, box):
            return  # no track is born in a site mask
        window = self._ship_window(left, box)
        u, v = self._reference(left, box, window)
        point = TrackPoint(u, v, self.ps, self.designs, window)
        if not point.step(left, right, self.rect):
            return
        m = point.match
        if m is not None and m.valid and not self._on_the_sea(m.disparity_px, box):
            return
        slope = self._slope(point, left, right) if m is not None and m.valid else None
        if slope is not None and slope > BIRTH_SLOPE_SHARE * self._sea_slope():
            return  # plainly a patch of sea (see `promotion_gate`): not worth a track
        self.tracks.append(Track(self.next_id, t_ns, point, np.asarray(box, float), self.s.confirm_m,
                                 max(1, round(CONFIDENCE_S * self.ps.fps))))
        self.next_id += 1
        self.births += 1

    def _reference(self, left: np.ndarray, box: np.ndarray, window: int | None = None) -> tuple[float, float]:
        return self._candidates(left, box, 1, window)[0]

    def _candidates(self, left: np.ndarray, box: np.ndarray, count: int = SEARCH_CANDIDATES,
                    window: int | None = None) -> list:
        """`edge.measure.anchor.ship_points` for `window` (default the configured one)."""
        return ship_points(self.rect, left, box, window or self.ps.window, count)

    def _on_the_sea(self, disparity_px: float, box: np.ndarray) -> bool:
        """Is the measured disparity possible for a ship whose waterline is the box's bottom row?

        No nearer than the sea at the bottom row (plus slack), and no farther than that sea
        range plus a ship length (the measured point may be on the far end of a bow-on ship)."""
        fb = self.rect.f_px * self.rect.rig.baseline_m
        u = 0.5 * (box[0] + box[2])
        tol = self.s.waterline_tol_px
        near = self._sea_range(u, box[3] + tol)
        far = self._sea_range(u, box[3] - tol) + self.s.max_ship_length_m
        d_max = fb / near if math.isfinite(near) else 0.0
        d_min = fb / far if math.isfinite(far) else 0.0
        slack = 3.0 * max(self.ps.max_sigma_px, 0.1)
        return d_min - slack <= disparity_px <= 1.1 * d_max + slack

    def promotion_gate(self, track: Track) -> str | None:
        """The first Q -> T check the track fails now (None: it passes them all, it becomes T):
        "updates" (its filter has fewer than min_updates measurements), "confirmations" (fewer
        than confirm_n detection passes confirmed it), "usable" (its raw disparities scatter too
        much), "vertical" and "height", the two tests that a ship stands up out of the sea while
        wave crests and troughs that persist and match in stereo lie on it: (1) the sea's disparity
        grows by L_B / h per row below the horizon (h the camera height: the same on every row, for
        any focal length), a ship's side is vertical and keeps one disparity, so the disparity
        measured above and below the point must change by much less than L_B / h per row; (2) the
        triangulated point must stand clear of the sea below it (`height_m`)."""
        s, p = self.s, track.point
        if p.updates < s.min_updates:
            return "updates"
        if sum(track.confirmations) < s.confirm_n:
            return "confirmations"
        if not p.usable:
            return "usable"
        if not track.slopes or abs(median(track.slopes)) > VERTICAL_SHARE * self._sea_slope():
            return "vertical"
        height, sigma = self.height_m(p)
        return "height" if height < max(s.min_height_m, 3.0 * sigma) else None

    def _sea_slope(self) -> float:
        """Disparity growth per row of the sea below the horizon: L_B / h (flat-sea approximation)."""
        return self.rect.rig.baseline_m / max(self.site_height_m, 1.0)

    def _slopes(self, points: list[TrackPoint], left: np.ndarray, right: np.ndarray) -> list[float | None]:
        """Disparity change per row across each point: its matches SLOPE_ROWS above and below it, all
        points' answered together (edge.measure.batch.answer_all; None: a match failed)."""
        requests = [stereo_request(p.s, left, right, self.rect, p.u, p.v + dv, p.predicted_disparity(),
                                   p.match_settings) for p in points for dv in (-SLOPE_ROWS, SLOPE_ROWS)]
        answers = answer_all(requests)
        out: list[float | None] = []
        for above, below in zip(answers[0::2], answers[1::2], strict=True):
            assert isinstance(above, Match) and isinstance(below, Match)  # answers to StereoMatches
            ok = above.valid and below.valid
            out.append((below.disparity_px - above.disparity_px) / (2 * SLOPE_ROWS) if ok else None)
        return out

    def _slope(self, p: TrackPoint, left: np.ndarray, right: np.ndarray) -> float | None:
        """`_slopes` of one point."""
        return self._slopes([p], left, right)[0]

    def height_m(self, p: TrackPoint) -> tuple[float, float]:
        """The point's height above the sea and its 1-sigma, m. The height comes from the
        triangulated point (eq. 4.1) against the curved sea below it; its 1-sigma is the range
        error's share (the filter's disparity sigma and the calibration's, `calibration_sigmas_px`)
        plus the row's."""
        f, b = self.rect.f_px, self.rect.rig.baseline_m
        assert p.disparity is not None  # asked only of a point with a filtered disparity
        xy_left = self.rect.rect_to_normalised(np.array([p.u, p.v]))
        point = triangulate_normalised(xy_left, xy_left - np.array([p.disparity / f, 0.0]), b)  # eq. 4.1
        height = float(height_above_sea_m(point, self.site_height_m))
        y, z = float(xy_left[1]), float(point[2])
        row_px, _, disp_px = self.calibration_sigmas_px(float(xy_left[0]), y, p.disparity)
        sigma_z = z * z * math.hypot(p.sigma_px, disp_px) / (f * b)
        return height, math.hypot(abs(y) * sigma_z, z * row_px / f)

    def calibration_sigmas_px(self, x: float, y: float, disparity_px: float) -> tuple[float, float, float]:
        """(row, column, disparity) 1-sigma in px that the calibration leaves at normalised (x, y)
        (edge.core.calibsigma, eq. C.1/C.2). Ruling 7 of issue 16: the row's comes from the
        calibration's standard errors and the site's tilt bound; a calibration without standard
        errors keeps ROW_SIGMA_PX (it stands for unknown pitch and mast tilt), with the tilt bound
        added if one is given."""
        pt = self.pointing
        if pt is None:
            return ROW_SIGMA_PX, 0.0, 0.0
        row, col, disp = (float(a) for a in pt.sigmas(np.array(x), np.array(y), np.array(disparity_px)))
        return (row if pt.known else math.hypot(ROW_SIGMA_PX, row)), col, disp

    def _sea_range(self, u: float, v: float) -> float:
        return sea_range_at(self.rect, self.site_height_m, u, v)

    # ------------------------------------------------------------ lifecycle
    def _lifecycle(self, track: Track, t_ns: int) -> None:
        s = self.s
        if track.status is TrackStatus.ACQUIRING:
            hits = sum(track.confirmations)
            misses = len(track.confirmations) - hits
            if misses > s.confirm_m - s.confirm_n or t_ns - track.last_measured_ns > s.coast_s * 1e9:
                self._drop(track)
            elif self.promotion_gate(track) is None:
                track.status = TrackStatus.TRACKING
            return
        if not track.point.usable and track.point.scatter_px() is not None:
            track.last_measured_ns = min(track.last_measured_ns, t_ns - int(s.coast_s * 1e9) - 1)
        stale = (t_ns - track.last_measured_ns > s.coast_s * 1e9
                 or t_ns - track.last_confirmed_ns > s.unconfirmed_s * 1e9)
        if track.status is TrackStatus.TRACKING and stale:
            track.status, track.lost_since_ns = TrackStatus.LOST, t_ns
        elif track.status is TrackStatus.LOST:
            if not stale and track.point.disparity is not None and track.confirmations[-1]:
                track.status, track.lost_since_ns = TrackStatus.TRACKING, None
            elif track.lost_since_ns is not None and \
                    t_ns - track.lost_since_ns > self._drop_after_s(track) * 1e9:
                self._drop(track)

    def _drop_after_s(self, track: Track) -> float:
        """How long a LOST track lives: drop_s, and while its restarting Kalman takes start samples
        the time those samples take (init_samples pairs: 5 s at 1 fps, longer than drop_s, so a track
        lost in a turn was dropped while it restarted and the ship was born again under a new id)."""
        p = track.point
        if p.kalman is None or p.frame - p.collected_frame >= p.kalman.design.init_samples:
            return self.s.drop_s
        return self.s.drop_s + p.kalman.design.init_samples / p.s.fps

    def _drop(self, track: Track) -> None:
        track.alive = False
        self.drops += 1
