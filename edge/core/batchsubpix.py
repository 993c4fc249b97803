"""Batched sub-pixel stage: the six-pass Gaussian cancellation (`match.refine` with
subpixel="cancel6-gauss", ZSSD) of many points in a few numpy operations, and the 3-point
parabola (subpixel="parabola", the left follow's fits) of many curves.

Why: once the integer searches were batched (edge.core.batchmatch), the per-point sub-pixel
stage was the largest per-track cost of the pipeline (tools/bench --stages, "sub-pixel
match"): per point a dozen small numpy calls (window sums, one product, log2, six 3-point fits),
each costing more in call overhead than in arithmetic. Here the points' regions are stacked and
the same integers computed for all of them at once:

    window sums S1, S2 and cross terms sum TW         (float64 carrying exact integers < 2^36)
    N-scaled E_W = N S2 - S1^2, 2X = 2(N sum TW - S1_T S1_W)          (subpixel._ncc_terms)
    y = log2(E_W) - 2 log2(2X) in Q24                               (fixedpoint.log2_q)
    six 3-point vertex fits, Q10 (eq. 5.2 on -log NCC)              (subpixel.gauss_fit_q)
    d = (dA + rA)/4 + (dB + dB' + rB + rB')/8, Q8, one rounding     (subpixel.symmetric6_q8)

Bit-identical to the per-point integer routine (`match._gauss6` with impl "int", which stays
the reference; tests/edge/core/test_batchsubpix.py checks equality with hypothesis): every sum
is an exact integer in float64 (so the batched summation order cannot change it), and the fits
and the final rounding are the same integer operations on int64 (|num << 10| < 2^43). A point
whose correlations are not all positive or whose log curves lack an interior minimum comes back
as None: the caller then runs the per-point `refine`, which falls back to the parabola fits.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from edge.core.fixedpoint import FIT_BITS, SUBPIX_BITS, div_round_array, log2_q, round_shift_array
from edge.core.subpixel import _CANDIDATE_OF, _TEMPLATE_OF, _ncc_index


def ncc_terms_batch(regions: np.ndarray) -> np.ndarray:
    """`subpixel._ncc_terms` of many points: (n, 2, w, w + 5) regions (left around xl, right around
    xl - d0, columns x - h - 2 .. x + h + 3; any integer dtype) -> (n, 2, 26) int64
    [N-scaled E_W | N-scaled 2X] of the 13 candidates of each direction."""
    w = regions.shape[2]
    # column sums over the w rows and the product's entries are sums of w terms <= 510^2: float32
    # holds them exactly while w 510^2 < 2^24 (windows up to 63 rows), at half the memory traffic of
    # float64; the sums over the window's columns (up to w^2 510^2) are then taken in float64
    exact: type[np.floating] = np.float32 if w * 510 * 510 < 2**24 else np.float64
    regs = regions.astype(exact)
    ext = np.concatenate((regs[..., :-1] + regs[..., 1:], 2 * regs[..., :-1]), axis=-1)  # (n, 2, w, 2w+8)
    windows, tmpl_cols, rows, pair_cols = _ncc_index(w)
    columns = np.stack((ext.sum(axis=2), (ext * ext).sum(axis=2))).astype(np.float64)
    s1, s2 = columns @ windows                                                        # (n, 2, 9) each
    prod = np.matmul(ext[..., tmpl_cols].transpose(0, 1, 3, 2), ext[:, ::-1])        # (n, 2, 2w, 2w+8)
    cross = prod[:, :, rows, pair_cols].astype(np.float64).sum(axis=-1)               # (n, 2, 13)
    n = w * w
    s1_w, s2_w = s1[:, ::-1][..., _CANDIDATE_OF], s2[:, ::-1][..., _CANDIDATE_OF]
    terms = np.concatenate((n * s2_w - s1_w * s1_w, 2 * (n * cross - s1[..., _TEMPLATE_OF] * s1_w)), axis=-1)
    return terms.astype(np.int64)


def vertex_fits_q(curves: np.ndarray, firsts: np.ndarray,
                  lengths: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """`subpixel.gauss_fit_q` along the last axis: (..., L) int64 log curves, (...) disparity of
    each curve's first entry -> (Q10 fits, ok). ok is False where the first minimum is at an end,
    the curve does not open upwards, or the vertex lies more than one sample away (fit undefined).
    `lengths` (broadcast to the curves' leading shape): curves shorter than L, padded with a value
    above every entry (the pad is never a first minimum, and a minimum next to it is an end)."""
    size = curves.shape[-1]
    flat = curves.reshape(-1, size)
    last = (np.full(curves.shape[:-1], size) if lengths is None
            else np.broadcast_to(lengths, curves.shape[:-1])).reshape(-1) - 1
    k = flat.argmin(axis=1)                                       # the first minimum, as list.index
    ok = (k > 0) & (k < last)
    rows, kc = np.arange(len(flat)), np.minimum(np.maximum(k, 1), size - 2)
    ym, y0, yp = flat[rows, kc - 1], flat[rows, kc], flat[rows, kc + 1]
    num, den = ym - yp, 2 * (ym - 2 * y0 + yp)
    ok &= (den > 0) & (np.abs(num) <= den)
    den = np.where(ok, den, 1)
    fits = ((firsts.reshape(-1) + k) << FIT_BITS) + div_round_array(num << FIT_BITS, den)
    return fits.reshape(curves.shape[:-1]), ok.reshape(curves.shape[:-1])


def parabola3_q8(curves: np.ndarray, d0s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`match.refine(..., "parabola")` of 3-point curves: (..., 3) int64 costs for d0 - 1, d0, d0 + 1,
    (...) d0 -> (Q8 sub-pixel disparities, ok). ok is False where refine has none: the middle is not
    the first minimum, or the parabola (eq. 5.2) does not bracket it (`subpixel.parabola_q`).
    |costs| < 2^50 (ZSSD of windows up to 61 x 61 of 9-bit data: < 2^44)."""
    cm, c0, cp = curves[..., 0], curves[..., 1], curves[..., 2]
    num, den = cm - cp, 2 * (cm - 2 * c0 + cp)
    ok = (c0 < cm) & (c0 <= cp) & (den > 0) & (2 * np.abs(num) <= den)      # subpixel.interior_argmin
    den = np.where(ok, den, 1)
    fit = (d0s << FIT_BITS) + div_round_array(num << FIT_BITS, den)
    return round_shift_array(fit, FIT_BITS - SUBPIX_BITS), ok      # subpixel.fit_to_q8


_PAD = 1 << 40     # above every log curve entry (|y| < 2^32), below any overflow in the fit's sums
# the six pass curves of `subpixel._split_lists` as indices into [LR row (13) | RL row (13) | pad]:
# LR-A, RL-A (5 entries), LR-B, RL-B, LR-B', RL-B' (4 entries and the pad), ascending disparity
_CURVES = np.array([[4, 3, 2, 1, 0], [17, 16, 15, 14, 13], [8, 7, 6, 5, 26], [21, 20, 19, 18, 26],
                    [12, 11, 10, 9, 26], [25, 24, 23, 22, 26]])
_LENGTHS = np.array([5, 5, 4, 4, 4, 4])
_FIRST_SIGN = np.array([1, -1, 1, -1, 1, -1])      # LR passes start at d0 - 2, RL passes at -d0 - 2
_WEIGHTS = np.array([2, -2, 1, -1, 1, -1])         # subpixel.symmetric6_q8 (RL fits sign-flipped)


def gauss6_q8_batch(left_bands: Sequence[np.ndarray], right_bands: Sequence[np.ndarray],
                    xls: Sequence[int], d0s: Sequence[int]) -> list[int | None]:
    """`match._gauss6` (integer) of each point: the Q8 disparity of the six-pass Gaussian
    cancellation around d0s[i] for the window at column xls[i] of the w-row bands, or None where
    the per-point routine gives None. Needs columns x - h - 2 .. x + h + 3 of both bands (the
    caller's border gate, `match.match_gate`)."""
    n = len(xls)
    if not n:
        return []
    w = left_bands[0].shape[0]
    h = w // 2
    regions = np.empty((n, 2, w, w + 5), np.uint8)
    for k, (a, b, x, d) in enumerate(zip(left_bands, right_bands, xls, d0s, strict=True)):
        regions[k, 0], regions[k, 1] = a[:, x - h - 2:x + h + 4], b[:, x - d - h - 2:x - d + h + 4]
    terms = ncc_terms_batch(regions)
    positive = terms.min(axis=(1, 2)) > 0
    logs = log2_q(np.where(positive[:, None, None], terms, 1))
    y = np.empty((n, 27), np.int64)
    y[:, :26] = (logs[..., :13] - 2 * logs[..., 13:]).reshape(n, 26)     # -2 log2 NCC + const
    y[:, 26] = _PAD
    firsts = np.asarray(d0s, dtype=np.int64)[:, None] * _FIRST_SIGN - 2
    fits, ok = vertex_fits_q(y[:, _CURVES], firsts, _LENGTHS)                  # (n, 6)
    ok = positive & ok.all(axis=1)
    values = round_shift_array(fits @ _WEIGHTS, FIT_BITS + 3 - SUBPIX_BITS).tolist()
    return [v if good else None for v, good in zip(values, ok.tolist(), strict=True)]


__all__ = ["gauss6_q8_batch", "ncc_terms_batch", "parabola3_q8", "vertex_fits_q"]
