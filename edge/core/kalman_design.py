"""Design of the default disparity filter (`edge.core.kalman`): the gain, covariance and gate tables
of the constant-velocity model, and the coverage factor of its reported sigma.

Why a separate design step: the filter's covariance does not depend on the data, so everything
the Kalman recursion would compute per frame is computed here once, in float, and the streaming
filter only looks it up (integers in the hot path).

The model (per-frame units, v in px/frame): x = [d, v], F = [[1, 1], [0, 1]], white
acceleration with Q = q [[1/4, 1/2], [1/2, 1]], q = (sigma_a T^2)^2, measurement R = sigma_n^2.
`design_kalman` runs the Riccati recursion from the start-up covariance (eq. K.5) to the steady
state and stores the gains alpha_k, beta_k (Q24) and covariances (Q36 px^2) as integer tables
indexed by k, the number of accepted updates since (re)initialisation, with the coast terms of
the gate's innovation variance (eq. K.6) and the start's residual limit.

The steady-state error of d is a Gaussian sequence with lag-1 correlation

    rho1 = ((I - K H) F P)_dd / P_dd,   from e' = (I - K H)(F e - w) + K n               (eq. K.2)

With c = 1, the reported sigma (eq. K.1) is an honest 1-sigma and, being Gaussian, the error leaves
+-3 sigma in about 0.27 % of frames (fewer here: the design's sigma_a exceeds a ship's d''). A track
test asking for *no* estimate beyond 3 sigma in 10^5 frames needs more: by Rice's formula a stationary
Gaussian sequence leaves +-u sigma about N arccos(rho1)/pi exp(-u^2/2) times in N frames, so
bound_s > 0 sets N = bound_s fs and

    c = max(1, sqrt(2 ln(N arccos(rho1) / (pi bound_risk))) / 3)                          (eq. K.3)

which makes 3 sigma a bound over a bound_s long track, broken with probability bound_risk; it
is a statement about the track's length and risk, not a tuning constant (c ~ 1.5 for 600 s, 5 %).
For reports, `accel_lag_px` is the alpha-beta lag to a *sustained* d'' = sigma_a,

    lag = sigma_a T^2 (1 - alpha) / beta  (~ sigma_meas for small tracking index)         (eq. K.4)

It is not added: sigma_a is a white-noise level (already in P_k), tuned well above a ship's
real d'', and the sustained-acceleration reading would make sigma ~4x the observed error.

The matcher's error is not white: it follows the window's texture as the ship's pose changes, so
successive pairs at 10 fps share much of it, at 1 fps hardly any. Modelled as AR(1) with lag-1
correlation rho = exp(-1 / (fs corr_s)), the error the (white-model) gains leave in steady state
follows from the discrete Lyapunov equation of the augmented state [e_d, e_v, n],

    x' = [[(I - K H) F, K rho], [0, rho]] x + sqrt(1 - rho^2) [K; 1] xi
    corr_gain = Var_AR(e_d) / Var_white(e_d),  both for var(n) = sigma_meas^2              (eq. K.8)

The reported variance is P_k times corr_gain: ~1 at 1 fps, 2-4 at 10 fps for the deep designs,
which average over many correlated samples. (Compared at the same difference variance, which the
track's scatter measures, no correlation time fitted the recordings: at 0.15 s approach-720 had
1.54 RMS(e / sigma) and 91 % within 3 sigma while small-boat-fog fell to 0.53. The error is not one
AR(1) process, and the ladder's rung already sits above the scatter. corr_s is therefore a
fitted figure, docs/decisions.md. `edge.measure.filter_designs` adds, for a design below the configured
acceleration, the share rho of the configured design's steady-state variance as a floor.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_discrete_lyapunov
from scipy.stats import chi2

from edge.core.fixedpoint import AB_BITS, VAR_BITS, to_q

MAX_TABLE = 20000
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
    corr_gain: float = 1.0     # eq. K.8: error variance for AR(1) measurement noise over the white model's
    corr_rho: float = 0.0      # lag-1 correlation of that measurement noise, exp(-1 / (fs corr_s))

    def table_index(self, k: int) -> int:
        return min(k, len(self.alpha) - 1)


def design_kalman(fs_hz: float, sigma_meas_px: float, sigma_accel_pxps2: float, *,
                  rate_prior_pxps: float | None = None, sigma_floor_px: float = 0.01, gate_sigma: float = 3.0,
                  reacquire_s: float = 3.0, init_samples: int = 5, bound_s: float = 0.0,
                  bound_risk: float = 0.01, young_restart: bool = True, corr_s: float = 0.0) -> KalmanDesign:
    """Run the Riccati recursion of the CV model from the line-fit start to its steady state and
    tabulate it.

    rate_prior_pxps: None (default) starts from the line fit alone; a value is the 1-sigma of the
    disparity rate a new track may have, applied to the fit as a pseudo-measurement v = 0.
    sigma_floor_px: systematic error the filter cannot average away (the matcher's sub-pixel
    bias bound); added in quadrature to the reported sigma, not to the gains.
    bound_s, bound_risk: 0 (default) reports the plain 1-sigma. bound_s > 0 scales the random
    part of the reported sigma by the coverage factor of eq. K.3, so that 3 sigma_px bounds
    every estimate of a bound_s long track except with probability bound_risk.
    young_restart: restart an unconfirmed start on n consistent refused samples (eq. K.7).
    corr_s: correlation time of the measurement error (s); > 0 scales the reported variance by
    eq. K.8's corr_gain (the gains stay the white model's)."""
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
    corr_rho = float(np.exp(-1.0 / (fs_hz * corr_s))) if corr_s > 0 else 0.0
    corr_gain = correlated_noise_gain(alpha[-1], beta[-1], corr_rho)
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
                        tuple(tuple(to_q(x, COV_BITS) for x in c) for c in cov3),  # type: ignore[misc]  # rows of 3
                        coast_q, tuple(to_q(x, COV_BITS) for x in coast_q), to_q(r, COV_BITS), to_q(g2, 8),
                        tuple(to_q(x, COV_BITS) for x in np.minimum.accumulate(pred_arr)),
                        to_q(chi2_lim, VAR_BITS), (to_q(gain[0], AB_BITS), to_q(gain[1], AB_BITS)),
                        (float(gain[0]), float(gain[1])), young, rho1, coverage, float(accel_lag),
                        corr_gain, corr_rho)


def _ar1_error_var(a: float, b: float, rho: float) -> float:
    """Steady-state variance of d's error for the alpha-beta gains (a, b) driven by AR(1) measurement
    noise of lag-1 correlation rho and unit variance (eq. K.8)."""
    k = np.array([a, b])
    m = np.zeros((3, 3))
    m[:2, :2] = (np.eye(2) - np.outer(k, [1.0, 0.0])) @ np.array([[1.0, 1.0], [0.0, 1.0]])
    m[:2, 2], m[2, 2] = k * rho, rho
    g = np.sqrt(1.0 - rho * rho) * np.array([a, b, 1.0])   # n' = rho n + sqrt(1 - rho^2) xi, var(n) = 1
    p = solve_discrete_lyapunov(m, np.outer(g, g))
    return float(p[0, 0])


def correlated_noise_gain(a: float, b: float, rho: float) -> float:
    """eq. K.8: the error variance the gains leave when the measurement noise is AR(1) with lag-1
    correlation rho, over the white model's, both for the same noise variance (the design's
    sigma_meas). 1 for rho = 0."""
    return _ar1_error_var(a, b, rho) / _ar1_error_var(a, b, 0.0)

