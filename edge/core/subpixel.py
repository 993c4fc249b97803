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
d = (dA + rA)/4 + (dB + dB' + rB + rB')/8.

Gaussian model (`ncc_log_curves`, `gauss_fit_q`; subpixel="cancel6-gauss", match_point's
default): the parabola assumes a quadratic cost curve, i.e. a quadratic autocorrelation of
the window; blurred texture has a near-Gaussian one, so each pass fits the parabola of
eq. 5.2 to -log NCC instead: y = log2(E_W) - 2 log2(2X), X the zero-mean cross-correlation of
template and candidate and E_W the candidate's zero-mean energy (E_T is common to a pass),
exact integers from window sums and one product, log2 in Q24 (`fixedpoint.log2_q`); the six
fits are combined as above. NCC is gain-invariant, so these passes need no contrast
equalisation. If a correlation is not positive or a log curve has no interior minimum, the
caller uses the parabola fits (tools/bench-core measures both; docs/decisions.md).

What is left (tools/bench-core, "subpixel" and opt-in "study" sections): the half-pixel
pairing cancels only odd harmonics of the pixel-locking curve, and exactly only if both
passes weight the image spectrum alike; pass A weights it by cos^2(w/2), pass B by
cos(w/2) (a [1 1] kernel gives odd powers of cos(w/2) with a half-pixel shift and even
powers without, so they can never match). The second harmonic, a per-texture constant from
the window edges, and ~25 % excess noise from the [1 1] smoothing remain. Gauss-Newton steps
on the raw windows avoid the smoothing but need samples at fractional positions: linear,
Keys cubic and Lanczos-3 interpolation all leave more phase error at quarter-pixel
positions on this texture than the cancellation does (study section).

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

from edge.core.fixedpoint import FIT_BITS, SUBPIX_BITS, div_round, log2_q, round_shift


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


def _pass_costs(left_band: np.ndarray, right_band: np.ndarray, xl: int, d0: int, cost: str,
                as_float: bool, six: bool, energies: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
    """Costs of all candidate windows, (2, 9) or (2, 13) with `six`, and (if `energies`) the
    zero-mean energy of each of the nine candidate windows of both images, (2, 9); see
    `cancellation_costs`."""
    w = left_band.shape[0]
    h = w // 2
    xr = xl - d0
    regs = np.stack((left_band[:, xl - h - 2:xl + h + 4], right_band[:, xr - h - 2:xr + h + 4]))
    regs = regs.astype(np.float64 if as_float else np.int64)                # (2, w, w+5)
    if cost != "ssd" and not energies:         # NCC (with energies) needs no gain equalisation
        regs = _equalise_contrast(regs, w, as_float)
    # half sums and doubled samples side by side; one gather takes all nine candidate windows
    ext = np.concatenate((regs[:, :, :-1] + regs[:, :, 1:], 2 * regs[:, :, :-1]), axis=2)
    cands = ext[:, :, _candidate_index(w)]                   # (2, w, 9, w): Xh p=0..4, 2X p=1..4
    templates = ext[:, :, None, 2:2 + w]                      # Lh, Rh at p = 2
    diff = templates - cands[::-1]                    # [0]: Lh vs (Rh, 2R); [1]: Rh vs (Lh, 2L)
    if six:                                           # 2L vs Rh p=0..3; 2R vs Lh p=0..3
        doubled = ext[:, :, None, w + 6:2 * w + 6]                          # 2L, 2R at p = 2
        diff = np.concatenate((diff, doubled - cands[::-1, :, :4]), axis=2)
    energy = None
    if energies:                                      # window sums from column sums
        s1, s2 = np.stack((ext, ext * ext)).sum(axis=2)[:, :, _candidate_index(w)].sum(axis=3)
        energy = s2 - s1 * s1 / (w * w) if as_float else (w * w) * s2 - s1 * s1
    if as_float:
        if cost != "ssd":
            diff = diff - diff.mean(axis=(1, 3), keepdims=True)
        return (diff * diff).sum(axis=(1, 3)), energy
    costs = (diff * diff).sum(axis=(1, 3))
    if cost != "ssd":
        d1 = diff.sum(axis=(1, 3))
        costs = (w * w) * costs - d1 * d1
    return costs, energy


_TEMPLATE_OF = np.r_[[2] * 9, [6] * 4]       # per pass candidate: its template's window
_CANDIDATE_OF = np.r_[0:9, 0:4]               # its window: Xh p=0..4, 2X p=1..4, then Xh p=0..3


def _split(costs: np.ndarray) -> tuple[np.ndarray, ...]:
    """(2, 9 or 13) candidate values -> the pass curves in ascending disparity order."""
    curve_a, curve_b = costs[:, 4::-1], costs[:, 8:4:-1]        # ascending d (descending p)
    if costs.shape[1] == 9:
        return curve_a[0], curve_b[0], curve_a[1], curve_b[1]
    # LR-B': Rh at p has d = d0 + 3/2 - p (ascending d: p = 3..0); RL-B': e = -d0 + 3/2 - p
    curve_m = costs[:, 12:8:-1]
    return curve_a[0], curve_b[0], curve_a[1], curve_b[1], curve_m[0], curve_m[1]


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
    return _split(_pass_costs(left_band, right_band, xl, d0, cost, as_float, six)[0])


def ncc_log_curves(left_band: np.ndarray, right_band: np.ndarray, xl: int, d0: int,
                   as_float: bool = False) -> tuple[list, ...] | None:
    """Curves y = log2(E_W) - 2 log2(2X) = -2 log2(NCC) + const of the six passes of
    `cancellation_costs(six=True)` (same order and candidates; lists, Q24 ints or float), where
    X is the zero-mean cross-correlation of template and candidate and E_T, E_W their
    zero-mean energies; None if some X <= 0 (no Gaussian through a non-positive correlation).
    NCC is gain-invariant, so there is no contrast equalisation.

    Integer: window sums S1, S2 from column sums and the cross terms sum TW from one matrix
    product of the 9-bit sums, then N-scaled E_W = N S2 - S1^2 and 2X = 2(N sum TW - S1_T S1_W)
    (all integers below 2^36, carried in float64, which holds them exactly, as in
    `costs.cost_curve`), log2 by `fixedpoint.log2_q`. Float (the reference): the
    mean-subtracted SSD curves and energies, 2X = E_T + E_W - SSD."""
    if as_float:
        costs, energy = _pass_costs(left_band, right_band, xl, d0, "zssd", True, True, True)
        assert energy is not None  # asked for with energies=True
        e_w = energy[::-1, _CANDIDATE_OF]            # LR: right candidates; RL: left ones
        both = np.concatenate((e_w, energy[:, _TEMPLATE_OF] + e_w - costs), axis=1)
    else:
        both = _ncc_terms(left_band, right_band, xl, d0)
    if not both.min() > 0:
        return None
    logs = np.log2(both) if as_float else log2_q(both)
    return _split_lists((logs[:, :13] - 2 * logs[:, 13:]).tolist())


@functools.cache
def _ncc_index(w: int) -> tuple[np.ndarray, ...]:
    """0/1 matrix summing band columns into the nine candidate windows of [half sums | doubled
    samples], the columns of the two templates (Xh and 2X at p = 2), and (row, column) in the
    template-by-band product of each of the 13 template-candidate pairs of the six passes."""
    starts = np.r_[0:5, w + 5:w + 9]
    cols = np.arange(2 * w + 8)[:, None]
    windows = ((cols >= starts) & (cols < starts + w)).astype(np.float64)     # (2w+8, 9)
    tmpl_cols = np.r_[2:2 + w, w + 6:2 * w + 6]
    rows = (_TEMPLATE_OF[:, None] == 6) * w + np.arange(w)[None, :]
    pair_cols = starts[_CANDIDATE_OF][:, None] + np.arange(w)[None, :]
    return windows, tmpl_cols, rows, pair_cols


def _ncc_terms(left_band: np.ndarray, right_band: np.ndarray, xl: int, d0: int) -> np.ndarray:
    """(2, 26) int64: [N-scaled E_W | N-scaled 2X] of the 13 candidates of each direction.
    Integer arithmetic carried in float64: every value is an integer below 2^36, so exact."""
    w = left_band.shape[0]
    h = w // 2
    xr = xl - d0
    regs = np.stack((left_band[:, xl - h - 2:xl + h + 4], right_band[:, xr - h - 2:xr + h + 4]))
    regs = regs.astype(np.float64)
    ext = np.concatenate((regs[:, :, :-1] + regs[:, :, 1:], 2 * regs[:, :, :-1]), axis=2)
    windows, tmpl_cols, rows, pair_cols = _ncc_index(w)
    s1, s2 = np.stack((ext.sum(axis=1), (ext * ext).sum(axis=1))) @ windows      # (2, 9) each
    prod = np.matmul(ext[:, :, tmpl_cols].transpose(0, 2, 1), ext[::-1])   # (2, 2w, 2w+8)
    cross = prod[:, rows, pair_cols].sum(axis=2)                            # (2, 13)
    n = w * w
    s1_w, s2_w = s1[::-1, _CANDIDATE_OF], s2[::-1, _CANDIDATE_OF]
    terms = np.concatenate((n * s2_w - s1_w * s1_w, 2 * (n * cross - s1[:, _TEMPLATE_OF] * s1_w)), axis=1)
    return terms.astype(np.int64)


def _split_lists(rows: list) -> tuple[list, ...]:
    """`_split` of a (2, 13) nested list: six pass curves as lists (fast to fit one by one)."""
    lr, rl = rows
    return lr[4::-1], lr[8:4:-1], rl[4::-1], rl[8:4:-1], lr[12:8:-1], rl[12:8:-1]


def gauss_fit_q(model: list, d_first: int) -> int | None:
    """Sub-pixel minimum (Q10 px) of the Gaussian model: the 3-point vertex of the log curve
    `model` (-2 log2 NCC) around its interior minimum (eq. 5.2 applied to -log NCC); None if
    that minimum is at an end, or the vertex lies more than one sample away."""
    k = interior_argmin(model)
    if k is None:
        return None
    ym, y0, yp = int(model[k - 1]), int(model[k]), int(model[k + 1])
    num, den = ym - yp, 2 * (ym - 2 * y0 + yp)
    if den <= 0 or abs(num) > den:
        return None
    return ((d_first + k) << FIT_BITS) + div_round(num << FIT_BITS, den)


def gauss_fit_float(model: list, d_first: int) -> float | None:
    """Float reference of `gauss_fit_q` (px)."""
    k = interior_argmin(model)
    if k is None:
        return None
    ym, y0, yp = float(model[k - 1]), float(model[k]), float(model[k + 1])
    num, den = ym - yp, 2.0 * (ym - 2.0 * y0 + yp)
    if not den > 0 or abs(num) > den:
        return None
    return d_first + k + num / den
