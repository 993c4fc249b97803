"""Default disparity filter: constant-velocity Kalman on disparity as a table-driven alpha-beta
filter in Q24 fixed point, with a float reference, a 3-sigma innovation gate, coasting,
re-acquisition after a gap and a robust start (research note §2.3).

Why: the Butterworth (eq. 6.1) lags an approaching ship by tau * d' and passes outliers; a CV
model has no ramp lag, and gating on the innovation drops glints and fog jumps (note §2.4).

The model (per-frame units, v in px/frame): x = [d, v], F = [[1, 1], [0, 1]], white
acceleration with Q = q [[1/4, 1/2], [1/2, 1]], q = (sigma_a T^2)^2, measurement R = sigma_n^2.
Its covariance does not depend on the data, so `design_kalman` runs the Riccati recursion
once, in float, from the start-up covariance to the steady state and stores the gains
alpha_k, beta_k (Q24) and variances (Q16 px^2) as integer tables indexed by k, the number of
accepted updates since (re)initialisation. The filter itself then only adds, multiplies and
shifts integers:

    predict   d += v                                   (Q24 px, Q24 px/frame; int64)
    residual  r = z - d                                (z in Q8 px, shifted to Q24)
    gate      r^2 > 9 S  ->  reject and coast          (S from the table, grown while coasting)
    correct   d += alpha_k r,  v += beta_k r           (Q24 x Q24 -> round-shift 24)

Missing or gated samples coast on the prediction; the gate and the reported sigma grow with
the coast count m. The first sample accepted after m misses rewinds k to the table entry whose
predicted variance matches the coasted one, so the filter re-converges like a Kalman filter
whose covariance grew. After `reacquire_s` of misses the track restarts. (Re)starts take the
median of `init_samples` samples for d (so one outlier among them cannot lock the gate onto
itself) and v = 0 with a rate prior in the start covariance: a 5-sample slope is noise at
30 fps (sigma 0.03 px/frame for 0.1 px samples), larger than the rates it would estimate.

Reported sigma (`sigma_px`), every term from the design:

    sigma^2 = c^2 (P_k + C_m - C_0) + sigma_floor^2 + LSB^2 / 12                        (eq. K.1)

P_k the Riccati variance of d after update k, C_m the coasted variance after m misses (both
tabulated), sigma_floor the matcher's sub-pixel bias bound (a systematic error the filter passes
at DC gain 1), LSB^2/12 the Q8 rounding of the output, c the coverage factor (1 by default).
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
from dataclasses import dataclass

import numpy as np

from edge.core.fixedpoint import AB_BITS, SUBPIX_BITS, VAR_BITS, round_shift, to_q

MAX_TABLE = 20000
Q8_ROUNDING_VAR = 1.0 / (12 * (1 << SUBPIX_BITS) ** 2)   # output rounded to 1/256 px: uniform, var LSB^2/12


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
    coast_pred: np.ndarray     # steady-state predicted variance of d after m misses, m = 0..
    coast_post: np.ndarray     # variance of the coasted estimate after m misses
    gate_q16: tuple[tuple[int, ...], ...]   # [k or coast m] -> (gate_sigma^2 * S) in Q16
    rewind: tuple[int, ...]    # k to continue with after m misses
    rho1: float = 1.0          # lag-1 correlation of the steady-state error of d (eq. K.2)
    coverage: float = 1.0      # factor on the random part of sigma_px (eq. K.3); 1 = plain 1-sigma
    accel_lag_px: float = 0.0  # steady-state lag if d'' = sigma_a were sustained (eq. K.4), for reports

    def table_index(self, k: int) -> int:
        return min(k, len(self.alpha) - 1)


def design_kalman(fs_hz: float, sigma_meas_px: float, sigma_accel_pxps2: float, *,
                  rate_prior_pxps: float = 1.0, sigma_floor_px: float = 0.01, gate_sigma: float = 3.0,
                  reacquire_s: float = 3.0, init_samples: int = 5, bound_s: float = 0.0,
                  bound_risk: float = 0.01) -> KalmanDesign:
    """Run the Riccati recursion of the CV model to its steady state and tabulate it.

    rate_prior_pxps: 1-sigma of the disparity rate a new track may have (it starts at v = 0).
    sigma_floor_px: systematic error the filter cannot average away (the matcher's sub-pixel
    bias bound); added in quadrature to the reported sigma, not to the gains.
    bound_s, bound_risk: 0 (default) reports the plain 1-sigma. bound_s > 0 scales the random
    part of the reported sigma by the coverage factor of eq. K.3, so that 3 sigma_px bounds
    every estimate of a bound_s long track except with probability bound_risk."""
    if fs_hz <= 0 or sigma_meas_px <= 0 or sigma_accel_pxps2 <= 0:
        raise ValueError("fs_hz, sigma_meas_px and sigma_accel_pxps2 must be positive")
    r = sigma_meas_px**2
    q = (sigma_accel_pxps2 / fs_hz**2) ** 2
    f = np.array([[1.0, 1.0], [0.0, 1.0]])
    qm = q * np.array([[0.25, 0.5], [0.5, 1.0]])
    # start-up covariance: the median of n samples (variance pi/2 * r/n) belongs to the middle
    # sample, (n-1)/2 frames ago, and v = 0 with the rate prior
    n = init_samples
    lag_frames = (n - 1) / 2
    vv = (rate_prior_pxps / fs_hz) ** 2
    p = np.array([[np.pi / 2 * r / n + lag_frames**2 * vv, lag_frames * vv], [lag_frames * vv, vv]])
    p0_dd = float(p[0, 0])
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
        if len(alpha) > 10 and abs(alpha[-1] - alpha[-2]) < 1e-10 * alpha[-1] and \
                abs(beta[-1] - beta[-2]) < 1e-10 * beta[-1]:
            break
    reacquire = max(1, int(round(reacquire_s * fs_hz)))
    coast_pred, coast_post = [pred[-1]], [post[-1]]
    pc = p.copy()                                   # steady-state posterior
    for _ in range(reacquire + 1):
        pc = f @ pc @ f.T + qm
        coast_post.append(pc[0, 0])
        coast_pred.append((f @ pc @ f.T + qm)[0, 0])
    pred_arr = np.array(pred)
    # after m misses continue at the first k whose predicted variance is <= the coasted one
    rewind = tuple(int(np.argmax(pred_arr <= cp)) if cp < pred_arr[0] else 0 for cp in coast_pred)
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
    gate_k = tuple(to_q(g2 * (pv + r), VAR_BITS) for pv in pred)
    gate_m = tuple(to_q(g2 * (cp + r), VAR_BITS) for cp in coast_pred)
    return KalmanDesign(fs_hz, sigma_meas_px, sigma_accel_pxps2, sigma_floor_px, gate_sigma, reacquire,
                        init_samples, p0_dd,
                        np.array(alpha), np.array(beta), tuple(to_q(a, AB_BITS) for a in alpha),
                        tuple(to_q(b, AB_BITS) for b in beta), pred_arr, np.array(post),
                        np.array(coast_pred), np.array(coast_post), (gate_k, gate_m), rewind,
                        rho1, coverage, float(accel_lag))


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
        self._frame = 0
        self.k = 0
        self.misses = 0
        self.running = False

    # arithmetic supplied by the subclasses -------------------------------------------------
    @abstractmethod
    def _quantise(self, z_px: float) -> object:
        """Measurement in the filter's number format."""

    @abstractmethod
    def _start(self, samples: list[tuple[int, object]]) -> None:
        """Initialise d to the median of the (frame, measurement) samples and v to 0."""

    @abstractmethod
    def _predict(self) -> None:
        """d += v."""

    @abstractmethod
    def _gate(self, z: object) -> tuple[object, bool]:
        """(residual, inside the gate)."""

    @abstractmethod
    def _correct(self, residual: object, k: int) -> None:
        """d += alpha_k r, v += beta_k r."""

    @abstractmethod
    def _output(self, accepted: bool) -> Estimate:
        """The current estimate."""

    def update(self, z_px: float | None) -> Estimate:
        """One frame: a disparity measurement in px, or None/NaN when the matcher had none."""
        d = self.design
        self._frame += 1
        have = z_px is not None and bool(np.isfinite(z_px))
        if not self.running:
            if have:
                self._init.append((self._frame, self._quantise(float(z_px))))
                self._init = self._init[-d.init_samples:]
            if len(self._init) < d.init_samples:
                return Estimate(False, float("nan"), float("nan"), float("inf"), have, 0)
            self._start(self._init)
            self._init = []
            self.running, self.k, self.misses = True, 0, 0
            return self._output(True)
        self._predict()
        accepted = False
        if have:
            residual, inside = self._gate(self._quantise(float(z_px)))
            if inside:
                if self.misses:
                    self.k = min(self.k, d.rewind[min(self.misses, len(d.rewind) - 1)])
                self._correct(residual, d.table_index(self.k))
                self.k += 1
                self.misses = 0
                accepted = True
        if not accepted:
            self.misses += 1
            if self.misses > d.reacquire_frames:
                self.running = False
                self._init = []
                return Estimate(False, float("nan"), float("nan"), float("inf"), False, self.misses)
        return self._output(accepted)

    def _gate_threshold_q16(self) -> int:
        d = self.design
        if self.misses:
            m = min(self.misses, len(d.gate_q16[1]) - 1)
            return max(d.gate_q16[1][m], d.gate_q16[0][d.table_index(self.k)])
        return d.gate_q16[0][d.table_index(self.k)]

    def sigma_px(self) -> float:
        """Predicted 1-sigma of the current estimate (grows while coasting)."""
        d = self.design
        var = d.post_var[d.table_index(self.k - 1)] if self.k else d.start_var
        if self.misses:
            m = min(self.misses, len(d.coast_post) - 1)
            var += d.coast_post[m] - d.coast_post[0]
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

    def _start(self, samples: list[tuple[int, object]]) -> None:
        z = sorted(int(s[1]) for s in samples)
        mid = len(z) // 2
        median_q8 = z[mid] if len(z) % 2 else round_shift(z[mid - 1] + z[mid], 1)
        self.d_q24, self.v_q24 = median_q8 << (AB_BITS - SUBPIX_BITS), 0

    def _predict(self) -> None:
        self.d_q24 += self.v_q24

    def _gate(self, z: object) -> tuple[int, bool]:
        residual = (int(z) << (AB_BITS - SUBPIX_BITS)) - self.d_q24                      # Q24
        r_q8 = round_shift(residual, AB_BITS - SUBPIX_BITS)
        return residual, r_q8 * r_q8 <= self._gate_threshold_q16()                          # Q16

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

    def _start(self, samples: list[tuple[int, object]]) -> None:
        self.d, self.v = float(np.median([float(s[1]) for s in samples])), 0.0

    def _predict(self) -> None:
        self.d += self.v

    def _gate(self, z: object) -> tuple[float, bool]:
        residual = float(z) - self.d
        return residual, residual * residual * (1 << VAR_BITS) <= self._gate_threshold_q16()

    def _correct(self, residual: object, k: int) -> None:
        self.d += self.design.alpha[k] * float(residual)
        self.v += self.design.beta[k] * float(residual)

    def _output(self, accepted: bool) -> Estimate:
        return Estimate(True, self.d, self.v * self.design.fs_hz, self.sigma_px(), accepted, self.misses)
