"""Sub-pixel refinement of a cost curve: the 3-point parabola (eq. 5.2) and Shimizu-Okutomi
half-pixel error cancellation, each as an integer routine with a float reference beside it.

Why cancellation: the parabola assumes a cost-curve shape the image does not have, leaving a
periodic error e(f) ~ -A sin(2 pi f) in the fractional disparity f ("pixel locking", the
thesis's 0.1 px floor). Its first harmonic flips sign under a half-pixel shift,
e(f + 1/2) ~ -e(f), so averaging with an estimate made on half-pixel-shifted data cancels it
(research note §1.1, §1.3). The *symmetric* variant used here:

    Lh(x) = L(x) + L(x+1),  Rh(x) = R(x) + R(x+1)          (9-bit sums, no interpolation)
    pass A: curve of (Lh, Rh)  -> dA ~ d                  (same [1 1] smoothing on both views)
    pass B: curve of (Lh, 2R)  -> dB ~ d - 1/2            (Lh(x) = 2 L(x + 1/2))
    d = (dA + dB + 1/2) / 2

Six-pass variant (`symmetric6_q8`, match_point subpixel="cancel6"): pass B smooths only the
template (Lh vs 2R), so it also runs mirrored (2L vs Rh, and 2R vs Lh right-to-left) and
d = (dA + rA)/4 + (dB + dB' + rB + rB')/8. Measured (tools/bench-core): RMS 2-4 % lower on
every condition for ~10 % more time; the default stays "cancel".

What is left (tools/bench-core, "subpixel" and opt-in "study" sections): on textured patches
at 1 DN the error is ~1.8x the Cramer-Rao bound. Noise-free, ~0.005 px RMS remains: the
first harmonic is not fully cancelled because pass A weights the image spectrum by
cos^2(w/2) and pass B by cos(w/2) (a [1 1] kernel can only give odd powers with a half-pixel
shift and even powers without one, so the two can never match exactly), the second harmonic
is untouched by any half-pixel pairing, and there is a per-texture constant from the window
edges. Under noise the [1 1] smoothing also costs ~25 % over the bound. Gauss-Newton steps on
the raw windows avoid the smoothing but need fractional-position samples: linear, Keys
cubic and Lanczos-3 interpolation all leave more phase error at quarter-pixel positions on
this texture than the cancellation does (study section).

Integer form: each fit is one division num/den to Q10 (FIT_BITS), with num = c(-1) - c(+1),
den = 2(c(-1) - 2c(0) + c(+1)) and |num| <= den/2 at an interior minimum; the average is
formed in Q10 and rounded once to Q8. Worst-case difference from the float reference:
2^-11 (fit) + 2^-9 (final rounding) < 1/256 px.

Widths (15x15): SSD of 9-bit sums < 2^26; ZSSD (N sum D^2 - (sum D)^2) < 2^34. For ZSSD the
passes first equalise contrast (left x 256, right x gain in Q8, gain clamped to [1/2, 2]), so
|D| < 2^18 and costs < 2^52: int64 sums, den < 2^54, and num << 10 would need 64 bits, so a
port uses `fixedpoint.restoring_divide` (bit-identical; its remainder stays below 2 den).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from edge.core.fixedpoint import FIT_BITS, SUBPIX_BITS, div_round, round_shift


def parabola_q(c_minus: int, c_zero: int, c_plus: int) -> int | None:
    """Offset of the parabola's vertex from the centre sample, Q10 px (eq. 5.2); None if the
    three costs do not bracket a minimum (den <= 0 or the vertex beyond +-1/2)."""
    num = c_minus - c_plus
    den = 2 * (c_minus - 2 * c_zero + c_plus)
    if den <= 0 or 2 * abs(num) > den:
        return None
    return div_round(num << FIT_BITS, den)     # == restoring_divide(num, den, FIT_BITS) (tested)


def parabola_float(c_minus: float, c_zero: float, c_plus: float) -> float | None:
    """Float reference of `parabola_q` (offset in px)."""
    num = c_minus - c_plus
    den = 2.0 * (c_minus - 2.0 * c_zero + c_plus)
    if not den > 0 or 2 * abs(num) > den * (1 + 1e-12):
        return None
    return num / den


def interior_argmin(costs: np.ndarray | list) -> int | None:
    """Index of the first minimum if it is not at either end of the curve, else None."""
    c = costs.tolist() if isinstance(costs, np.ndarray) else costs
    k = c.index(min(c))
    return k if 0 < k < len(c) - 1 else None


def fit_curve_q(costs: np.ndarray, d_first: int) -> int | None:
    """Sub-pixel minimum (Q10 px) of an integer curve whose entry k is disparity d_first + k."""
    c = costs.tolist()                       # Python ints: exact, and faster for 3-5 entries
    k = interior_argmin(c)
    if k is None:
        return None
    off = parabola_q(c[k - 1], c[k], c[k + 1])
    if off is None:
        return None
    return ((d_first + k) << FIT_BITS) + off


def fit_curve_float(costs: np.ndarray, d_first: int) -> float | None:
    """Float reference of `fit_curve_q` (px)."""
    k = interior_argmin(costs)
    if k is None:
        return None
    off = parabola_float(float(costs[k - 1]), float(costs[k]), float(costs[k + 1]))
    return None if off is None else d_first + k + off


def fit_to_q8(fit_q10: int) -> int:
    """Round a Q10 fit to the Q8 interface format."""
    return round_shift(fit_q10, FIT_BITS - SUBPIX_BITS)


def cancel_q8(da_q10: int, db_q10: int) -> int:
    """d = (dA + dB + 1/2) / 2, from two Q10 fits to Q8 with a single rounding."""
    twice_d_q10 = da_q10 + db_q10 + (1 << (FIT_BITS - 1))      # 2d in Q10 = d in Q11
    return round_shift(twice_d_q10, FIT_BITS + 1 - SUBPIX_BITS)


def cancel_float(da: float, db: float) -> float:
    """Float reference of `cancel_q8`."""
    return 0.5 * (da + db + 0.5)


def symmetric_q8(da_q10: int, db_q10: int, ra_q10: int, rb_q10: int) -> int:
    """Both-way cancellation: left-to-right dA ~ d, dB ~ d - 1/2 and right-to-left
    rA ~ d, rB ~ d + 1/2; d = (dA + dB + rA + rB) / 4, from Q10 fits to Q8 in one rounding."""
    four_d_q10 = da_q10 + db_q10 + ra_q10 + rb_q10              # 4d in Q10 = d in Q12
    return round_shift(four_d_q10, FIT_BITS + 2 - SUBPIX_BITS)


def symmetric_float(da: float, db: float, ra: float, rb: float) -> float:
    """Float reference of `symmetric_q8`."""
    return 0.25 * (da + db + ra + rb)


def symmetric6_q8(da_q10: int, db_q10: int, ra_q10: int, rb_q10: int, dm_q10: int, rm_q10: int) -> int:
    """Six-pass cancellation: the four passes of `symmetric_q8` plus the mirrored half-pixel
    passes dB' ~ d - 1/2 (2L vs Rh) and rB' ~ d + 1/2 (2R vs Lh, sign-flipped),
    d = (dA + rA)/4 + (dB + dB' + rB + rB')/8, from Q10 fits to Q8 in one rounding."""
    eight_d_q10 = 2 * (da_q10 + ra_q10) + db_q10 + dm_q10 + rb_q10 + rm_q10     # d in Q13
    return round_shift(eight_d_q10, FIT_BITS + 3 - SUBPIX_BITS)


def symmetric6_float(da: float, db: float, ra: float, rb: float, dm: float, rm: float) -> float:
    """Float reference of `symmetric6_q8`."""
    return 0.25 * (da + ra) + 0.125 * (db + dm + rb + rm)


def contrast_gain_q8(energy_left: int, energy_right: int) -> int:
    """sqrt(energy_left / energy_right) in Q8 (integer square root), clamped to [1/2, 2]."""
    if energy_left <= 0 or energy_right <= 0:
        return 1 << SUBPIX_BITS
    g_q8 = math.isqrt(((energy_left << (4 * SUBPIX_BITS)) + energy_right // 2) // energy_right)
    return min(max(round_shift(g_q8, SUBPIX_BITS), 1 << (SUBPIX_BITS - 1)), 2 << SUBPIX_BITS)


def _equalise_contrast(regs: np.ndarray, w: int, as_float: bool) -> np.ndarray:
    """Scale the right region so its centre window has the left one's zero-mean energy.

    ZSSD removes an offset but not a gain: with R = g*L the fitted minimum of sum (L' - g R')^2
    moves with how sum R'^2 varies across candidates. Matching the contrast first (integer:
    left x 256, right x g in Q8) makes the half-pixel passes gain-invariant."""
    centre = regs[:, :, 2:2 + w]
    energy = (w * w) * np.einsum("ijk,ijk->i", centre, centre) - centre.sum(axis=(1, 2)) ** 2
    if as_float:
        if energy[0] <= 0 or energy[1] <= 0:
            return regs
        gain = min(max(float(np.sqrt(energy[0] / energy[1])), 0.5), 2.0)
        return regs * np.array([1.0, gain])[:, None, None]
    g_q8 = contrast_gain_q8(int(energy[0]), int(energy[1]))
    return regs * np.array([1 << SUBPIX_BITS, g_q8], dtype=np.int64)[:, None, None]


@functools.cache
def _candidate_index(w: int) -> np.ndarray:
    """Columns of the nine candidate windows in [half sums | doubled samples] (each w+4 wide):
    half-sum windows at shifts p = 0..4, then doubled-sample windows at p = 1..4."""
    cols = np.arange(5)[:, None] + np.arange(w)[None, :]
    return np.concatenate((cols, cols[1:] + w + 4))


def cancellation_costs(left_band: np.ndarray, right_band: np.ndarray, xl: int, d0: int, cost: str,
                       as_float: bool = False, *, six: bool = False) -> tuple[np.ndarray, ...]:
    """Cost curves of the half-pixel passes around the integer disparity d0, in one vectorised
    step (18 windows, 26 with `six`):

    LR-A (Lh vs Rh) for d = d0-2 .. d0+2,   LR-B (Lh vs 2R) for d = d0-2 .. d0+1,
    RL-A (Rh vs Lh) for e = -d0-2 .. -d0+2, RL-B (Rh vs 2L) for e = -d0-2 .. -d0+1,
    and with six=True also the mirrored half-pixel passes
    LR-B' (2L vs Rh) for d = d0-2 .. d0+1,  RL-B' (2R vs Lh) for e = -d0-2 .. -d0+1,
    where the right-to-left passes put the template on the right window at xr = xl - d0 and
    search the left image (e = -d). Needs columns xl-h-2 .. xl+h+3 and xr-h-2 .. xr+h+3.
    Returns (LR-A, LR-B, RL-A, RL-B) or (LR-A, LR-B, RL-A, RL-B, LR-B', RL-B').
    Integer: N*sum(D^2) - (sum D)^2 (or sum D^2) in int64; float: mean-subtracted SSD (/N)."""
    w = left_band.shape[0]
    h = w // 2
    xr = xl - d0
    regs = np.stack((left_band[:, xl - h - 2:xl + h + 4], right_band[:, xr - h - 2:xr + h + 4]))
    regs = regs.astype(np.float64 if as_float else np.int64)                # (2, w, w+5)
    if cost != "ssd":
        regs = _equalise_contrast(regs, w, as_float)
    # half sums and doubled samples side by side; one gather takes all nine candidate windows
    ext = np.concatenate((regs[:, :, :-1] + regs[:, :, 1:], 2 * regs[:, :, :-1]), axis=2)
    cands = ext[:, :, _candidate_index(w)]                   # (2, w, 9, w): Xh p=0..4, 2X p=1..4
    templates = ext[:, :, None, 2:2 + w]                      # Lh, Rh at p = 2
    diff = templates - cands[::-1]                    # [0]: Lh vs (Rh, 2R); [1]: Rh vs (Lh, 2L)
    if six:                                           # 2L vs Rh p=0..3; 2R vs Lh p=0..3
        doubled = ext[:, :, None, w + 6:2 * w + 6]                          # 2L, 2R at p = 2
        diff = np.concatenate((diff, doubled - cands[::-1, :, :4]), axis=2)
    if as_float:
        if cost != "ssd":
            diff = diff - diff.mean(axis=(1, 3), keepdims=True)
        costs = (diff * diff).sum(axis=(1, 3))
    else:
        costs = (diff * diff).sum(axis=(1, 3))
        if cost != "ssd":
            s1 = diff.sum(axis=(1, 3))
            costs = (w * w) * costs - s1 * s1
    curve_a, curve_b = costs[:, 4::-1], costs[:, 8:4:-1]        # ascending d (descending p)
    if not six:
        return curve_a[0], curve_b[0], curve_a[1], curve_b[1]
    # LR-B': Rh at p has d = d0 + 3/2 - p (ascending d: p = 3..0); RL-B': e = -d0 + 3/2 - p
    curve_m = costs[:, 12:8:-1]
    return curve_a[0], curve_b[0], curve_a[1], curve_b[1], curve_m[0], curve_m[1]
