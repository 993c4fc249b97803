"""Default disparity filter: constant-velocity Kalman on disparity as a table-driven alpha-beta
filter in Q24 fixed point, with a float reference, a 3-sigma innovation gate, coasting,
re-acquisition after a gap and a robust line-fit start (research note §2.3).

Why: the Butterworth (eq. 6.1) lags an approaching ship by tau * d' and passes outliers; a CV
model has no ramp lag, and gating on the innovation drops glints and fog jumps (note §2.4).

The model (per-frame units, v in px/frame): x = [d, v], F = [[1, 1], [0, 1]], white
acceleration with Q = q [[1/4, 1/2], [1/2, 1]], q = (sigma_a T^2)^2, measurement R = sigma_n^2.
Its covariance does not depend on the data, so `design_kalman` runs the Riccati recursion
once, in float, from the start-up covariance to the steady state and stores the gains
alpha_k, beta_k (Q24) and covariances (Q36 px^2) as integer tables indexed by k, the number of
accepted updates since (re)initialisation. The filter itself then only adds, multiplies and
shifts integers (and divides twice per start):

    predict   d += v                                   (Q24 px, Q24 px/frame; int64)
    residual  r = z - d                                (z in Q8 px, shifted to Q24)
    gate      r^2 > 9 S  ->  reject and coast          (S from the tables, eq. K.6)
    correct   d += alpha_k r,  v += beta_k r           (Q24 x Q24 -> round-shift 24)
    start     line through n samples, eq. K.5          (integer sums, two rounded divisions)

Missing or gated samples coast on the prediction; the gate and the reported sigma grow with
the coast count m. The first sample accepted after m misses rewinds k to the table entry whose
predicted variance matches a steady-state track's coasted one, so the filter re-converges like a
Kalman filter whose covariance grew (not a young track's own coast: that lands on the start's
gains, which move v as if unknown; measured, the glints recording then followed its glints).
After `reacquire_s` of misses the track restarts.

Start-up, and why it changed (bench-core's start-up lock-loss table: 10 000 starts, 2 % outliers,
lost = off by > 5 sigma_n or no estimate in the 3 s after the start): the start was the median of
5 samples with v = 0 and a 1 px/s rate prior, so the first residuals were read as velocity
(beta_0 = 0.29 at 10 fps) and a ramp left it lagging, while the gate of a coasting young track was
the *steady-state* coast, far below its un-converged covariance. A noise run in the first updates
(or a fast boat's rate) drove the state off, the gate refused the truth and the estimate ran away
until the 3 s re-acquisition: 10 and 828 of 10 000 starts lost (ship / fast boat, 10 fps), 0 and
202 at 30 fps. Now none (1 of 10 000 in each row without change 3):

1. (Re)starts fit a least-squares line to `init_samples` = n samples: d at the last one, v its slope
(unbiased for any rate), covariance for n consecutive frames, l = (n - 1)/2, Sxx = n (n^2 - 1)/12,

    P_0 = sigma_n^2 [[1/n + l^2/Sxx, l/Sxx], [l/Sxx, 1/Sxx]]     (n = 5: 0.6, 0.2, 0.1)    (eq. K.5)

and only if the residuals are consistent, sum e^2 <= chi2_{n-2}(1 - 10^-3) sigma_n^2; otherwise
the sample whose removal leaves a line (the oldest if none does) is dropped and the start waits
for the next one: an outlier (>= 10 sigma) cannot lock the gate onto itself. The price: d starts
at 0.6 sigma_n^2 instead of the median's ~0.3 (plus its lag). An optional rate prior enters as a
pseudo-measurement v = 0.
2. The gate uses the innovation variance of the time-varying filter, j = m + 1 predictions after
update k, from the tabulated posterior covariance P_k (not the steady state):

    S = P_dd + 2 j P_dv + j^2 P_vv + q sum_{i<j} (i + 1/2)^2 + sigma_n^2    (Q36 tables)   (eq. K.6)

3. An unconfirmed start (no update accepted since it, k = 0) whose gate refuses n samples in a
row that pass the start's line test restarts on them instead of waiting 3 s: such a start is no
better than a new one (left: a start whose slope was > 3 sigma off, which the gate, growing by
3 sqrt(P_vv) per frame, never catches). A start that then holds does this only after n refusals,
each with probability p_g = outlier rate + 2 Phi(-3) (0.023 in the track test): p_g^n = 6e-9
per frame for n = 5 (n = 3: 1e-5) before the line test. Not for confirmed tracks (measured: armed
while the gains were still the start's, it followed consistent wrong matches in akashi-crossing,
29 false T fixes at 3-4 km; and a glint burst is as self-consistent as the truth).      (eq. K.7)

Reported sigma (`sigma_px`), every term from the design:

    sigma^2 = c^2 (P_k + C_m - C_0) + sigma_floor^2 + LSB^2 / 12                        (eq. K.1)

P_k + C_m - C_0 the variance of d coasted m frames from the covariance of update k (eq. K.6 with
j = m, without sigma_n^2), sigma_floor the matcher's sub-pixel bias bound (a systematic error the
filter passes at DC gain 1), LSB^2/12 the Q8 rounding of the output, c the coverage factor (1 by default).
The steady-state error of d is a Gaussian sequence with lag-1 correlation

    rho1 = ((I - K H) F P)_dd / P_dd,   from e' = (I - K H)(F e - w) + K n               (eq. K.2)

With c = 1, sigma is an honest 1-sigma and, being Gaussian, the error leaves +-3 sigma in about
0.27 % of frames (fewer here: the design's sigma_a exceeds a ship's d''). A track test asking
for *no* estimate beyond 3 sigma in 10^5 frames needs more: by Rice's formula a stationary
Gaussian sequence leaves +-u sigma about N arccos(rho1)/pi exp(-u^2/2) times in N frames, so
bound_s > 0 sets N = bound_s fs and

    c = max(1, sqrt(2 ln(N arccos(rho1) / (pi bound_risk))) / 3)                          (eq. K.3)

which makes 3 sigma a bound over a bound_s long track, broken with probability bound_risk; it
is a statement about the track's length and risk, not a tuning constant (c ~ 1.5 for 600 s, 5 %).
For reports, `accel_lag_px` is the alpha-beta lag to a *sustained* d'' = sigma_a,

    lag = sigma_a T^2 (1 - alpha) / beta  (~ sigma_meas for small tracking index)         (eq. K.4)

It is not added: sigma_a is a white-noise level (already in P_k), tuned well above a ship's
real d'', and the sustained-acceleration reading would make sigma ~4x the observed error.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from bisect import bisect_left
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from edge.core.fixedpoint import AB_BITS, SUBPIX_BITS, VAR_BITS, div_round, round_shift, to_q

MAX_TABLE = 20000
Q8_ROUNDING_VAR = 1.0 / (12 * (1 << SUBPIX_BITS) ** 2)   # output rounded to 1/256 px: uniform, var LSB^2/12
COV_BITS = 36                  # Q36 px^2 covariance tables of the gate (int64 for coasts up to ~10^3 frames)
START_RISK = 1e-3              # a consistent start is refused (and waits one frame) with this probability


@dataclass(frozen=True)
class KalmanDesign:
    """Gain/variance tables of one filter setting (build with `design_kalman`)."""

    fs_hz: float
    sigma_meas_px: float
    sigma_accel_pxps2: float
    sigma_floor_px: float
    gate_sigma: float
    reacquire_frames: int
    init_samples: int
    start_var: float           # variance of d right after (re)initialisation (px^2)
    alpha: np.ndarray          # float gains per k
    beta: np.ndarray
    alpha_q24: tuple[int, ...]
    beta_q24: tuple[int, ...]
    pred_var: np.ndarray       # predicted variance of d before update k (px^2)
    post_var: np.ndarray       # variance of d after update k
    # posterior covariance after k updates (k = 0: the start, eq. K.5) as (P_dd, 2 P_dv, P_vv), float
    # and Q36, and the process noise q_j that j predictions add to P_dd (eq. K.6)
    cov: np.ndarray
    cov_q36: tuple[tuple[int, int, int], ...]
    coast_q: np.ndarray
    coast_q_q36: tuple[int, ...]
    r_q36: int
    gate2_q8: int              # gate_sigma^2 in Q8
    pred_env_q36: tuple[int, ...]          # running minimum of pred_var (Q36) for the rewind search
    start_chi2_q16: int        # eq. K.5: the start's residual sum of squares must stay below this
    prior_gain_q24: tuple[int, int]        # the rate prior as a pseudo-measurement v = 0: (g_d, g_v)
    prior_gain: tuple[float, float]
    young_updates: int         # restart on consistent refused samples armed while k < this (eq. K.7)
    rho1: float = 1.0          # lag-1 correlation of the steady-state error of d (eq. K.2)
    coverage: float = 1.0      # factor on the random part of sigma_px (eq. K.3); 1 = plain 1-sigma
    accel_lag_px: float = 0.0  # steady-state lag if d'' = sigma_a were sustained (eq. K.4), for reports

    def table_index(self, k: int) -> int:
        return min(k, len(self.alpha) - 1)


def design_kalman(fs_hz: float, sigma_meas_px: float, sigma_accel_pxps2: float, *,
                  rate_prior_pxps: float | None = None, sigma_floor_px: float = 0.01, gate_sigma: float = 3.0,
                  reacquire_s: float = 3.0, init_samples: int = 5, bound_s: float = 0.0,
                  bound_risk: float = 0.01, young_restart: bool = True) -> KalmanDesign:
    """Run the Riccati recursion of the CV model from the line-fit start to its steady state and
    tabulate it.

    rate_prior_pxps: None (default) starts from the line fit alone; a value is the 1-sigma of the
    disparity rate a new track may have, applied to the fit as a pseudo-measurement v = 0.
    sigma_floor_px: systematic error the filter cannot average away (the matcher's sub-pixel
    bias bound); added in quadrature to the reported sigma, not to the gains.
    bound_s, bound_risk: 0 (default) reports the plain 1-sigma. bound_s > 0 scales the random
    part of the reported sigma by the coverage factor of eq. K.3, so that 3 sigma_px bounds
    every estimate of a bound_s long track except with probability bound_risk.
    young_restart: restart an unconfirmed start on n consistent refused samples (eq. K.7)."""
    if fs_hz <= 0 or sigma_meas_px <= 0 or sigma_accel_pxps2 <= 0:
        raise ValueError("fs_hz, sigma_meas_px and sigma_accel_pxps2 must be positive")
    if init_samples < 3:
        raise ValueError("init_samples must be >= 3 (a line fit with a residual test)")
    r = sigma_meas_px**2
    q = (sigma_accel_pxps2 / fs_hz**2) ** 2
    f = np.array([[1.0, 1.0], [0.0, 1.0]])
    qm = q * np.array([[0.25, 0.5], [0.5, 1.0]])
    n = init_samples
    sxx, lag = n * (n * n - 1) / 12.0, (n - 1) / 2.0         # eq. K.5: LS line, d at the last sample
    p = r * np.array([[1.0 / n + lag * lag / sxx, lag / sxx], [lag / sxx, 1.0 / sxx]])
    gain = np.zeros(2)
    if rate_prior_pxps is not None:
        gain = p[:, 1] / (p[1, 1] + (rate_prior_pxps / fs_hz) ** 2)
        p = p - np.outer(gain, p[1, :])
    cov = [p.copy()]
    alpha, beta, pred, post = [], [], [], []
    for _ in range(MAX_TABLE):
        pp = f @ p @ f.T + qm
        s = pp[0, 0] + r
        k = pp[:, 0] / s
        p = pp - np.outer(k, pp[0, :])
        alpha.append(k[0])
        beta.append(k[1])
        pred.append(pp[0, 0])
        post.append(p[0, 0])
        cov.append(p.copy())
        if len(alpha) > 10 and abs(alpha[-1] - alpha[-2]) < 1e-10 * alpha[-1] and \
                abs(beta[-1] - beta[-2]) < 1e-10 * beta[-1]:
            break
    reacquire = max(1, int(round(reacquire_s * fs_hz)))
    pred_arr = np.array(pred)
    # eq. K.2: steady-state error e' = (I - K H) F e + ..., so E[e'_d e_d] = ((I - K H) F P)_dd
    i_kh = np.eye(2) - np.outer([alpha[-1], beta[-1]], [1.0, 0.0])
    rho1 = float(np.clip((i_kh @ f @ p)[0, 0] / p[0, 0], -1.0, 1.0))
    coverage = 1.0
    if bound_s > 0:
        # eq. K.3 (Rice): a stationary Gaussian sequence with lag-1 correlation rho1 leaves the band
        # +-u sigma about N arccos(rho1) / pi * exp(-u^2 / 2) times in N frames; set that to the risk
        excursions = bound_s * fs_hz * np.arccos(rho1) / np.pi
        coverage = max(1.0, float(np.sqrt(2.0 * np.log(max(excursions / bound_risk, 1.0)))) / 3.0)
    # eq. K.4: a sustained d'' = a leaves the alpha-beta filter a T^2 (1 - alpha) / beta behind
    accel_lag = sigma_accel_pxps2 / fs_hz**2 * (1.0 - alpha[-1]) / beta[-1]
    g2 = gate_sigma**2
    # eq. K.6: j predictions after update k: P_dd + 2 j P_dv + j^2 P_vv + q sum_{i<j} (i + 1/2)^2
    cov3 = np.array([[c[0, 0], 2 * c[0, 1], c[1, 1]] for c in cov])
    coast_q = q * np.concatenate([[0.0], np.cumsum((np.arange(reacquire + 2) + 0.5) ** 2)])
    young = 1 if young_restart else 0                                            # eq. K.7: k = 0 only
    chi2_lim = float(chi2.isf(START_RISK, n - 2)) * r
    return KalmanDesign(fs_hz, sigma_meas_px, sigma_accel_pxps2, sigma_floor_px, gate_sigma, reacquire,
                        init_samples, float(cov3[0, 0]), np.array(alpha), np.array(beta),
                        tuple(to_q(a, AB_BITS) for a in alpha), tuple(to_q(b, AB_BITS) for b in beta),
                        pred_arr, np.array(post), cov3,
                        tuple(tuple(to_q(x, COV_BITS) for x in c) for c in cov3),
                        coast_q, tuple(to_q(x, COV_BITS) for x in coast_q), to_q(r, COV_BITS), to_q(g2, 8),
                        tuple(to_q(x, COV_BITS) for x in np.minimum.accumulate(pred_arr)),
                        to_q(chi2_lim, VAR_BITS), (to_q(gain[0], AB_BITS), to_q(gain[1], AB_BITS)),
                        (float(gain[0]), float(gain[1])), young, rho1, coverage, float(accel_lag))


@dataclass(frozen=True)
class Estimate:
    """Filter output after one frame. valid is False until the track is (re)initialised."""

    valid: bool
    disparity_px: float
    rate_pxps: float
    sigma_px: float
    accepted: bool          # this frame's measurement passed the gate
    misses: int             # consecutive frames without an accepted measurement
    disparity_q8: int | None = None


class _CVFilter(ABC):
    """State machine shared by the integer filter and its float reference."""

    def __init__(self, design: KalmanDesign) -> None:
        self.design = design
        self._init: list[tuple[int, object]] = []     # (frame, measurement) while (re)starting
        self._gated: list[tuple[int, object]] = []    # gated samples since the last accepted one
        self._frame = 0
        self.k = 0
        self.misses = 0
        self.running = False

    # arithmetic supplied by the subclasses -------------------------------------------------
    @abstractmethod
    def _quantise(self, z_px: float) -> object:
        """Measurement in the filter's number format."""

    @abstractmethod
    def _line(self, samples: list[tuple[int, object]]) -> tuple[object, object, float]:
        """Least-squares line through the (frame, measurement) samples (eq. K.5): d at the last
        frame, slope v, residual sum of squares in Q16 px^2."""

    @abstractmethod
    def _set_start(self, d_last: object, v: object) -> None:
        """State from the line fit, with the rate prior's pseudo-measurement v = 0 if any."""

    @abstractmethod
    def _predict(self) -> None:
        """d += v."""

    @abstractmethod
    def _residual(self, z: object) -> tuple[object, int]:
        """(residual, its square in Q16 px^2)."""

    @abstractmethod
    def _correct(self, residual: object, k: int) -> None:
        """d += alpha_k r, v += beta_k r."""

    @abstractmethod
    def _output(self, accepted: bool) -> Estimate:
        """The current estimate."""

    def _try_start(self, samples: list[tuple[int, object]]) -> bool:
        """(Re)start from the samples if they lie on a line (eq. K.5); else drop the one whose
        removal leaves a line (the largest residual can be a good sample next to an outlier), or,
        if there is none (two outliers), the oldest."""
        d_last, v, sse = self._line(samples)
        if sse > self.design.start_chi2_q16:
            loo = [self._line(samples[:i] + samples[i + 1:])[2] for i in range(len(samples))]
            best = min(range(len(samples)), key=loo.__getitem__)
            del samples[best if loo[best] <= self.design.start_chi2_q16 else 0]
            return False
        self._set_start(d_last, v)
        self.running, self.k, self.misses = True, 0, 0
        self._init, self._gated = [], []
        return True

    def update(self, z_px: float | None) -> Estimate:
        """One frame: a disparity measurement in px, or None/NaN when the matcher had none."""
        d = self.design
        self._frame += 1
        have = z_px is not None and bool(np.isfinite(z_px))
        if not self.running:
            if have:
                self._init.append((self._frame, self._quantise(float(z_px))))
                self._init = self._init[-d.init_samples:]
            if len(self._init) < d.init_samples or not self._try_start(self._init):
                return Estimate(False, float("nan"), float("nan"), float("inf"), have, 0)
            return self._output(True)
        self._predict()
        accepted = False
        if have:
            z = self._quantise(float(z_px))
            residual, r2_q16 = self._residual(z)
            if r2_q16 <= self._gate_threshold_q16():
                if self.misses:
                    self.k = min(self.k, self._rewind())
                self._correct(residual, d.table_index(self.k))
                self.k += 1
                self.misses = 0
                self._gated = []
                accepted = True
            elif self.k < d.young_updates:
                # eq. K.7: an unconfirmed start whose gate refuses n samples on a line restarts on them
                self._gated.append((self._frame, z))
                if len(self._gated) == d.init_samples and self._try_start(self._gated):
                    return self._output(True)
        if not accepted:
            self.misses += 1
            if self.misses > d.reacquire_frames:
                self.running = False
                self._init, self._gated = [], []
                return Estimate(False, float("nan"), float("nan"), float("inf"), False, self.misses)
        return self._output(accepted)

    def _coast_var_q36(self, k: int | None = None) -> int:
        """Predicted variance of d (Q36 px^2) for the coming update, eq. K.6: j = misses + 1
        predictions after the k-th update (default: this track's), from that update's covariance."""
        d = self.design
        pdd, pdv2, pvv = d.cov_q36[min(self.k if k is None else k, len(d.cov_q36) - 1)]
        j = self.misses + 1
        return pdd + j * pdv2 + j * j * pvv + d.coast_q_q36[min(j, len(d.coast_q_q36) - 1)]

    def _gate_threshold_q16(self) -> int:
        """gate_sigma^2 S in Q16 px^2, S the innovation variance of the coming update (eq. K.6)."""
        d = self.design
        return round_shift(d.gate2_q8 * (self._coast_var_q36() + d.r_q36), COV_BITS + 8 - VAR_BITS)

    def _rewind(self) -> int:
        """The first k whose predicted variance is no larger than a *steady-state* track's coasted
        one: the table maps only the variance of d, and a young track's coast, mostly d uncertainty,
        would land on the start's gains (k = 0), which move v as if it were unknown."""
        c = self._coast_var_q36(len(self.design.cov_q36) - 1)
        return bisect_left(self.design.pred_env_q36, -c, key=lambda x: -x)

    def sigma_px(self) -> float:
        """Predicted 1-sigma of the current estimate (grows while coasting, eq. K.6)."""
        d = self.design
        pdd, pdv2, pvv = d.cov[min(self.k, len(d.cov) - 1)]
        m = self.misses
        var = pdd + m * pdv2 + m * m * pvv + d.coast_q[min(m, len(d.coast_q) - 1)]
        # eq. K.1: random part (times the coverage factor, eq. K.3), bias floor, Q8 output rounding
        var = d.coverage**2 * var + d.sigma_floor_px**2 + Q8_ROUNDING_VAR
        return float(np.sqrt(var))


class DisparityKalman(_CVFilter):
    """Integer filter: Q8 measurements, Q24 state and gains, Q16 gate (the product path)."""

    def __init__(self, design: KalmanDesign) -> None:
        super().__init__(design)
        self.d_q24 = 0
        self.v_q24 = 0

    def _quantise(self, z_px: float) -> int:
        return to_q(z_px, SUBPIX_BITS)

    def _line(self, samples: list[tuple[int, object]]) -> tuple[int, int, int]:
        # u_i = n t_i - sum t (integer), slope = n sum(u z) / sum(u^2), d at the last frame (eq. K.5)
        n, t_last = len(samples), samples[-1][0]
        t_sum = sum(t for t, _ in samples)
        z_sum = sum(int(z) for _, z in samples)
        uu = sum((n * t - t_sum) ** 2 for t, _ in samples)
        uz = sum((n * t - t_sum) * int(z) for t, z in samples)
        shift = AB_BITS - SUBPIX_BITS
        v = div_round((n * uz) << shift, uu)                                              # Q24 px/frame
        dl = div_round((z_sum << shift) + v * (n * t_last - t_sum), n)                      # Q24 px
        res = [round_shift((int(z) << shift) - dl - v * (t - t_last), shift) for t, z in samples]   # Q8
        return dl, v, sum(e * e for e in res)                                               # Q16

    def _set_start(self, d_last: object, v: object) -> None:
        gd, gv = self.design.prior_gain_q24
        self.d_q24 = int(d_last) - round_shift(gd * int(v), AB_BITS)
        self.v_q24 = int(v) - round_shift(gv * int(v), AB_BITS)

    def _predict(self) -> None:
        self.d_q24 += self.v_q24

    def _residual(self, z: object) -> tuple[int, int]:
        residual = (int(z) << (AB_BITS - SUBPIX_BITS)) - self.d_q24                      # Q24
        r_q8 = round_shift(residual, AB_BITS - SUBPIX_BITS)
        return residual, r_q8 * r_q8                                                        # Q16

    def _correct(self, residual: object, k: int) -> None:
        r = int(residual)
        self.d_q24 += round_shift(self.design.alpha_q24[k] * r, AB_BITS)
        self.v_q24 += round_shift(self.design.beta_q24[k] * r, AB_BITS)

    def _output(self, accepted: bool) -> Estimate:
        q8 = round_shift(self.d_q24, AB_BITS - SUBPIX_BITS)
        rate = self.v_q24 / float(1 << AB_BITS) * self.design.fs_hz
        return Estimate(True, q8 / float(1 << SUBPIX_BITS), rate, self.sigma_px(), accepted, self.misses, q8)


class DisparityKalmanFloat(_CVFilter):
    """Float64 reference with the same tables (float gains) and the same decisions."""

    def __init__(self, design: KalmanDesign) -> None:
        super().__init__(design)
        self.d = 0.0
        self.v = 0.0

    def _quantise(self, z_px: float) -> float:
        return to_q(z_px, SUBPIX_BITS) / float(1 << SUBPIX_BITS)     # the same Q8 input

    def _line(self, samples: list[tuple[int, object]]) -> tuple[float, float, float]:
        t = np.array([s[0] for s in samples], dtype=float)
        z = np.array([float(s[1]) for s in samples])
        tc = t - t.mean()
        v = float(tc @ z / (tc @ tc))
        dl = float(z.mean() + v * (t[-1] - t.mean()))
        res = z - dl - v * (t - t[-1])
        return dl, v, float(res @ res) * (1 << VAR_BITS)

    def _set_start(self, d_last: object, v: object) -> None:
        gd, gv = self.design.prior_gain
        self.d, self.v = float(d_last) - gd * float(v), float(v) - gv * float(v)

    def _predict(self) -> None:
        self.d += self.v

    def _residual(self, z: object) -> tuple[float, float]:
        residual = float(z) - self.d
        return residual, residual * residual * (1 << VAR_BITS)

    def _correct(self, residual: object, k: int) -> None:
        self.d += self.design.alpha[k] * float(residual)
        self.v += self.design.beta[k] * float(residual)

    def _output(self, accepted: bool) -> Estimate:
        return Estimate(True, self.d, self.v * self.design.fs_hz, self.sigma_px(), accepted, self.misses)
