"""Target motion in the ground plane: an IMM of two constant-velocity Kalman filters on east/north,
per track, fed each pair's own triangulated position; SOG, COG and their 1-sigma come from it.

Why here and not from the image-space filters' rates: the disparity Kalman's rate of a far, slow
ship is known to tens of knots for minutes (a steady 3.4 kn ship at 3 km at 1 fps got no speed in
four minutes), because its white acceleration must let a near ship manoeuvre. On the ground a
ship's motion is simple: straight at constant speed for minutes, now and then a turn. And the
filter must not take the disparity filter's output, whose errors are correlated in time; it takes
each pair's own measurement (the raw disparity of the pair, the column of `GroundTracks.column`:
the ship's box centre, or for a young track the followed point plus the box's offset).

Measurement (per pair): the position triangulated from the pair's own disparity (eq. 4.1). Its
covariance is anisotropic: along the line of sight the range sigma of eq. 4.5 (first order,
sigma_r = r^2 sigma_d / (f L_B), sigma_d the track's own disparity scatter), across it the
bearing sigma r sigma_u / f (sigma_u that column's scatter). R = G diag(sigma_r^2,
sigma_b^2) G^T with G the rotation to the line of sight's bearing (`measurement_cov`). The
matcher's error is not white (it follows the window's texture as the ship's pose changes, over
seconds: docs/decisions.md); R is inflated by (1 + rho) / (1 - rho), rho = exp(-dt / tau), the
variance of a long average of first-order correlated errors against white ones, so that the
filter does not average correlated samples as if they were independent.

Motion models (the IMM, Blom & Bar-Shalom): both constant velocity with white acceleration of
spectral density q (m^2/s^3, Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]] per axis), q small for a
ship holding its course (`QUIET_Q`), large for one turning (`MANOEUVRE_Q`: 0.3 m/s^2 of turn for
tens of seconds). The mode probabilities follow the innovations; the combined covariance holds the
spread of the two models, so while a ship turns its sigma says how unsure the filter is.

Outliers: an innovation beyond the chi-square gate (`GATE_NIS`) is not taken; `RESEAT_AFTER` such
in a row (the point moved to another part of the hull, or the track to another ship's
neighbourhood) re-seat the position on the measurement, keeping the velocity. A point that moved on
the hull (`jumped`) or a restarted disparity filter re-seats at once.

Reporting (`GroundTracks._latch`): SOG/COG are shown once their sigma meets the configured bound
and stay shown until it exceeds HOLD_FACTOR times the bound.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from edge.core import native
from edge.core.geo import KNOT_MPS

QUIET_Q = 2e-4  # m^2/s^3: a ship holding course and speed (helm, swell: velocity wanders ~11 cm/s a minute)
MANOEUVRE_Q = 0.1  # m^2/s^3: a ship turning or changing speed (0.3 m/s^2 for ~10 s)
QUIET_STAY_S = 1200.0  # mean time in the quiet mode before a manoeuvre (the Markov chain's)
MANOEUVRE_STAY_S = 10.0  # mean time in the manoeuvre mode
INIT_SPEED_SIGMA_MPS = 10.0  # the velocity's prior 1-sigma per axis at the first measurement (~20 kn)
GATE_NIS = 16.0  # chi-square, 2 dof: a measurement beyond is an outlier (p = 3e-4)
RESEAT_AFTER = 3  # outliers in a row before the position is re-seated on the measurement
MIN_SPEED_FOR_COURSE_MPS = 0.25  # a course of a slower target is not reported (about 0.5 kn)
HOLD_FACTOR = 1.5  # once shown, SOG/COG stay shown until their sigma exceeds this times the bound


@dataclass(frozen=True)
class GroundSettings:
    """The filter's knobs (the pipeline builds them from its configuration)."""

    quiet_q: float = QUIET_Q
    manoeuvre_q: float = MANOEUVRE_Q
    correlation_s: float = 1.0  # time constant of the matcher's correlated error (R inflation)
    max_sog_sigma_kn: float = 0.75  # SOG reported once its 1-sigma is at most this
    max_cog_sigma_deg: float = 5.5  # COG reported once its 1-sigma is at most this
    hold_factor: float = HOLD_FACTOR  # ... and kept until it exceeds hold_factor times the bound


def measurement_cov(bearing_rad: float, sigma_along_m: float, sigma_across_m: float) -> np.ndarray:
    """2x2 east/north covariance of a fix: sigma_along on the line of sight at `bearing_rad`
    (true, from north toward east), sigma_across perpendicular to it."""
    u0, u1 = math.sin(bearing_rad), math.cos(bearing_rad)  # unit line of sight (east, north)
    w0, w1 = u1, -u0
    a, b = sigma_along_m**2, sigma_across_m**2
    # a u u^T + b w w^T entry by entry in Python floats: the same IEEE operations as np.outer, faster
    return np.array([[a * (u0 * u0) + b * (w0 * w0), a * (u0 * u1) + b * (w0 * w1)],
                     [a * (u1 * u0) + b * (w1 * w0), a * (u1 * u1) + b * (w1 * w1)]])


def _transition(dt_s: float) -> np.ndarray:
    f = np.eye(4)
    f[0, 2] = f[1, 3] = dt_s
    return f


def _process(q: float, dt_s: float) -> np.ndarray:
    """White-acceleration CV process noise for state (e, n, ve, vn)."""
    a, b, c = q * dt_s**3 / 3.0, q * dt_s**2 / 2.0, q * dt_s
    return np.array([[a, 0, b, 0], [0, a, 0, b], [b, 0, c, 0], [0, b, 0, c]])


H = np.hstack([np.eye(2), np.zeros((2, 2))])
_EYE4 = np.eye(4)


def _quad(s: np.ndarray, y: np.ndarray) -> float:
    """y^T S^-1 y for a 2x2 S (closed form: this runs per track and pair)."""
    det = s[0, 0] * s[1, 1] - s[0, 1] * s[1, 0]
    return float((s[1, 1] * y[0] ** 2 - (s[0, 1] + s[1, 0]) * y[0] * y[1] + s[0, 0] * y[1] ** 2) / det)


class GroundTrack:
    """IMM (two CV models) on east/north of one track; `update` once per pair with or without a fix."""

    def __init__(self, settings: GroundSettings | None = None) -> None:
        self.s = settings or GroundSettings()
        self.qs = (self.s.quiet_q, self.s.manoeuvre_q)
        self.t_s: float | None = None
        self._state: tuple[np.ndarray, np.ndarray] | None = None  # state() until the filter changes
        self._speed: tuple[float, float, float, float] | None = None  # speed_course() of ...
        self._speed_for: tuple[np.ndarray, np.ndarray] | None = None  # ... this state
        self.x = np.zeros((2, 4))  # per model
        self.p = np.zeros((2, 4, 4))
        self.mu = np.array([0.5, 0.5])
        self.started = False
        self.measurements = 0  # taken since the start
        self.outliers = 0  # in a row
        self.since_s = 0.0  # time since the first measurement
        self.last_nis = math.nan

    # ------------------------------------------------------------ estimate
    @property
    def mu(self) -> np.ndarray:
        """The models' probabilities (setting them, as every step of the filter does, renews `state`)."""
        return self._mu

    @mu.setter
    def mu(self, value: np.ndarray) -> None:
        self._mu, self._state = value, None

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """Combined (x, P) of the models (the IMM's output). Computed once per step of the filter: the
        fix, its speed and course, the reporting latch and CPA all ask for it (callers get copies)."""
        kernels = native.kernels
        if self._state is None and kernels is not None:
            xs, ps = np.empty(4), np.empty((4, 4))
            kernels.imm_state(self.x, self.p, self._mu, xs, ps)
            self._state = (xs, ps)
        elif self._state is None:
            x = self.mu @ self.x
            p = np.zeros((4, 4))
            for j in range(2):
                d = self.x[j] - x
                p += self.mu[j] * (self.p[j] + np.outer(d, d))
            self._state = (x, p)
        x, p = self._state
        return x.copy(), p.copy()

    def velocity(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(east, north) velocity m/s and its 2x2 covariance; None before the first measurement."""
        if not self.started:
            return None
        x, p = self.state()
        return x[2:], p[2:, 2:]

    def speed_course(self) -> tuple[float, float, float, float] | None:
        """(speed m/s, its 1-sigma, course rad from north toward east, its 1-sigma rad) to first order;
        the course's sigma is inf below MIN_SPEED_FOR_COURSE_MPS. None before the first measurement.
        Computed once per step of the filter (the latch and the fix both ask)."""
        if self._state is not None and self._speed_for is self._state:
            return self._speed
        self._speed = self._speed_course()
        self._speed_for = self._state
        return self._speed

    def _speed_course(self) -> tuple[float, float, float, float] | None:
        vel = self.velocity()
        if vel is None:
            return None
        v, pv = vel
        speed = float(math.hypot(v[0], v[1]))
        if speed <= 1e-9:
            return 0.0, math.sqrt(max(np.trace(pv) / 2.0, 0.0)), 0.0, math.inf
        u = v / speed
        w = np.array([u[1], -u[0]])
        speed_sd = math.sqrt(max(float(u @ pv @ u), 0.0))
        course_sd = math.sqrt(max(float(w @ pv @ w), 0.0)) / speed
        if speed < MIN_SPEED_FOR_COURSE_MPS:
            course_sd = math.inf
        return speed, speed_sd, math.atan2(v[0], v[1]) % (2.0 * math.pi), course_sd

    # ------------------------------------------------------------ per pair
    def update(self, t_s: float, z_en_m: np.ndarray | None, r_en: np.ndarray | None,
               reseat: bool = False) -> bool:
        """Advance to `t_s` and take the east/north fix `z_en_m` with covariance `r_en` (None: a
        pair without one). `reseat`: the measured point moved on the hull (keep the velocity,
        start the position over). True when the fix was taken."""
        if z_en_m is None or r_en is None:
            if self.started and self.t_s is not None and t_s > self.t_s:
                self._predict(t_s - self.t_s)
                self.t_s = t_s
            return False
        z = np.asarray(z_en_m, float)
        if not self.started:
            self._start(t_s, z, r_en)
            return True
        dt = max(t_s - (self.t_s if self.t_s is not None else t_s), 0.0)
        r = r_en * self._inflation(dt)
        if dt > 0:
            self._predict(dt)
            self.since_s += dt
        self.t_s = t_s
        if reseat:
            self._reseat(z, r)
            return True
        x, p = self.state()
        y = z - x[:2]
        nis = _quad(p[:2, :2] + r, y)
        self.last_nis = nis
        if nis > GATE_NIS:
            self.outliers += 1
            if self.outliers >= RESEAT_AFTER:
                self._reseat(z, r)
                return True
            return False
        self.outliers = 0
        kernels = native.kernels
        if kernels is not None:  # the same model updates compiled (native/src/imm.c)
            kernels.imm_correct(self.x, self.p, self._mu, float(z[0]), float(z[1]),
                                np.ascontiguousarray(r, dtype=np.float64))
            self._state = None
            self.measurements += 1
            return True
        likelihood = np.zeros(2)
        for j in range(2):
            yj = z - self.x[j, :2]
            sj = self.p[j, :2, :2] + r
            det = float(sj[0, 0] * sj[1, 1] - sj[0, 1] * sj[1, 0])
            s_inv = np.array([[sj[1, 1], -sj[0, 1]], [-sj[1, 0], sj[0, 0]]]) / det
            k = self.p[j, :, :2] @ s_inv  # P H^T S^-1
            self.x[j] = self.x[j] + k @ yj
            ikh = _EYE4 - k @ H
            self.p[j] = ikh @ self.p[j] @ ikh.T + k @ r @ k.T  # Joseph form: stays symmetric, positive
            nj = float(yj @ s_inv @ yj)
            likelihood[j] = math.exp(-0.5 * nj) / (2.0 * math.pi * math.sqrt(max(det, 1e-300)))
        post = likelihood * self.mu
        self._state = None  # the models' x and P changed above
        if post.sum() > 0 and np.all(np.isfinite(post)):
            self.mu = post / post.sum()
        self.measurements += 1
        return True

    def _inflation(self, dt_s: float) -> float:
        """(1 + rho) / (1 - rho), rho = exp(-dt / tau): a long average's variance of first-order
        correlated errors over that of white ones (module doc); 1 without correlation."""
        if self.s.correlation_s <= 0 or dt_s <= 0:
            return 1.0
        rho = math.exp(-dt_s / self.s.correlation_s)
        return (1.0 + rho) / (1.0 - rho)

    def _start(self, t_s: float, z: np.ndarray, r: np.ndarray) -> None:
        self.t_s, self.started, self.measurements, self.since_s = t_s, True, 1, 0.0
        p = np.zeros((4, 4))
        p[:2, :2] = r
        p[2, 2] = p[3, 3] = INIT_SPEED_SIGMA_MPS**2
        for j in range(2):
            self.x[j] = np.array([z[0], z[1], 0.0, 0.0])
            self.p[j] = p
        self.mu = np.array([0.5, 0.5])
        self.outliers = 0

    def _reseat(self, z: np.ndarray, r: np.ndarray) -> None:
        """Start the position over on z (covariance r), keeping each model's velocity and its variance."""
        for j in range(2):
            self.x[j, :2] = z
            pv = self.p[j, 2:, 2:].copy()
            self.p[j] = 0.0
            self.p[j, :2, :2] = r
            self.p[j, 2:, 2:] = pv
        self._state = None
        self.outliers = 0

    def _predict(self, dt_s: float) -> None:
        """The IMM's mixing (Markov chain of mean stays QUIET_STAY_S / MANOEUVRE_STAY_S) and each
        model's CV prediction."""
        kernels = native.kernels
        if kernels is not None:  # the same mixing and prediction compiled (native/src/imm.c)
            kernels.imm_predict(self.x, self.p, self._mu, float(dt_s), float(self.qs[0]), float(self.qs[1]),
                                QUIET_STAY_S, MANOEUVRE_STAY_S)
            self._state = None
            return
        p01 = 1.0 - math.exp(-dt_s / QUIET_STAY_S)
        p10 = 1.0 - math.exp(-dt_s / MANOEUVRE_STAY_S)
        trans = np.array([[1.0 - p01, p01], [p10, 1.0 - p10]])
        c = self.mu @ trans  # predicted mode probabilities
        w = (trans * self.mu[:, None]) / np.maximum(c[None, :], 1e-300)  # w[i, j] = P(i | j)
        x0 = w.T @ self.x
        f = _transition(dt_s)
        d = self.x[:, None, :] - x0[None, :, :]  # d[i, j] = x_i - x0_j
        p0 = np.einsum("ij,iab->jab", w, self.p) + np.einsum("ij,ija,ijb->jab", w, d, d)
        self.x = x0 @ f.T
        self.p = f @ p0 @ f.T + np.stack([_process(q, dt_s) for q in self.qs])
        self.mu = c


# ---------------------------------------------------------------- per track, from the pipeline's points
COLUMN_NOISE_PX = 0.05  # the least scatter a followed column is credited with (bearing sigma)
BOX_FIT_S = 20.0  # the box centre's scatter is its RMS residual about a line over this much of the track
BOX_CENTRE_FLOOR_PX = 0.5  # the least scatter a box centre is credited with (whole-pixel box edges)
BOX_MIN_SAMPLES = 5  # detections within BOX_FIT_S before the box centre is the column
DISPARITY_NOISE_FLOOR_PX = 0.02  # the least disparity scatter a fix is credited with (range sigma)


@dataclass(frozen=True)
class PairFix:
    """One pair's own measurement of a track's point: east/north (m) and its covariance."""

    en_m: np.ndarray
    cov: np.ndarray


def column_noise_px(columns: list[tuple[float, float]], floor_px: float = COLUMN_NOISE_PX) -> float:
    """RMS residual of (time or frame, column) samples about their least-squares line (>= floor_px;
    the floor alone with fewer than 5 samples)."""
    n = len(columns)
    if n < 5:
        return floor_px
    # the least-squares line about the mean time, its residuals summed in Python floats (np.linalg.lstsq
    # took 20-40 us a call for these few samples; the two agree to ~1e-15 of the columns,
    # tests/edge/measure/test_groundtrack.py)
    ts, us = zip(*columns, strict=True)
    t_mean, u_mean = sum(ts) / n, sum(us) / n
    stt = stu = 0.0
    for t, u in columns:
        dt = t - t_mean
        stt += dt * dt
        stu += dt * (u - u_mean)
    slope = stu / stt if stt > 0 else 0.0
    rss = 0.0
    for t, u in columns:
        e = u - u_mean - slope * (t - t_mean)
        rss += e * e
    return max(floor_px, math.sqrt(rss / (n - 2)))


def pair_fix(east_m: float, north_m: float, sigma_d_px: float, sigma_u_px: float, focal_px: float,
             baseline_m: float) -> PairFix:
    """A triangulated point's east/north and its anisotropic covariance: eq. 4.5's range sigma to
    first order (r^2 sigma_d / (f L_B), eq. 2.12) along the line of sight, r sigma_u / f across it."""
    r = math.hypot(east_m, north_m)
    sigma_r = r * r * max(sigma_d_px, DISPARITY_NOISE_FLOOR_PX) / (focal_px * baseline_m)  # eq. 4.5
    sigma_b = r * max(sigma_u_px, COLUMN_NOISE_PX) / focal_px
    cov = measurement_cov(math.atan2(east_m, north_m), sigma_r, sigma_b)
    return PairFix(np.array([east_m, north_m]), cov)


@dataclass
class _Entry:
    track: GroundTrack
    updates: int = 0  # the point's disparity-filter updates at the last pair (a drop: it restarted)
    sog_shown: bool = False  # the reporting latch (`GroundTracks._latch`)
    cog_shown: bool = False
    centres: deque[tuple[float, float]] = field(default_factory=deque)  # (t s, detected box centre px)
    centres_noise_px: float | None = None  # column_noise_px of `centres` as they are (None: not computed)
    offset_px: float | None = None  # the box centre's last known offset from the followed point


class GroundTracks:
    """The ground-plane filters of all live tracks, by track id."""

    def __init__(self, settings: GroundSettings | None = None) -> None:
        self.s = settings or GroundSettings()
        self._by_id: dict[int, _Entry] = {}

    def step(self, t_s: float, fixes: dict[int, tuple[PairFix | None, bool, int]]) -> None:
        """Advance every live track's filter: track id -> (this pair's fix or None, whether the
        point moved on the hull, its disparity filter's update count). Tracks not given are gone."""
        self._by_id = {i: e for i, e in self._by_id.items() if i in fixes}
        for track_id, (fix, jumped, updates) in fixes.items():
            entry = self._entry(track_id)
            restarted = updates < entry.updates
            entry.updates = updates
            if fix is None:
                entry.track.update(t_s, None, None)
            else:
                reseat = (jumped or restarted) and entry.track.started
                entry.track.update(t_s, fix.en_m, fix.cov, reseat=reseat)
            self._latch(entry)

    def _entry(self, track_id: int) -> _Entry:
        """The track's entry, made at its first pair."""
        entry = self._by_id.get(track_id)
        if entry is None:
            entry = self._by_id[track_id] = _Entry(GroundTrack(self.s))
        return entry

    def _latch(self, entry: _Entry) -> None:
        """Reporting with hysteresis: SOG (COG) is first shown when its sigma meets its bound, and
        stays shown until the sigma exceeds `hold_factor` times the bound. A short rise of the
        manoeuvre mode's probability (a few pairs of unlucky innovations) widens the sigma a little
        past the bound; withholding a speed already known to the bound's accuracy for it would
        blank the field for seconds and help nobody. The sigma reported beside the value stays the
        filter's own, so a VTS sees how unsure it is meanwhile; a real manoeuvre widens it past the
        hold limit within seconds (the manoeuvre model's q) and the field empties."""
        est = entry.track.speed_course()
        if est is None:
            entry.sog_shown = entry.cog_shown = False
            return
        _, speed_sd, _, course_sd = est
        sog_kn, cog_deg = speed_sd / KNOT_MPS, math.degrees(course_sd)
        hold = max(self.s.hold_factor, 1.0)
        sog_limit = self.s.max_sog_sigma_kn * (hold if entry.sog_shown else 1.0)
        entry.sog_shown = sog_kn <= sog_limit
        cog_limit = self.s.max_cog_sigma_deg * (hold if entry.cog_shown else 1.0)
        entry.cog_shown = entry.sog_shown and cog_deg <= cog_limit

    def column(self, track_id: int, t_s: float, point_px: float, point_noise_px: float, centre_px: float,
               detected: bool, jumped: bool) -> tuple[float, float]:
        """The column (px) the track's fix takes and its 1-sigma (see `Pipeline._ground_step`). Once
        BOX_MIN_SAMPLES detections lie within the last BOX_FIT_S: the ship's box centre (`centre_px`,
        between detections the last box carried by the followed point), its sigma the detected
        centres' RMS residual about their line (>= BOX_CENTRE_FLOOR_PX). The followed point is
        precise from pair to pair but slides along the hull as its template is re-taken; the box
        centre stays on the ship but scatters by a pixel. Before that (a young track, or detections
        lost): the followed point plus the box centre's offset from it when last known, with the
        point's own scatter: over a few seconds the slide is a few hundredths of a pixel. The switch
        steps the column by about the box's scatter, which the sigma then allows. `detected`: the
        centre is this pair's detection box; `jumped`: the point moved to another part of the hull."""
        entry = self._entry(track_id)
        if jumped:
            entry.centres.clear()
            entry.offset_px = entry.centres_noise_px = None
        if detected:
            entry.centres.append((t_s, centre_px))
            entry.centres_noise_px = None
        while entry.centres and entry.centres[0][0] < t_s - BOX_FIT_S:
            entry.centres.popleft()
            entry.centres_noise_px = None
        if len(entry.centres) >= BOX_MIN_SAMPLES:
            entry.offset_px = centre_px - point_px
            if entry.centres_noise_px is None:  # the centres change on detection pairs only
                entry.centres_noise_px = column_noise_px(list(entry.centres), floor_px=0.0)
            return centre_px, max(BOX_CENTRE_FLOOR_PX, entry.centres_noise_px)
        if entry.offset_px is None:
            entry.offset_px = centre_px - point_px
        return point_px + entry.offset_px, point_noise_px

    def state(self, track_id: int) -> tuple[np.ndarray, np.ndarray] | None:
        """The track's combined east/north state (e, n, ve, vn) and its 4x4 covariance (the IMM's
        output, for CPA/TCPA: edge.core.cpa); None before its first fix."""
        entry = self._by_id.get(track_id)
        if entry is None or not entry.track.started:
            return None
        return entry.track.state()

    def position(self, track_id: int) -> tuple[np.ndarray, np.ndarray] | None:
        """The track's filtered east/north position (m) and its 2x2 covariance; None before its
        first fix (the AIS association's gate, edge.ais.associate)."""
        state = self.state(track_id)
        if state is None:
            return None
        x, p = state
        return x[:2].copy(), p[:2, :2].copy()

    def motion(self, track_id: int) -> Motion | None:
        """The track's east/north velocity and its speed and course sigmas, with whether each is shown
        (its sigma met the configured bound, with `_latch`'s hysteresis; the speed's holds for
        both); None before its first fix."""
        entry = self._by_id.get(track_id)
        est = None if entry is None else entry.track.speed_course()
        vel = None if entry is None else entry.track.velocity()
        if est is None or vel is None:
            return None
        _, speed_sd, _, course_sd = est
        assert entry is not None
        return Motion(vel[0].copy(), speed_sd / KNOT_MPS, math.degrees(course_sd), entry.sog_shown,
                      entry.cog_shown)


@dataclass(frozen=True)
class Motion:
    """A track's ground motion for its fix."""

    velocity_en_mps: np.ndarray  # (east, north)
    sog_sigma_kn: float
    cog_sigma_deg: float  # inf below MIN_SPEED_FOR_COURSE_MPS
    sog_ok: bool  # report SOG: its sigma met the bound (and has not since passed the hold limit)
    cog_ok: bool  # ... and likewise the course: report COG
