"""Shift-and-refit: a second sub-pixel stage that removes most of what is left of pixel locking
by resampling the right image at a first estimate and refitting the small residual around zero.

Why: every 3-point fit of a sampled cost curve has an error e(f) that depends on the fractional
disparity f (pixel locking) and vanishes at f = 0 by symmetry. The half-pixel passes of
`subpixel.py` cancel its odd harmonics only in part (their [1 1] kernel weights the spectrum
unlike the integer passes; docs/limits.md "Matcher vs theory"). Here the right band is resampled so that
the remaining disparity is near zero, and eq. 5.2 on -log NCC (the Gaussian model of
`subpixel.gauss_fit_q`) is fitted around zero, where its locking error is ~slope x residual:

    Rs(x) = R(x - s),  s = the first estimate (Q8: n whole pixels + phase p/256)
    LR fit: template L(x), candidates Rs(x - k), k = -1, 0, 1   -> rL ~ d - s
    RL fit: template Rs(x), candidates L(x - k)                  -> rR ~ s - d
    d = s + (rL - rR) / 2

A finite window's correlation peak is not symmetric (its edge columns), which shifts each fit
by a per-texture constant of ~0.02 px; in the RL fit it has the other sign, so the average
removes it. Why not Gauss-Newton on interpolated samples (lab/bench/subpix_study.py): there
the interpolator's phase error at fractional positions is the estimate's error, and short
kernels (linear, Keys, Lanczos-3) have too much of it; here an 8-tap kernel carries it, and
only the right image is resampled, so the left one keeps its noise unfiltered.

Interpolator: 8-tap Kaiser-windowed sinc (beta 6, half-width 4), as video codecs do it:
`taps_q14()[p]` holds the taps for the phase p/256, each row summing to exactly 2^14 (an
offset stays an offset). Beta and length were chosen on the tuning seeds (5000+) during
development: a flatter passband (beta 4-5) was better on smooth texture and worse on the
aliased "sharp" condition, beta 6 better than the six passes on both, 10-12 taps worse on
aliased texture.

Smoothing (lead "(c)" of the CRB work: noise-dependent): what the refit leaves at low noise is
mostly aliasing (pixels integrate a scene with detail above Nyquist, so no interpolator can
reproduce the other view exactly), a per-texture error the noise does not average out. Where
the predicted sigma is small (REFIT_SMOOTH_MAX_SIGMA_PX) both views are filtered by
[1 6 1]/8 before the fits, which weights the aliased band down for a little more noise, unless
the aligned centre windows differ by more than MISMATCH_FACTOR times what the noise explains
(a vertical offset between the views: 0.25 px trips it, the aliased texture of bench-core's
"sharp" condition does not), where smoothing makes it worse
(`_mismatched`; then the unsmoothed refit). tools/bench-core --sections study has the
variants (never / always / by sigma only).

Integer form: `_stage_matrix` maps [L band | R band | 1] in one product to [L | Rs | 1]: L as is
or filtered (Q3), Rs the interpolated (and filtered) right band, Q14 (Q17) taps scaled to Q8 DN
and rounded once (|Rs| < 2^17, exact in float64). Every window sum (S1, S2 of each window, the
cross sums) is one entry sum of the Gram matrix of [L | Rs | 1], exact integers below 2^53
(N S2 < 2^50). Per fit, the N-scaled energies E(k) = N S2 - S1^2 and cross terms
X(k) = N sum T C - S1_T S1_C are Python ints; the first and second differences of
y = log2 E - 2 log2 X are the logs of two exact Q40 quotients (`_fit_q`, `fixedpoint.log2_q_int`,
Q24), one division to Q10 per fit, and s + (rL - rR) / 2 is formed in Q11 and rounded
once to Q8. Float reference: float taps at the unrounded shift, float filter, sums and
math.log2. Difference: 2^-11 (fits) + 2^-9 (final rounding) + the rounding of Rs (far below
the noise) < 1/256 px; the refit moves by a small fraction of a change in s, so the float's
unrounded s adds little (tests/lab/subpix/test_refit.py).
Needs left columns xl - h - 1 - e .. xl + h + 1 + e and right columns xr - h - 5 - e ..
xr + h + 4 + e (xr = xl - n, e = 1 with smoothing); `refit_q8` returns None when the bands do
not hold them or a fit has no interior minimum.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from edge.core.fixedpoint import (
    FIT_BITS,
    LOG_BITS,
    SUBPIX_BITS,
    div_round,
    log2_q_int,
    round_shift,
)
from edge.core.match import CostArithmetic, refine
from edge.core.subpixel import gauss_fit_float

REFIT_MAX_SIGMA_PX = 0.08          # match_point(subpixel="refit") refits only up to this predicted sigma
REFIT_SMOOTH_MAX_SIGMA_PX = 0.01   # ... and smooths both views by [1 6 1]/8 up to this one
PHASE_BITS = 8                    # the applied shift s in Q8 (1/256 px, the first estimate itself)
TAP_BITS = 14                     # Q14 interpolation taps
RS_BITS = 8                       # resampled right band in Q8 DN
HALF_TAPS = 4                     # 8 taps: j = -4 .. 3
KAISER_BETA = 6.0
SMOOTHED_NOISE_GAIN = 38 / 64     # noise variance through [1 6 1]/8
MISMATCH_FACTOR = 8.0             # smoothing only where the views match to 8x the noise (doc)
_J = np.arange(-HALF_TAPS, HALF_TAPS)


def kernel_float(q: float) -> np.ndarray:
    """Taps c_j (j = -4..3) that sample a row at x - q for 0 <= q < 1: sum_j c_j R(x + j)
    ~ R(x - q); Kaiser-windowed sinc, normalised to sum 1."""
    t = _J + q                                          # distance of tap j from x - q
    window = np.i0(KAISER_BETA * np.sqrt(np.clip(1.0 - (t / HALF_TAPS) ** 2, 0.0, None)))
    taps = np.sinc(t) * window
    return taps / taps.sum()


@functools.cache
def taps_q14() -> np.ndarray:
    """(64, 8) int64 table: row p is `kernel_float(p / 64)` in Q14, rounded, with the rounding
    residue put on the largest tap so every row sums to exactly 2^14."""
    table = np.rint(np.stack([kernel_float(p / (1 << PHASE_BITS)) for p in range(1 << PHASE_BITS)])
                    * (1 << TAP_BITS)).astype(np.int64)
    rows = np.arange(table.shape[0])
    table[rows, np.argmax(table, axis=1)] += (1 << TAP_BITS) - table.sum(axis=1)
    return table


@functools.cache
def _interp_matrix(p: int, ncols: int, smooth: bool) -> np.ndarray:
    """Band columns c - 4 .. c + ncols + 2 times this (ncols + 7, ncols') float64 matrix give
    the band sampled at c - p/256 .. in Q14 (ncols' = ncols), or with `smooth` then filtered
    by [1 6 1] in Q17 (ncols' = ncols - 2, from c + 1 - p/256); exact integer entries."""
    m = _banded(taps_q14()[p].astype(np.float64), ncols)
    return m @ _smoother(ncols) if smooth else m


@functools.lru_cache(maxsize=1024)
def _stage_matrix(p: int, ncols: int, smooth: bool) -> np.ndarray:
    """One matrix for the integer refit's linear stage: [L band (ncols) | R band (ncols + 7) | 1]
    times it gives [L | Rs | 1], w + 2 columns each, where L is unchanged or filtered by
    [1 6 1] (Q3) and Rs is the interpolated (and filtered) right band scaled to Q8 DN before
    rounding: the taps are Q14 (Q17 with the filter) integers times 2^-6 (2^-9), so every
    entry of the product is exact in float64 (< 2^17 in steps of 2^-9) and `np.rint` rounds it
    once (to nearest, ties to even)."""
    e = int(smooth)
    nout = ncols - 2 * e
    m = np.zeros((2 * ncols + 2 * HALF_TAPS, 2 * nout + 1))
    m[:ncols, :nout] = _smoother(ncols) if smooth else np.eye(ncols)
    m[ncols:-1, nout:-1] = _interp_matrix(p, ncols, smooth) * 2.0 ** -(TAP_BITS + 3 * e - RS_BITS)
    m[-1, -1] = 1.0
    return m


@functools.cache
def _ones(rows: int) -> np.ndarray:
    return np.ones((rows, 1))


@functools.cache
def _smoother(ncols: int) -> np.ndarray:
    """(ncols, ncols - 2) matrix of the [1 6 1] filter (x 8, exact): column c is 1, 6, 1 at
    rows c, c + 1, c + 2."""
    m = np.zeros((ncols, ncols - 2))
    c = np.arange(ncols - 2)
    m[c, c], m[c + 1, c], m[c + 2, c] = 1.0, 6.0, 1.0
    return m


def _banded(taps: np.ndarray, ncols: int) -> np.ndarray:
    m = np.zeros((ncols + 2 * HALF_TAPS - 1, ncols))
    for j, tap in zip(_J, taps, strict=True):
        m[np.arange(ncols) + j + HALF_TAPS, np.arange(ncols)] = tap
    return m


@functools.cache
def _sum_index(w: int) -> np.ndarray:
    """(18, w) flat indices into the Gram matrix of [L | Rs | 1] (w + 2 columns each, then a
    ones column) whose row sums are: S1 of L windows at column offsets 0, 1, 2 (the window at
    x - k has offset 1 - k); S1 of Rs windows; S2 of L; S2 of Rs; the LR cross sums of
    template L (offset 1) with Rs at x - k, k = -1, 0, 1; the RL cross sums of template Rs
    (offset 1) with L at x - k."""
    m = 2 * (w + 2) + 1
    one, c = m - 1, np.arange(w)
    rows = []
    for b in (0, w + 2):                                             # S1: (col, ones)
        rows += [(o + b + c) * m + one for o in range(3)]
    for b in (0, w + 2):                                             # S2: diagonal
        rows += [(o + b + c) * (m + 1) for o in range(3)]
    rows += [(1 + c) * m + (w + 2) + (1 - k) + c for k in (-1, 0, 1)]   # L(1 + c) x Rs(1 - k + c)
    rows += [(1 - k + c) * m + (w + 2) + 1 + c for k in (-1, 0, 1)]     # L(1 - k + c) x Rs(1 + c)
    return np.stack(rows)


def _sums(ls: np.ndarray, rs: np.ndarray) -> list:
    """The 18 window sums of `_sum_index` from one Gram matrix (exact integers in float64)."""
    q = np.concatenate((ls, rs, np.ones((ls.shape[0], 1))), axis=1)
    return (q.T @ q).ravel()[_sum_index(ls.shape[0])].sum(axis=1).tolist()


RATIO_BITS = 40                   # the two log arguments as Q40 quotients


def _fit_q(n_px: int, s1_t: int, s1_c: list, s2_c: list, cross: list) -> int | None:
    """Q10 vertex of y(k) = log2 E_C(k) - 2 log2 X(k), k = -1, 0, 1 (eq. 5.2 on -log NCC), or
    None without an interior minimum. Exact integers: the first and second differences of y
    are logs of two quotients, y(-1) - y(1) = log2(E- X+^2 / (E+ X-^2)) and y(-1) - 2 y(0) + y(1)
    = log2(E- E+ X0^4 / (E0^2 X-^2 X+^2)), each taken as a Q40 quotient (a port needs
    ~200-bit products here, or the six logs of `fixedpoint.log2_q` instead)."""
    (am, a0, ap), (bm, b0, bp), (cm, c0, cp) = s1_c, s2_c, cross
    em, e0, ep = n_px * bm - am * am, n_px * b0 - a0 * a0, n_px * bp - ap * ap
    xm, x0, xp = n_px * cm - s1_t * am, n_px * c0 - s1_t * a0, n_px * cp - s1_t * ap
    if em <= 0 or e0 <= 0 or ep <= 0 or xm <= 0 or x0 <= 0 or xp <= 0:
        return None
    xm2, x02, xp2 = xm * xm, x0 * x0, xp * xp
    if not (e0 * xm2 < em * x02 and e0 * xp2 <= ep * x02):     # y(0) the first minimum
        return None
    q1 = ((em * xp2) << RATIO_BITS) // (ep * xm2)
    q2 = ((em * ep * x02 * x02) << RATIO_BITS) // (e0 * e0 * xm2 * xp2)
    if not (0 < q1 < 1 << 62 and 1 << RATIO_BITS < q2 < 1 << 62):
        return None
    num = log2_q_int(q1) - (RATIO_BITS << LOG_BITS)
    den = 2 * (log2_q_int(q2) - (RATIO_BITS << LOG_BITS))
    if den <= 0 or abs(num) > den:
        return None
    return div_round(num << FIT_BITS, den)


def _fit_float(n_px: int, s1_t: float, s1_c: list, s2_c: list, cross: list) -> float | None:
    """Float reference of `_fit_q` (px), through `subpixel.gauss_fit_float`."""
    e = [n_px * b - a * a for a, b in zip(s1_c, s2_c, strict=True)]
    x = [n_px * c - s1_t * a for a, c in zip(s1_c, cross, strict=True)]
    if min(e) <= 0 or min(x) <= 0:
        return None
    fit = gauss_fit_float([math.log2(a) - 2 * math.log2(b) for a, b in zip(e, x, strict=True)], -1)
    return fit


def _mismatched(n_px: int, v: list, noise_var: float) -> bool:
    """Whether the centre windows (template L, Rs at k = 0) differ by more than MISMATCH_FACTOR
    times what noise of variance noise_var (in L's units) in both views explains: with
    E_T, E_C, X the N-scaled energies and cross term, 1 - X^2 / (E_T E_C) against
    2 noise_var N^2 / E_T (the exact integer side is compared with a float bound)."""
    e_t, e_c = n_px * v[7] - v[1] * v[1], n_px * v[10] - v[4] * v[4]
    x0 = n_px * v[13] - v[1] * v[4]
    return e_t * e_c - x0 * x0 > MISMATCH_FACTOR * 2 * noise_var * n_px * n_px * e_c


def _columns(band_width: int, right_width: int, xl: int, h: int, n: int, e: int) -> tuple[int, int] | None:
    """First column of the left span xl - h - 1 - e .. xl + h + 1 + e (e = 1 with the smoothing
    filter) and of the right columns the interpolator reads, if both bands hold them."""
    lo, hi = xl - h - 1 - e, xl + h + 1 + e
    if lo < 0 or hi >= band_width or lo - n - HALF_TAPS < 0 or hi - n + HALF_TAPS - 1 >= right_width:
        return None
    return lo, lo - n - HALF_TAPS


def refit_q8(left_band: np.ndarray, right_band: np.ndarray, xl: int, first_q8: int,
             smooth_noise_dn: float | None = None) -> int | None:
    """Refined disparity (Q8 px) of the window at column xl of left_band, given a first estimate
    first_q8 (Q8). With smooth_noise_dn (the read noise, DN) both views are filtered by
    [1 6 1]/8 first unless the aligned windows differ by more than that noise explains (module
    doc). None if the bands lack the columns or a fit has no interior minimum."""
    smooth = smooth_noise_dn is not None
    w, e = left_band.shape[0], int(smooth)
    n, p = first_q8 >> PHASE_BITS, first_q8 & ((1 << PHASE_BITS) - 1)
    span = _columns(left_band.shape[1], right_band.shape[1], xl, w // 2, n, e)
    if span is None:
        return None
    lo, r_lo = span
    ncols = w + 2 + 2 * e
    bands = np.concatenate((left_band[:, lo:lo + ncols], right_band[:, r_lo:r_lo + ncols + 2 * HALF_TAPS - 1],
                            _ones(w)), axis=1)
    q = np.rint(bands @ _stage_matrix(p, ncols, smooth))                   # [L (Q0/Q3) | Rs (Q8) | 1]
    v = (q.T @ q).ravel()[_sum_index(w)].sum(axis=1).astype(np.int64).tolist()     # exact: < 2^53
    n_px = w * w
    if smooth_noise_dn is not None and _mismatched(
        n_px, v, SMOOTHED_NOISE_GAIN * 64 * (smooth_noise_dn ** 2 + 1 / 12)
    ):
        return refit_q8(left_band, right_band, xl, first_q8)
    r_l = _fit_q(n_px, v[1], v[5:2:-1], v[11:8:-1], v[12:15])              # template L, candidates Rs
    r_r = _fit_q(n_px, v[4], v[2::-1], v[8:5:-1], v[15:18])               # template Rs, candidates L
    if r_l is None or r_r is None:
        return None
    d_q11 = (first_q8 << (FIT_BITS + 1 - PHASE_BITS)) + r_l - r_r
    return round_shift(d_q11, FIT_BITS + 1 - SUBPIX_BITS)


def refit_float(left_band: np.ndarray, right_band: np.ndarray, xl: int, first_px: float,
                smooth_noise_dn: float | None = None) -> float | None:
    """Float reference of `refit_q8` (px): the shift is the first estimate itself (no 1/256 px
    phase rounding), float taps, filter, window sums and logs."""
    smooth = smooth_noise_dn is not None
    w, e = left_band.shape[0], int(smooth)
    n = math.floor(first_px)
    span = _columns(left_band.shape[1], right_band.shape[1], xl, w // 2, n, e)
    if span is None:
        return None
    lo, r_lo = span
    ncols = w + 2 + 2 * e
    rs = right_band[:, r_lo:r_lo + ncols + 2 * HALF_TAPS - 1] @ _banded(kernel_float(first_px - n), ncols)
    ls = left_band[:, lo:lo + ncols].astype(np.float64)
    if smooth:
        ls, rs = ls @ _smoother(ncols) / 8, rs @ _smoother(ncols) / 8
    v = _sums(ls, rs)
    n_px = w * w
    if smooth_noise_dn is not None and _mismatched(
        n_px, v, SMOOTHED_NOISE_GAIN * (smooth_noise_dn ** 2 + 1 / 12)
    ):
        return refit_float(left_band, right_band, xl, first_px)
    r_l = _fit_float(n_px, v[1], v[5:2:-1], v[11:8:-1], v[12:15])
    r_r = _fit_float(n_px, v[4], v[2::-1], v[8:5:-1], v[15:18])
    if r_l is None or r_r is None:
        return None
    return first_px + 0.5 * (r_l - r_r)


def refine_refit(arith: CostArithmetic, a_band: np.ndarray, b_band: np.ndarray, xa: int, d_lo: int,
                 costs: np.ndarray, k0: int, sigma_px: float,
                 noise_dn: float) -> tuple[float | int | None, str]:
    """match_point's subpixel="refit": the "cancel" estimate, then the refit around it; where it
    cannot run, or the predicted sigma exceeds REFIT_MAX_SIGMA_PX (noise-dominated windows),
    "cancel6-gauss"."""
    if sigma_px <= REFIT_MAX_SIGMA_PX:
        first, _ = refine(arith, a_band, b_band, xa, d_lo, costs, k0, "cancel")
        step = refit_float if arith.is_float else refit_q8
        noise = noise_dn if sigma_px <= REFIT_SMOOTH_MAX_SIGMA_PX else None
        # values are Q8 ints on the integer path, floats on the float one (is_float)
        value = None if first is None else step(a_band, b_band, xa, first, noise)  # type: ignore[arg-type]
        if value is not None:
            return value, ""
    return refine(arith, a_band, b_band, xa, d_lo, costs, k0, "cancel6-gauss", sigma_px, noise_dn)
