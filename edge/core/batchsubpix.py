"""Batched sub-pixel stage: the six-pass Gaussian cancellation (`match.refine` with
subpixel="cancel6-gauss", ZSSD) of many points in a few numpy operations.

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

from edge.core.fixedpoint import FIT_BITS, SUBPIX_BITS, log2_q, round_shift_array
from edge.core.subpixel import _CANDIDATE_OF, _TEMPLATE_OF, _ncc_index


def ncc_terms_batch(regions: np.ndarray) -> np.ndarray:
    """`subpixel._ncc_terms` of many points: (n, 2, w, w + 5) regions (left around xl, right around
    xl - d0, columns x - h - 2 .. x + h + 3; any integer dtype) -> (n, 2, 26) int64
    [N-scaled E_W | N-scaled 2X] of the 13 candidates of each direction."""
    w = regions.shape[2]
    regs = regions.astype(np.float64)
    ext = np.concatenate((regs[..., :-1] + regs[..., 1:], 2 * regs[..., :-1]), axis=-1)  # (n, 2, w, 2w+8)
    windows, tmpl_cols, rows, pair_cols = _ncc_index(w)
    s1, s2 = np.stack((ext.sum(axis=2), (ext * ext).sum(axis=2))) @ windows           # (n, 2, 9) each
    prod = np.matmul(ext[..., tmpl_cols].transpose(0, 1, 3, 2), ext[:, ::-1])        # (n, 2, 2w, 2w+8)
    cross = prod[:, :, rows, pair_cols].sum(axis=-1)                                  # (n, 2, 13)
    n = w * w
    s1_w, s2_w = s1[:, ::-1][..., _CANDIDATE_OF], s2[:, ::-1][..., _CANDIDATE_OF]
    terms = np.concatenate((n * s2_w - s1_w * s1_w, 2 * (n * cross - s1[..., _TEMPLATE_OF] * s1_w)), axis=-1)
    return terms.astype(np.int64)


def vertex_fits_q(curves: np.ndarray, firsts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`subpixel.gauss_fit_q` along the last axis: (..., L) int64 log curves, (...) disparity of
    each curve's first entry -> (Q10 fits, ok). ok is False where the first minimum is at an end,
    the curve does not open upwards, or the vertex lies more than one sample away (fit undefined)."""
    size = curves.shape[-1]
    k = curves.argmin(axis=-1)                                    # the first minimum, as list.index
    ok = (k > 0) & (k < size - 1)
    kc = np.clip(k, 1, size - 2)[..., None]
    ym, y0, yp = (np.take_along_axis(curves, kc + o, axis=-1)[..., 0] for o in (-1, 0, 1))
    num, den = ym - yp, 2 * (ym - 2 * y0 + yp)
    ok &= (den > 0) & (np.abs(num) <= den)
    den = np.where(ok, den, 1)
    scaled = num << FIT_BITS
    q = (2 * np.abs(scaled) + den) // (2 * den)                  # fixedpoint.div_round
    return ((firsts + k) << FIT_BITS) + np.where(scaled >= 0, q, -q), ok


def gauss6_q8_batch(left_bands: Sequence[np.ndarray], right_bands: Sequence[np.ndarray],
                    xls: Sequence[int], d0s: Sequence[int]) -> list[int | None]:
    """`match._gauss6` (integer) of each point: the Q8 disparity of the six-pass Gaussian
    cancellation around d0s[i] for the window at column xls[i] of the w-row bands, or None where
    the per-point routine gives None. Needs columns x - h - 2 .. x + h + 3 of both bands (the
    caller's border gate, `match.match_gate`)."""
    if not len(xls):
        return []
    h = left_bands[0].shape[0] // 2
    regions = np.stack([np.stack((a[:, x - h - 2:x + h + 4], b[:, x - d - h - 2:x - d + h + 4]))
                        for a, b, x, d in zip(left_bands, right_bands, xls, d0s, strict=True)])
    terms = ncc_terms_batch(regions)
    positive = terms.min(axis=(1, 2)) > 0
    logs = log2_q(np.where(positive[:, None, None], terms, 1))
    y = logs[..., :13] - 2 * logs[..., 13:]                       # (n, 2, 13): LR row, RL row
    d0 = np.asarray(d0s, dtype=np.int64)
    first = np.stack((d0 - 2, -d0 - 2), axis=1)                   # LR passes start at d0-2, RL at -d0-2
    fits_a, ok_a = vertex_fits_q(y[..., 4::-1], first)            # LR-A, RL-A: (n, 2)
    fits_b, ok_b = vertex_fits_q(y[..., 8:4:-1], first)           # LR-B, RL-B
    fits_m, ok_m = vertex_fits_q(y[..., 12:8:-1], first)          # LR-B', RL-B'
    ok = positive & ok_a.all(axis=1) & ok_b.all(axis=1) & ok_m.all(axis=1)
    eight_d = (2 * (fits_a[:, 0] - fits_a[:, 1]) + fits_b[:, 0] - fits_b[:, 1]     # subpixel.symmetric6_q8
               + fits_m[:, 0] - fits_m[:, 1])
    values = round_shift_array(eight_d, FIT_BITS + 3 - SUBPIX_BITS).tolist()
    return [v if good else None for v, good in zip(values, ok.tolist(), strict=True)]


__all__ = ["gauss6_q8_batch", "ncc_terms_batch", "vertex_fits_q"]
