"""Pipeline: FramePair -> list[ShipFix], the whole measurement chain of docs/design.md.

    detect (every k-th pair, decimated left image)     edge.measure.detect
    -> TrackTable: associate, birth/confirm/coast/drop  edge.measure.tracks
    -> per track: left point, right match, filter       edge.measure.point
    -> triangulate (eq. 4.1) and error (eq. 4.5)        edge.core.triangulation
    -> range, bearing, lat/lon                          edge.core.geo
    -> per track, ground-plane motion: SOG/COG          edge.measure.groundtrack

The daemon and `mast-stereo replay` run the same object. It is synchronous
and deterministic: no clocks, no randomness, no threads, so the same pairs
give the same fixes bit for bit. A pair it cannot use (wrong size or type,
an exception deep in a track) is counted and skipped, never raised: the
daemon must keep running. Gaps in `t_ns` longer than a frame period are
counted as skipped pairs and the filters coast through them.

Every track the tracker holds is in every step's fixes from its first fix until its drop: in a pair
where its point cannot be ranged on (disparity unknown, or scattering more than the usable bound)
its last measured fix is coasted to the pair (`edge.measure.coast`), so no output sees a track end
and start again while the tracker still holds it.

Speed and course come from each track's ground-plane filter (`edge.measure.groundtrack`: an IMM of
two constant-velocity Kalman filters on east/north, fed each pair's own triangulated position with
its anisotropic covariance). They are left unknown (None: empty in TTM, the "unknown" value on
Modbus) while their 1-sigma exceeds the configured bounds (`pipeline.max_sog_sigma_kn`,
`pipeline.max_cog_sigma_deg`): a ghost speed misleads a VTS operator more than an empty field.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import cv2
import numpy as np

from drivers.camera.base import FramePair
from edge.config.app import PipelineConfig
from edge.config.calibration import Calibration
from edge.core import native
from edge.core.calibsigma import Pointing
from edge.core.geo import enu_to_world, range_bearing, speed_course, world_to_enu, world_to_latlon
from edge.core.match import subpixel_methods
from edge.core.rectify import Rectifier
from edge.core.site import Site
from edge.core.triangulation import position_error, triangulate_normalised
from edge.fix import ShipFix, TrackStatus
from edge.measure.coast import coast
from edge.measure.detect import Detector
from edge.measure.groundtrack import GroundSettings, GroundTracks, PairFix, column_noise_px, pair_fix
from edge.measure.seadetect import SeaDetector
from edge.measure.settings import FILTERS, SUBPIXELS, PointSettings
from edge.measure.tracks import TableSettings, Track, TrackTable

log = logging.getLogger(__name__)

MAX_DETECT_INTERVAL_S = 0.5  # slow cameras detect more often than every k-th pair (1 fps: every pair)


@dataclass
class Counters:
    """What the pipeline did with the pairs it was given (reported by replay and the daemon)."""

    pairs: int = 0  # pairs given to step()
    processed: int = 0  # pairs that went through the whole chain
    bad_input: int = 0  # pairs refused (wrong size, type, or time going backwards)
    failed: int = 0  # pairs abandoned after an unexpected error
    gaps: int = 0  # frame periods without a pair (dropped upstream), coasted through
    detections: int = 0  # detection passes run
    masked: int = 0  # detections whose waterline lay in a site mask (masks:), not used
    fixes: int = 0


class Pipeline:
    """One rig's processing state; call `step` with each pair in time order."""

    def __init__(self, calibration: Calibration, config: PipelineConfig | None = None, *, fps: float = 10.0,
                 site: Site | None = None, subpixel: str = PointSettings.subpixel, filter: str | None = None,
                 utc_offset_ns: int = 0, search_mask: np.ndarray | None = None) -> None:
        cfg = config or PipelineConfig()
        exp = cfg.experimental  # research switches: the defaults are the product
        site = site or calibration.site
        if site is None:
            raise ValueError("the pipeline needs a site (lat/lon/height/heading) for positions")
        if subpixel not in SUBPIXELS + subpixel_methods() or (filter is not None and filter not in FILTERS):
            raise ValueError(f"subpixel must be one of {SUBPIXELS}, filter one of {FILTERS}")
        self.site, self.fps, self.cfg = site, float(fps), cfg
        if native.kernels is None:
            log.warning("the compiled kernels (mast-stereo-native, native/) are not installed: the NumPy "
                        "reference runs instead (the same fixes, about three times the CPU time)")
        self.utc_offset_ns = int(utc_offset_ns)
        self.rig = calibration.rig
        self.rect = Rectifier(self.rig)
        kind = SeaDetector if exp.detector == "seaclutter" else Detector
        self.detector = kind(self.rect, site.height_m, decimation=cfg.detect_decimation,
                             min_ship_px=cfg.min_ship_px)
        self.point_settings = PointSettings(
            fps=self.fps, window=cfg.window, max_disparity=cfg.max_disparity, cost=exp.cost,
            prefilter=cfg.prefilter, subpixel=subpixel,
            filter=filter or exp.filter, butterworth_cutoff_hz=exp.butterworth_cutoff_hz,
            gate_sigma=exp.gate_sigma, reacquire_s=cfg.coast_s, baseline_m=self.rig.baseline_m,
            focal_px=self.rect.f_px, alias_check=exp.alias_check, depth_check=exp.depth_check)
        self.table = TrackTable(self.rect, site.height_m, self.point_settings,
                                TableSettings(coast_s=cfg.coast_s, max_tracks=cfg.max_tracks,
                                              waterline_tol_px=2.0 + 2.0 * cfg.detect_decimation))
        self.pointing = Pointing(self.rect.f_px, self.rig.left.rotation_deg, self.rig.right.rotation_deg,
                                 calibration.sigma,
                                 site.tilt_sigma_deg or 0.0)
        self.table.pointing = self.pointing
        self.search_mask = None if search_mask is None else np.asarray(search_mask, dtype=bool)
        if self.search_mask is not None and self.search_mask.shape != (self.rig.height, self.rig.width):
            raise ValueError(f"search mask {self.search_mask.shape} is not the image's "
                             f"{(self.rig.height, self.rig.width)}")
        self.table.search_mask = self.search_mask
        self.ground = GroundTracks(GroundSettings(max_sog_sigma_kn=cfg.max_sog_sigma_kn,
                                                  max_cog_sigma_deg=cfg.max_cog_sigma_deg))
        self.counters = Counters()
        self.last_detections: tuple[tuple[int, int, int, int], ...] = ()  # raw left boxes kept (the page)
        self._last_t_ns: int | None = None
        self._last_measured: dict[int, ShipFix] = {}  # track id -> its last measured fix (for coasting)
        self._since_detect = cfg.detect_every - 1  # detect on the first pair
        self._logged: set[str] = set()

    # ------------------------------------------------------------ per pair
    def step(self, pair: FramePair) -> list[ShipFix]:
        """Process one pair; the fixes of every live track that has a position."""
        c = self.counters
        c.pairs += 1
        images = self._images(pair)
        if images is None:
            c.bad_input += 1
            return []
        try:
            fixes = self._step(*images, pair.t_ns)
        except Exception as exc:  # a fault in one pair must not stop the appliance
            c.failed += 1
            self._log_once(f"{type(exc).__name__}", "pair at t_ns=%d abandoned: %r", pair.t_ns, exc)
            return []
        c.processed += 1
        c.fixes += len(fixes)
        return fixes

    def _images(self, pair: FramePair) -> tuple[np.ndarray, np.ndarray] | None:
        out = []
        for name, image in (("left", pair.left), ("right", pair.right)):
            if not isinstance(image, np.ndarray) or image.dtype != np.uint8:
                self._log_once(f"type-{name}", "%s image is not 8-bit; pair skipped", name)
                return None
            if image.ndim == 3 and image.shape[2] == 3:
                image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
            if image.shape != (self.rig.height, self.rig.width):
                self._log_once(f"shape-{name}", "%s image is %s, the calibration says %dx%d; pair skipped",
                               name, image.shape, self.rig.width, self.rig.height)
                return None
            out.append(image)
        if self._last_t_ns is not None and pair.t_ns <= self._last_t_ns:
            self._log_once("time", "pair time does not increase (t_ns=%d); pair skipped", pair.t_ns)
            return None
        return out[0], out[1]

    def _step(self, left: np.ndarray, right: np.ndarray, t_ns: int) -> list[ShipFix]:
        skipped = 0
        if self._last_t_ns is not None:
            periods = int(round((t_ns - self._last_t_ns) * self.fps / 1e9))
            skipped = max(0, periods - 1)
            self.counters.gaps += skipped
        self._last_t_ns = t_ns
        self._since_detect += 1 + skipped
        boxes, weak = None, None
        if self._since_detect >= min(self.cfg.detect_every, max(1, int(MAX_DETECT_INTERVAL_S * self.fps))):
            self._since_detect = 0
            self.counters.detections += 1
            blobs = self.detector.detect(left)
            if self.search_mask is not None:  # site masks: a ship's waterline must be in the open
                kept = [b for b in blobs if waterline_open(self.search_mask, b.x0, b.x1, b.y1)]
                self.counters.masked += len(blobs) - len(kept)
                blobs = kept
            self.last_detections = tuple((int(b.x0), int(b.y0), int(b.x1), int(b.y1)) for b in blobs)
            boxes = self._rect_boxes([(b.x0, b.y0, b.x1, b.y1) for b in blobs])
            # a blob the detector calls weak (`weak` true) waits until it persists (edge.measure.candidates)
            weak = [bool(getattr(b, "weak", False)) for b in blobs]
        tracks = self.table.step(left, right, t_ns, skipped, boxes, weak)
        return self._fixes(tracks, t_ns)

    def _rect_boxes(self, raw: list[tuple[int, int, int, int]]) -> list[np.ndarray]:
        """Raw left-image boxes -> rectified boxes (corners and edge midpoints mapped), all boxes'
        points through the lens model in one call (the undistortion costs ~0.1 ms a call)."""
        if not raw:
            return []
        pts: list[tuple[float, float]] = []
        for x0, y0, x1, y1 in raw:
            xs, ys = (x0 - 0.5, 0.5 * (x0 + x1) - 0.5, x1 - 0.5), (y0 - 0.5, 0.5 * (y0 + y1) - 0.5, y1 - 0.5)
            pts.extend((x, y) for x in xs for y in ys)
        mapped = self.rect.raw_to_rect(np.array(pts), 0).reshape(len(raw), 9, 2)
        lo, hi = mapped.min(axis=1) + 0.5, mapped.max(axis=1) + 0.5
        return [np.array([a[0], a[1], b[0], b[1]]) for a, b in zip(lo, hi, strict=True)]

    # ------------------------------------------------------------ fixes
    def _fixes(self, tracks: list[Track], t_ns: int) -> list[ShipFix]:
        """Every live track's fix: measured where its point can be ranged on, else, for a track that
        has had a fix, its last one coasted to this pair (`edge.measure.coast`), so only a drop
        from the tracker ends a track in the outputs."""
        live = [t for t in tracks if t.point.disparity is not None and t.point.disparity > 0.0
                and (t.point.usable or t.point.scatter_px() is None)]
        measured = {f.track_id: f for f in self._measured_fixes(live, tracks, t_ns)}
        self._last_measured = {t.id: measured.get(t.id) or self._last_measured[t.id] for t in tracks
                               if t.id in measured or t.id in self._last_measured}
        return [measured.get(t.id) or coast(self._last_measured[t.id], t_ns + self.utc_offset_ns, t.status,
                                            self.site, age_s=t.age_s(t_ns), confidence=t.confidence)
                for t in tracks if t.id in self._last_measured]

    def _measured_fixes(self, live: list[Track], tracks: list[Track], t_ns: int) -> list[ShipFix]:
        """The fixes of the `live` tracks (those whose point can be ranged on in this pair)."""
        if not live:
            self._ground_step(tracks, t_ns)
            return []
        f, b = self.rect.f_px, self.rig.baseline_m
        use_filtered_u = self.point_settings.filter == "kalman"
        u = np.array([t.point.u_filtered if use_filtered_u and t.point.u_filtered is not None else t.point.u
                      for t in live])
        v = np.array([t.point.v for t in live])
        d = np.array([t.point.disparity for t in live])
        xy_l = self.rect.rect_to_normalised(np.stack([u, v], -1))
        xy_r = xy_l - np.stack([d / f, np.zeros_like(d)], -1)
        world = triangulate_normalised(xy_l, xy_r, b)  # eq. 4.1
        range_m, bearing = range_bearing(world, self.site.heading_deg)
        # the filter's sigma and, in quadrature, the aliasing and depth checks' terms (0 when they are off)
        sigma_d = np.array([math.hypot(t.point.sigma_px, t.point.alias_sigma_px, t.point.depth_sigma_px)
                            for t in live])
        sigma_m, across_m = self._sigmas_m(world, xy_l, d, sigma_d, range_m)
        lat, lon, _ = world_to_latlon(world, self.site)
        self._ground_step(tracks, t_ns)
        motions = [self.ground.motion(t.id) for t in live]
        v_en = np.array([[0.0, 0.0] if m is None else m.velocity_en_mps.tolist() for m in motions])
        v_world = enu_to_world(np.concatenate([v_en, np.zeros((len(live), 1))], axis=1),
                               self.site.heading_deg)
        sog, cog = speed_course(v_world, lat, lon, self.site)  # COG against north at the target
        # per-fix values as Python floats in one call per array (the same doubles as float(a[i]), without
        # a numpy scalar per field and fix)
        rows = zip(live, motions, world.tolist(), *(a.tolist() for a in (range_m, bearing, lat, lon, sog, cog,
                                                                          sigma_m, across_m, d)),
                   strict=True)
        fixes = []
        for t, mo, (x_m, y_m, z_m), r_m, brg, la, lo, sog_kn, cog_deg, sig_m, across, d_px in rows:
            # speed and course from the ground-plane filter, withheld (None: empty in TTM, "unknown"
            # on Modbus) until their 1-sigma meets the configured bound
            sog_ok, cog_ok = mo is not None and mo.sog_ok, mo is not None and mo.cog_ok
            x0_rel, _, x1_rel, _ = t.box_rel.tolist()  # t.box's columns, the same sums in Python floats
            u_px = t.point.u
            en = self.ground.state(t.id) if sog_ok else None  # for CPA/TCPA (edge.alerts)
            fixes.append(ShipFix(
                t_ns=t_ns + self.utc_offset_ns, track_id=t.id, status=t.status,
                x_m=x_m, y_m=y_m, z_m=z_m, range_m=r_m, bearing_deg=brg, lat_deg=la, lon_deg=lo,
                sog_kn=sog_kn if sog_ok else None, cog_deg=cog_deg if cog_ok else None,
                sigma_m=sig_m, disparity_px=d_px, age_s=t.age_s(t_ns), confidence=t.confidence,
                length_m=((x1_rel + u_px) - (x0_rel + u_px)) * z_m / f,
                sog_sigma_kn=mo.sog_sigma_kn if mo is not None and sog_ok else None,
                cog_sigma_deg=mo.cog_sigma_deg if mo is not None and cog_ok else None,
                en_state=None if en is None else tuple(en[0].tolist()),
                en_cov=None if en is None else tuple(en[1].ravel().tolist()), sigma_across_m=across))
        return fixes

    def _sigma_m(self, world: np.ndarray, xy_l: np.ndarray, d: np.ndarray, sigma_d: np.ndarray,
                 range_m: np.ndarray) -> np.ndarray:
        """Each fix's 1-sigma, m (the first of `_sigmas_m`)."""
        return self._sigmas_m(world, xy_l, d, sigma_d, range_m)[0]

    def _sigmas_m(self, world: np.ndarray, xy_l: np.ndarray, d: np.ndarray, sigma_d: np.ndarray,
                  range_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each fix's 1-sigma and its share across the line of sight, m: along the line of sight
        eq. 4.5's range error (its far side, the larger) for the filter's disparity sigma and the
        calibration's disparity share in quadrature, across it the range times the calibration's
        column sigma over f (the bearing; edge.core.calibsigma); the 1-sigma is both in quadrature.
        Without calibration standard errors or a tilt bound the bearing share is 0 and this is
        eq. 4.5 alone. The across share lets ASTERIX I010/500 state an ellipse, not a circle."""
        f, b = self.rect.f_px, self.rig.baseline_m
        _, col_px, disp_px = self.pointing.sigmas(xy_l[..., 0], xy_l[..., 1], d)
        err = position_error(world, np.hypot(sigma_d, disp_px) / f, b)  # eq. 4.5
        along = np.hypot(err[..., 0], err[..., 2])
        across = range_m * col_px / f
        sigma_m = np.hypot(along, across)
        return np.where(np.isfinite(err).all(axis=-1), sigma_m, math.inf), across

    def _ground_step(self, tracks: list[Track], t_ns: int) -> None:
        """Each track's own measurement of this pair into its ground-plane filter
        (edge.measure.groundtrack): the raw disparity the disparity filter accepted (not the filter's
        output, whose errors are correlated in time) on the followed point's column corrected by the
        ship's box centre (`GroundTracks.column`): the point's template is re-taken every second, so
        it slides along the hull (slow-5km: 14 px in 250 s, an apparent 0.06 m/s across the line of
        sight), while the detector's box centre stays on the ship's centre (0.95 px white scatter
        there)."""
        f, b = self.rect.f_px, self.rig.baseline_m
        fixes: dict[int, tuple[PairFix | None, bool, int]] = {}
        measured = [t for t in tracks if t.point.accepted and t.point.raw_disparity is not None
                    and t.point.raw_disparity > 0.0 and (t.point.followed or t.point.jumped != (0.0, 0.0))]
        if measured:
            cols = [self.ground.column(t.id, t_ns / 1e9, t.point.u, column_noise_px(list(t.point.columns)),
                                       self._box_centre(t), t.det_frame == t.point.frame,
                                       t.point.jumped != (0.0, 0.0)) for t in measured]
            uv = np.array([[c, t.point.v] for (c, _), t in zip(cols, measured, strict=True)])
            raw = np.array([t.point.raw_disparity for t in measured])
            xy_l = self.rect.rect_to_normalised(uv)
            xy_r = xy_l - np.stack([raw / f, np.zeros_like(raw)], -1)
            world = triangulate_normalised(xy_l, xy_r, b)  # eq. 4.1
            enu = world_to_enu(world, self.site.heading_deg)
            for t, (_, sigma_u), (east, north, _) in zip(measured, cols, enu.tolist(), strict=True):
                p = t.point
                sigma_d = p.scatter_px() or p.noise_px
                fixes[t.id] = (pair_fix(east, north, sigma_d, sigma_u, f, b),
                               p.jumped != (0.0, 0.0), p.updates)
        for t in tracks:
            fixes.setdefault(t.id, (None, False, t.point.updates))
        self.ground.step(t_ns / 1e9, fixes)

    @staticmethod
    def _box_centre(t: Track) -> float:
        """0.5 * float(t.box[0] + t.box[2]), the same float64 additions in Python floats (t.box makes
        two arrays a call)."""
        x0_rel, _, x1_rel, _ = t.box_rel.tolist()
        u = t.point.u
        return 0.5 * ((x0_rel + u) + (x1_rel + u))

    def _log_once(self, key: str, msg: str, *args: object) -> None:
        if key not in self._logged:
            self._logged.add(key)
            log.warning(msg, *args)


def waterline_open(mask: np.ndarray, x0: float, x1: float, y1: float) -> bool:
    """Whether a raw left-image box [x0, x1) x [..., y1) has its waterline, the centre of its
    bottom row, where the search mask allows detection (True: may detect)."""
    h, w = mask.shape
    u = min(w - 1, max(0, int(round(0.5 * (x0 + x1 - 1)))))
    v = min(h - 1, max(0, int(round(y1 - 1))))
    return bool(mask[v, u])


__all__ = ["Counters", "Pipeline", "TrackStatus", "waterline_open"]
