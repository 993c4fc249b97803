"""Default disparity filter: constant-velocity Kalman on disparity as a table-driven alpha-beta
filter in Q24 fixed point, with a float reference, a 3-sigma innovation gate, coasting,
re-acquisition after a gap and a robust line-fit start (research note §2.3).

Why: the Butterworth (eq. 6.1) lags an approaching ship by tau * d' and passes outliers; a CV
model has no ramp lag, and gating on the innovation drops glints and fog jumps (note §2.4).

The model, and its gains and covariances as integer tables indexed by k, the number of accepted
updates since (re)initialisation, come from `edge.core.kalman_design` (`design_kalman`, re-exported
here). The filter itself then only adds, multiplies and shifts integers (and divides twice per start):

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
per frame for n = 5 (n = 3: 1e-5) before the line test. Not for confirmed tracks: armed while
the gains are still the start's, it follows consistent wrong matches (docs/decisions.md), and a
glint burst is as self-consistent as the truth.                                          (eq. K.7)

Reported sigma (`sigma_px`), every term from the design:

    sigma^2 = c^2 g (P_k + C_m - C_0) + sigma_floor^2 + LSB^2 / 12                      (eq. K.1)

P_k + C_m - C_0 the variance of d coasted m frames from the covariance of update k (eq. K.6 with
j = m, without sigma_n^2), sigma_floor the matcher's sub-pixel bias bound (a systematic error the
filter passes at DC gain 1), LSB^2/12 the Q8 rounding of the output, c the coverage factor (1 by default;
eq. K.3 in `edge.core.kalman_design`, from the steady-state error's correlation, eq. K.2), g the
correlated-noise gain of the matcher's error (eq. K.8 there; 1 for white noise).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from bisect import bisect_left
from dataclasses import dataclass

import numpy as np

from edge.core.fixedpoint import AB_BITS, SUBPIX_BITS, VAR_BITS, div_round, round_shift, to_q
from edge.core.kalman_design import COV_BITS, KalmanDesign, design_kalman

__all__ = ["Q8_ROUNDING_VAR", "DisparityKalman", "DisparityKalmanFloat", "Estimate", "KalmanDesign",
           "design_kalman"]

Q8_ROUNDING_VAR = 1.0 / (12 * (1 << SUBPIX_BITS) ** 2)   # output rounded to 1/256 px: uniform, var LSB^2/12


def _sqrt(x: float) -> float:
    """np.sqrt of a Python float without numpy's per-call overhead (both round correctly, IEEE 754);
    NaN for a negative argument as numpy gives it (math.sqrt would raise)."""
    return math.sqrt(x) if x >= 0 else math.nan


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
        self._init: list[tuple[int, float]] = []     # (frame, measurement) while (re)starting
        self._gated: list[tuple[int, float]] = []    # gated samples since the last accepted one
        self._frame = 0
        self.k = 0
        self.misses = 0
        self.running = False

    # arithmetic supplied by the subclasses -------------------------------------------------
    @abstractmethod
    def _quantise(self, z_px: float) -> float:
        """Measurement in the filter's number format."""

    @abstractmethod
    def _line(self, samples: list[tuple[int, float]]) -> tuple[float, float, float]:
        """Least-squares line through the (frame, measurement) samples (eq. K.5): d at the last
        frame, slope v, residual sum of squares in Q16 px^2."""

    @abstractmethod
    def _set_start(self, d_last: float, v: float) -> None:
        """State from the line fit, with the rate prior's pseudo-measurement v = 0 if any."""

    @abstractmethod
    def _predict(self) -> None:
        """d += v."""

    @abstractmethod
    def _residual(self, z: float) -> tuple[float, float]:
        """(residual, its square in Q16 px^2)."""

    @abstractmethod
    def _correct(self, residual: float, k: int) -> None:
        """d += alpha_k r, v += beta_k r."""

    @abstractmethod
    def _output(self, accepted: bool) -> Estimate:
        """The current estimate."""

    def _try_start(self, samples: list[tuple[int, float]]) -> bool:
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
        have = z_px is not None and math.isfinite(z_px)
        if not self.running:
            if have:
                assert z_px is not None  # have
                self._init.append((self._frame, self._quantise(float(z_px))))
                self._init = self._init[-d.init_samples:]
            if len(self._init) < d.init_samples or not self._try_start(self._init):
                return Estimate(False, float("nan"), float("nan"), float("inf"), have, 0)
            return self._output(True)
        self._predict()
        accepted = False
        if have:
            assert z_px is not None  # have
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
        # eq. K.8: the random part for the matcher's correlated error
        var = d.coverage**2 * (d.corr_gain * var) + d.sigma_floor_px**2 + Q8_ROUNDING_VAR
        return _sqrt(var)


class DisparityKalman(_CVFilter):
    """Integer filter: Q8 measurements, Q24 state and gains, Q16 gate (the product path)."""

    def __init__(self, design: KalmanDesign) -> None:
        super().__init__(design)
        self.d_q24 = 0
        self.v_q24 = 0

    def _quantise(self, z_px: float) -> int:
        return to_q(z_px, SUBPIX_BITS)

    def _line(self, samples: list[tuple[int, float]]) -> tuple[int, int, int]:
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

    def _set_start(self, d_last: float, v: float) -> None:
        gd, gv = self.design.prior_gain_q24
        self.d_q24 = int(d_last) - round_shift(gd * int(v), AB_BITS)
        self.v_q24 = int(v) - round_shift(gv * int(v), AB_BITS)

    def _predict(self) -> None:
        self.d_q24 += self.v_q24

    def _residual(self, z: float) -> tuple[int, int]:
        residual = (int(z) << (AB_BITS - SUBPIX_BITS)) - self.d_q24                      # Q24
        r_q8 = round_shift(residual, AB_BITS - SUBPIX_BITS)
        return residual, r_q8 * r_q8                                                        # Q16

    def _correct(self, residual: float, k: int) -> None:
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

    def _line(self, samples: list[tuple[int, float]]) -> tuple[float, float, float]:
        t = np.array([s[0] for s in samples], dtype=float)
        z = np.array([float(s[1]) for s in samples])
        tc = t - t.mean()
        v = float(tc @ z / (tc @ tc))
        dl = float(z.mean() + v * (t[-1] - t.mean()))
        res = z - dl - v * (t - t[-1])
        return dl, v, float(res @ res) * (1 << VAR_BITS)

    def _set_start(self, d_last: float, v: float) -> None:
        gd, gv = self.design.prior_gain
        self.d, self.v = float(d_last) - gd * float(v), float(v) - gv * float(v)

    def _predict(self) -> None:
        self.d += self.v

    def _residual(self, z: float) -> tuple[float, float]:
        residual = float(z) - self.d
        return residual, residual * residual * (1 << VAR_BITS)

    def _correct(self, residual: float, k: int) -> None:
        self.d += self.design.alpha[k] * float(residual)
        self.v += self.design.beta[k] * float(residual)

    def _output(self, accepted: bool) -> Estimate:
        return Estimate(True, self.d, self.v * self.design.fs_hz, self.sigma_px(), accepted, self.misses)
