"""Batched matching: the integer searches of many points' `follow_point` and `match_point` in a
few numpy operations, for a pipeline that follows and matches every track once per pair.

Why: a 15x15 window's search is a few thousand multiply-adds, but each numpy call costs
5-30 us whatever its size, so one point's search (a dozen calls) was mostly call overhead and
the pipeline's cost grew by ~0.4 ms per track (tools/bench). Here the windows and search bands
of all points are gathered into stacked arrays and their integer cost curves (match) and cost
squares (follow) computed in one batched product each; the second-best ratios of the squares
are vectorised too. What remains per point is the part after the integer search, done by the
same functions the per-point routines use (`refpoint.finish_follow`, `match.finish_match`: the
gates and the sub-pixel fit, so the sub-pixel method of match.py/subpixel.py carries over), and
the parabola fits of the follow read their 3-point curves off the cost square instead of
recomputing them.

Results are bit-identical to `follow_point` / `match_point` with impl="int" (the per-point
functions stay the reference; tests/edge/core/test_batchmatch.py checks equality with
hypothesis): all costs are exact integers in float64 (every partial sum < 2**53, see
costs.py), so the batched summation order cannot change them. Points the fast path does not
cover (bad images, non-finite values, borders, too little texture, empty ranges) are handed to
the per-point function, which gives the reason.
"""

from __future__ import annotations

import inspect
import math
from collections import defaultdict
from collections.abc import Sequence
from typing import Any, cast

import cv2
import numpy as np
from numpy.lib.stride_tricks import as_strided

from edge.core import native
from edge.core.batchsubpix import gauss6_q8_batch, parabola3_q8
from edge.core.costs import COSTS
from edge.core.fixedpoint import SUBPIX_BITS, from_q
from edge.core.match import (
    NO_BRACKET,
    CostArithmetic,
    Match,
    _invalid,
    check_images,
    finish_match,
    match_gate,
    match_point,
    round_half_away,
    search_range,
    subpixel_methods,
)
from edge.core.refpoint import (
    FollowResult,
    FollowSite,
    _fail,
    finish_follow,
    follow_point,
    follow_site,
    texture_sigmas,
)

# from this many follows on, their parabola fits are vectorised (_axis_fits: ~25 numpy calls); fewer
# fit them one by one off the cost squares (finish_follow's own path; the same values)
AXIS_FITS_MIN = 5
_NO_COST = np.iinfo(np.int64).max  # above every cost: masks entries out of a minimum
_MATCH_SUBPIXEL = inspect.signature(match_point).parameters["subpixel"].default  # match_points follows it


def batch_costs(templates: np.ndarray, regions: np.ndarray, cost: str = "zssd") -> np.ndarray:
    """Integer cost of each template against every window of its region: (n, h, w) uint8 templates,
    (n, H, W) uint8 regions -> (n, H - h + 1, W - w + 1) int64, entry [k, v, u] for the window at row
    v, column u of region k. The same integers as `costs.cost_curve` on each row of windows
    (SSD = sum T^2 - 2 sum T*R + sum R^2, ZSSD = N SSD - (sum T - sum R)^2), computed in floating
    point on 8-bit data where every partial sum is an integer the format holds exactly."""
    n_items, h, w = templates.shape
    height, width = regions.shape[1:]
    nv, nu = height - h + 1, width - w + 1
    # cross-correlation: one product per item of the template's columns with all its rows of
    # windows, [k, j] = sum_i T[i, k] R[v + i, j]; the diagonal sums over k give sum T*R at u = j - k.
    # A product entry is an integer <= h 255^2 and a diagonal sum one <= h w 255^2: float32 holds
    # them exactly below 2**24, which halves the product's cost, so the product is float32 for any
    # window up to 258 rows, and the diagonal sums are too up to 16 x 16 (float64 beyond)
    exact = np.float32 if h * 255 * 255 < 2**24 else np.float64
    summed = np.float32 if h * w * 255 * 255 < 2**24 else np.float64
    # rows[k, i, v, j] = R[k, v + i, j]: the windows' rows as a strided view (what sliding_window_view
    # makes, without its ~10 us of argument handling per call)
    region = regions.astype(exact)
    s_item, s_row, s_col = region.strides
    rows = as_strided(region, (n_items, h, nv, width), (s_item, s_row, s_row, s_col), writeable=False)
    prod = np.matmul(templates.astype(exact).transpose(0, 2, 1), rows.reshape(n_items, h, nv * width))
    # the diagonal sums in one reduction over a strided view: entry [i, k, v, u] is prod[i, k, v, u + k]
    # (summed in `summed`, where every partial sum is an exact integer, so the order cannot matter)
    prod = prod.reshape(n_items, w, nv, width)
    s_item, s_col, s_row, s_u = prod.strides
    diagonals = as_strided(prod, (n_items, w, nv, nu), (s_item, s_col + s_u, s_row, s_u), writeable=False)
    cross = diagonals.sum(axis=1, dtype=summed)
    t = templates.astype(np.float64)
    # window sums of R and R^2 from one integral image of the regions stacked (h zero rows below
    # so every item's windows have their bottom corner row); rectangles never cross items
    stacked = np.zeros((n_items * height + h, width), np.uint8)
    stacked[:n_items * height] = regions.reshape(n_items * height, width)
    integrals = np.stack(cv2.integral2(stacked, sdepth=cv2.CV_64F, sqdepth=cv2.CV_64F))
    top = integrals[:, :n_items * height].reshape(2, n_items, height, width + 1)[:, :, :nv]
    bottom = integrals[:, h:h + n_items * height].reshape(2, n_items, height, width + 1)[:, :, :nv]
    rows_sum = bottom - top
    box = rows_sum[..., w:] - rows_sum[..., :-w]                      # (2, n, nv, nu)
    ssd = (t * t).sum(axis=(1, 2))[:, None, None] - 2.0 * cross.astype(np.float64) + box[1]
    if cost != "ssd":
        diff = t.sum(axis=(1, 2))[:, None, None] - box[0]
        ssd = (h * w) * ssd - diff * diff
    return ssd.astype(np.int64)


def _second_ratios(costs: np.ndarray, iy: np.ndarray, ix: np.ndarray) -> list[float]:
    """`refpoint._second_ratio_2d` of each (n, s, s) cost square around its (iy, ix)."""
    n, s = costs.shape[0], costs.shape[1]
    c = costs
    is_min = np.ones(c.shape, dtype=bool)           # not above any 4-neighbour (none beyond the edges)
    is_min[:, 1:] &= c[:, 1:] <= c[:, :-1]
    is_min[:, :-1] &= c[:, :-1] <= c[:, 1:]
    is_min[:, :, 1:] &= c[:, :, 1:] <= c[:, :, :-1]
    is_min[:, :, :-1] &= c[:, :, :-1] <= c[:, :, 1:]
    k = np.arange(s)
    near = ((np.abs(k[None, :] - iy[:, None]) <= 1)[:, :, None]
            & (np.abs(k[None, :] - ix[:, None]) <= 1)[:, None, :])
    is_min &= ~near
    return _ratios(c.reshape(n, -1), is_min.reshape(n, -1), costs[np.arange(n), iy, ix].tolist())


def _ratios(costs: np.ndarray, is_min: np.ndarray, best: list[int]) -> list[float]:
    """Per row: the least cost where is_min, over the best (inf without one; the reference's rules)."""
    second = np.where(is_min, costs, _NO_COST).min(axis=1).tolist()
    out = []
    # cast: numpy's stubs type .any(axis=...) as bool | ndarray
    for any_min, sec, b in zip(cast(np.ndarray, is_min.any(axis=1)).tolist(), second, best, strict=True):
        if not any_min:
            out.append(math.inf)
        elif b <= 0:
            out.append(math.inf if sec > 0 else 1.0)
        else:
            out.append(float(sec) / float(b))
    return out


def track_points(prevs: Sequence[np.ndarray], curs: Sequence[np.ndarray], xs: Sequence[float],
                 ys: Sequence[float], predicted_dxs: Sequence[float], predicted_dys: Sequence[float], *,
                 window: int = 15, search_radius: int = 4, subpixel: str = "cancel", noise_dn: float = 1.0,
                 min_ratio: float = 1.1, max_sigma_px: float = 0.3) -> list[FollowResult]:
    """`follow_point(prevs[i], curs[i], xs[i], ys[i], predicted_dx=..., predicted_dy=...)` (impl="int")
    for every i, the integer searches batched; bit-identical results."""
    kw: dict[str, Any] = dict(window=window, search_radius=search_radius, subpixel=subpixel,
                              noise_dn=noise_dn, min_ratio=min_ratio, max_sigma_px=max_sigma_px)
    n = len(prevs)
    kernels = native.kernels
    if kernels is not None and subpixel == "parabola" and n:
        return _track_points_native(kernels, prevs, curs, xs, ys, predicted_dxs, predicted_dys, kw)
    out: list[FollowResult | None] = [None] * n
    h, r = window // 2, search_radius
    side = window + 2 * r
    fast: list[tuple[int, FollowSite]] = []
    regions = np.empty((n, window + 2, window + 2), np.uint8)     # the windows + 1 all round
    searched = np.empty((n, side, side), np.uint8)                 # the search squares
    for i in range(n):
        site = follow_site(prevs[i], curs[i], xs[i], ys[i], window, search_radius, predicted_dxs[i],
                           predicted_dys[i])
        if isinstance(site, FollowResult):
            out[i] = site
            continue
        xi, yi, x0, y0 = site.xi, site.yi, site.xi + site.pu - r - h, site.yi + site.pv - r - h
        regions[len(fast)] = prevs[i][yi - h - 1:yi + h + 2, xi - h - 1:xi + h + 2]
        searched[len(fast)] = curs[i][y0:y0 + side, x0:x0 + side]
        fast.append((i, site))
    if fast:
        region = regions[:len(fast)].astype(np.int32)
        gx = region[:, 1:-1, 2:] - region[:, 1:-1, :-2]          # = gradient_energy of the window rows
        gy = region[:, 2:, 1:-1] - region[:, :-2, 1:-1]          # ... and of its columns
        energy_x, energy_y = (gx * gx).sum(axis=(1, 2)).tolist(), (gy * gy).sum(axis=(1, 2)).tolist()
        keep, sigmas = [], []
        for k, (i, _) in enumerate(fast):
            sx, sy = texture_sigmas(energy_x[k], energy_y[k], noise_dn)
            if sx <= max_sigma_px and sy <= max_sigma_px:
                keep.append(k)
                sigmas.append((sx, sy))
            else:                                       # the reference says why (rare: flat windows)
                out[i] = follow_point(prevs[i], curs[i], xs[i], ys[i], predicted_dx=predicted_dxs[i],
                                     predicted_dy=predicted_dys[i], **kw)
        if keep:
            every = len(keep) == len(fast)
            costs = batch_costs(region[:, 1:-1, 1:-1] if every else region[keep, 1:-1, 1:-1],
                                searched[:len(fast)] if every else searched[keep], "zssd")
            flat_best = costs.reshape(len(keep), -1).argmin(axis=1)
            iy, ix = np.divmod(flat_best, 2 * r + 1)
            ratios = _second_ratios(costs, iy, ix)
            sites = [fast[k][1] for k in keep]
            vectorised = subpixel == "parabola" and len(keep) >= AXIS_FITS_MIN
            fits = _axis_fits(costs, iy, ix, sites, r) if vectorised else None
            arith = CostArithmetic("int", "zssd")
            for j, (k, v, u) in enumerate(zip(keep, iy.tolist(), ix.tolist(), strict=True)):
                i, site = fast[k]
                out[i] = finish_follow(prevs[i], curs[i], site, costs[j], sigmas[j], arith, window=window,
                                       search_radius=search_radius, subpixel=subpixel, min_ratio=min_ratio,
                                       best=(v, u), ratio=ratios[j], curves_from_costs=True,
                                       axis_fits=None if fits is None else fits[j])
    return out  # type: ignore[return-value]


def _floats(values: Sequence[Any]) -> np.ndarray | None:
    """float64 array of the values (None: one is not a real number; the caller takes the reference)."""
    try:
        return np.array(values, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        return None


def _track_points_native(kernels: Any, prevs: Sequence[np.ndarray], curs: Sequence[np.ndarray],
                         xs: Sequence[float], ys: Sequence[float], predicted_dxs: Sequence[float],
                         predicted_dys: Sequence[float], kw: dict[str, Any]) -> list[FollowResult]:
    """`track_points` by the compiled follow (native/src/follow.c, bit-identical): points off its
    fast path (bad images or numbers, borders, too little texture) go to `follow_point`."""
    n = len(prevs)
    x, y, pdx, pdy = (_floats(v) for v in (xs, ys, predicted_dxs, predicted_dys))
    if x is None or y is None or pdx is None or pdy is None or x.shape != (n,):
        return [follow_point(prevs[i], curs[i], xs[i], ys[i], predicted_dx=predicted_dxs[i],
                             predicted_dy=predicted_dys[i], **kw) for i in range(n)]
    status = np.empty(n, np.int32)
    values = np.empty((n, 8))
    kernels.follow(prevs, curs, x, y, pdx, pdy, kw["window"], kw["search_radius"], float(kw["noise_dn"]),
                   float(kw["min_ratio"]), float(kw["max_sigma_px"]), status, values)
    out: list[FollowResult] = []
    for i, (code, row) in enumerate(zip(status.tolist(), values.tolist(), strict=True)):
        if code == native.FOLLOW_VALID:
            out.append(FollowResult(True, row[0], row[1], row[2], row[3], row[4], row[5], row[6], ""))
            continue
        if code == native.FOLLOW_REFERENCE:
            out.append(follow_point(prevs[i], curs[i], xs[i], ys[i], predicted_dx=predicted_dxs[i],
                                    predicted_dy=predicted_dys[i], **kw))
            continue
        xf, yf = float(xs[i]), float(ys[i])
        if code == native.FOLLOW_EDGE:
            reason = "minimum on the edge of the search square"
        elif code == native.FOLLOW_AMBIGUOUS:
            reason = f"ambiguous: second-best cost only {row[7]:.3f}x the best"
        else:
            reason = NO_BRACKET
        out.append(_fail(reason, xf, yf, row[5], row[6]))
    return out


def _axis_fits(costs: np.ndarray, iy: np.ndarray, ix: np.ndarray, sites: list[FollowSite],
               r: int) -> list[tuple[list, list] | None]:
    """The parabola fits `finish_follow` may need, off each (n, s, s) cost square around its minimum
    (iy, ix), as `refine` finds them: ([[Q8 fits along x on the rows iy - 1 .. iy + 1], [... along y
    on the columns ix - 1 .. ix + 1]], [[whether each has one], [...]]). None for a minimum on the
    square's edge (finish_follow refuses it before any fit)."""
    n, s = costs.shape[0], costs.shape[1]
    cy, cx = np.minimum(np.maximum(iy, 1), s - 2), np.minimum(np.maximum(ix, 1), s - 2)
    near = np.arange(-1, 2)
    block = costs[np.arange(n)[:, None, None], (cy[:, None] + near)[:, :, None],
                  (cx[:, None] + near)[:, None, :]]                               # (n, 3, 3)
    # the row fits take d = -u ascending (u = u0 + 1, u0, u0 - 1) around d0 = -u0; the columns alike
    curves = np.stack((block[:, :, ::-1], block[:, ::-1, :].transpose(0, 2, 1)), axis=1)    # (n, 2, 3, 3)
    d0 = np.stack((np.array([site.pu for site in sites]) - r + ix,
                   np.array([site.pv for site in sites]) - r + iy), axis=1)
    q8, ok = parabola3_q8(curves, -d0[:, :, None])
    edge = ((iy != cy) | (ix != cx)).tolist()
    fits = zip(q8.tolist(), ok.tolist(), strict=True)
    return [None if e else fit for e, fit in zip(edge, fits, strict=True)]


def match_points(lefts: Sequence[np.ndarray], rights: Sequence[np.ndarray], xs: Sequence[float],
                 ys: Sequence[float], max_disparities: Sequence[int],
                 predicted_disparities: Sequence[float | None], *, window: int = 15,
                 search_radius: int | None = None, cost: str = "zssd", subpixel: str | None = None,
                 noise_dn: float = 1.0, min_ratio: float = 1.1, max_sigma_px: float = 0.3) -> list[Match]:
    """`match_point(lefts[i], rights[i], xs[i], ys[i], max_disparity=..., predicted_disparity=...)`
    (impl="int", min_disparity=0) for every i, the cost curves batched; bit-identical results.
    `search_radius` applies to the points that have a prediction (None: match_point's default);
    subpixel None is match_point's default method."""
    n = len(lefts)
    subpixel = _MATCH_SUBPIXEL if subpixel is None else subpixel

    def reference(i: int) -> Match:
        pred = predicted_disparities[i]
        return match_point(lefts[i], rights[i], xs[i], ys[i], window=window, max_disparity=max_disparities[i],
                           predicted_disparity=pred, search_radius=None if pred is None else search_radius,
                           cost=cost, subpixel=subpixel, noise_dn=noise_dn, min_ratio=min_ratio,
                           max_sigma_px=max_sigma_px)

    if cost not in COSTS or subpixel not in subpixel_methods() or window < 3 or window % 2 == 0:
        return [reference(i) for i in range(n)]        # raises ValueError as match_point does
    kernels = native.kernels
    if kernels is not None and n:
        return _match_points_native(kernels, lefts, rights, xs, ys, max_disparities, predicted_disparities,
                                    reference, window=window, search_radius=search_radius, cost=cost,
                                    subpixel=subpixel, noise_dn=noise_dn, min_ratio=min_ratio,
                                    max_sigma_px=max_sigma_px)
    out: list[Match | None] = [None] * n
    h = window // 2
    sites, gathered = [], []
    for i in range(n):
        site = _match_site(lefts[i], rights[i], xs[i], ys[i], predicted_disparities[i], h)
        if site is None:
            out[i] = reference(i)
            continue
        xf, yf, xi, yi = site
        sites.append((i, xf, yf, xi, yi))
        gathered.append(lefts[i][yi - h:yi + h + 1, xi - h - 1:xi + h + 2])
    if not sites:
        return out  # type: ignore[return-value]
    rows = np.array(gathered, dtype=np.int32)
    g = rows[:, :, 2:] - rows[:, :, :-2]
    energies = (g * g).sum(axis=(1, 2)).tolist()
    searches = []
    for (i, xf, yf, xi, yi), g2 in zip(sites, energies, strict=True):
        sigma = noise_dn * math.sqrt(8.0 / g2) if g2 > 0 else math.inf     # sqrt(2 / sum Ix^2)
        if not sigma <= max_sigma_px:
            out[i] = reference(i)
            continue
        pred = predicted_disparities[i]
        lo, hi = search_range(xi, lefts[i].shape[1], window, 0, int(max_disparities[i]),
                              None if pred is None else float(pred), None if pred is None else search_radius)
        if hi - lo < 2:
            out[i] = reference(i)
            continue
        searches.append((i, xf, yf, xi, yi, lo, hi, sigma, g2 / 4.0))
    arith = CostArithmetic("int", cost)
    searched = []                                     # (item, its curve, k0, ratio, bands)
    for n, items in _share_curves(searches, [r.shape[1] for r in rights], h).items():
        templates = np.empty((len(items), window, window), np.uint8)
        bands = np.empty((len(items), window, window + n - 1), np.uint8)
        for k, (i, _, _, xi, yi, *_, start) in enumerate(items):
            templates[k] = lefts[i][yi - h:yi + h + 1, xi - h:xi + h + 1]
            bands[k] = rights[i][yi - h:yi + h + 1, xi - h - start - n + 1:xi + h + 1 - start]
        curves = batch_costs(templates, bands, cost)[:, 0, ::-1]       # ascending disparity from lo'
        first = np.array([it[5] - it[9] for it in items])
        last = np.array([it[6] - it[9] for it in items])
        k0s, ratios = _curve_minima(curves, first, last)
        for it, curve, a, k0, ratio in zip(items, curves, first.tolist(), k0s, ratios, strict=True):
            # rows: the gathered windows above, a slice of image rows here
            i, rows = it[0], slice(it[4] - h, it[4] + h + 1)  # type: ignore[assignment]
            row_bands = (lefts[i][rows], rights[i][rows])
            searched.append((it, curve[a:a + it[6] - it[5] + 1], k0, ratio, row_bands))
    refined = _refine_gauss(searched, h, [left.shape[1] for left in lefts], subpixel, cost, min_ratio)
    for (it, curve, k0, ratio, (a_band, b_band)), value in zip(searched, refined, strict=True):
        i, xf, yf, xi, yi, lo, hi, sigma, texture, _ = it
        out[i] = finish_match(arith, a_band, b_band, xf, yf, xi, lo, curve, sigma, texture,
                              width=lefts[i].shape[1], subpixel=subpixel, min_ratio=min_ratio, k0=k0,
                              ratio=ratio, noise_dn=noise_dn,
                              refined=None if value is None else (value, ""))
    return out  # type: ignore[return-value]


_NATIVE_REASONS = {  # refine's reasons for the compiled matcher's failures after the gates
    native.MATCH_NO_BRACKET: NO_BRACKET,
    native.MATCH_CANCEL_LR: "half-pixel cancellation pass has no interior minimum",
    native.MATCH_CANCEL_RL: "right-to-left cancellation pass has no interior minimum",
}


def _match_points_native(kernels: Any, lefts: Sequence[np.ndarray], rights: Sequence[np.ndarray],
                         xs: Sequence[float], ys: Sequence[float], max_disparities: Sequence[int],
                         predicted_disparities: Sequence[float | None], reference: Any, *, window: int,
                         search_radius: int | None, cost: str, subpixel: str, noise_dn: float,
                         min_ratio: float, max_sigma_px: float) -> list[Match]:
    """`match_points` by the compiled matcher (native/src/match.c, bit-identical): its gates and
    sub-pixel step for "none", "parabola" and "cancel6-gauss" (with its fallback to the six passes'
    parabola fits); `finish_match` refines for the other methods and `reference` takes the points
    off its fast path."""
    n = len(lefts)
    x, y = _floats(xs), _floats(ys)
    preds = [math.nan if p is None else p for p in predicted_disparities]
    pred = _floats(preds)
    try:
        maxd = np.array([int(d) for d in max_disparities], dtype=np.int64)
    except (TypeError, ValueError, OverflowError):
        maxd = None
    if x is None or y is None or pred is None or maxd is None or x.shape != (n,) or pred.shape != (n,):
        return [reference(i) for i in range(n)]
    for i, p in enumerate(predicted_disparities):   # a prediction that is not finite: the reference says so
        if p is not None and not math.isfinite(pred[i]):
            x[i] = math.nan
    status = np.empty(n, np.int32)
    ints = np.empty((n, 5), np.int64)
    floats = np.empty((n, 3))
    kernels.match(lefts, rights, x, y, maxd, pred, window, -1 if search_radius is None else search_radius,
                  cost == "zssd", native.SUBPIXEL_CODES.get(subpixel, native.SUB_OTHER), float(noise_dn),
                  float(min_ratio), float(max_sigma_px), status, ints, floats)
    out: list[Match] = []
    h = window // 2
    for i, (code, (value, d0, lo, hi, best), (ratio, sigma, texture)) in enumerate(
            zip(status.tolist(), ints.tolist(), floats.tolist(), strict=True)):
        if code == native.MATCH_VALID:
            out.append(Match(True, from_q(value, SUBPIX_BITS), float(best), sigma, "", value, d0, ratio,
                             texture, float(xs[i]), float(ys[i])))
            continue
        if code == native.MATCH_REFERENCE:
            out.append(reference(i))
            continue
        xf, yf = float(xs[i]), float(ys[i])
        xi, width = round_half_away(xf), lefts[i].shape[1]
        if code == native.MATCH_REFINE:                  # gates passed; refine as the reference does
            arith = CostArithmetic("int", cost)
            yi = round_half_away(yf)
            a_band, b_band = lefts[i][yi - h:yi + h + 1], rights[i][yi - h:yi + h + 1]
            curve = arith.curve(a_band, b_band, xi, lo, hi)
            out.append(finish_match(arith, a_band, b_band, xf, yf, xi, lo, curve, sigma, texture, width=width,
                                    subpixel=subpixel, min_ratio=min_ratio, k0=d0 - lo, ratio=ratio,
                                    noise_dn=noise_dn))
            continue
        reason = _NATIVE_REASONS.get(code) or \
            match_gate(window, xi, lo, hi - lo + 1, d0 - lo, ratio, width=width, subpixel=subpixel,
                       min_ratio=min_ratio)
        out.append(_invalid(reason, xf, yf, sigma_px=sigma, texture=texture, disparity_int=d0,
                            second_ratio=ratio, cost=float(best)))
    return out


def _refine_gauss(searched: list[tuple], h: int, widths: list[int], subpixel: str, cost: str,
                  min_ratio: float) -> list[int | None]:
    """`refine`'s Q8 result of each searched point that passes `match_gate` and takes the six-pass
    Gaussian cancellation, all in one batch (edge.core.batchsubpix); None where finish_match is to
    run `refine` itself (other methods, a failed gate, or no Gaussian fit: its parabola fallback)."""
    out: list[int | None] = [None] * len(searched)
    if subpixel != "cancel6-gauss" or cost != "zssd":
        return out
    todo = [j for j, (it, curve, k0, ratio, _) in enumerate(searched)
            if not match_gate(2 * h + 1, it[3], it[5], len(curve), k0, ratio, width=widths[it[0]],
                              subpixel=subpixel, min_ratio=min_ratio)]
    values = gauss6_q8_batch([searched[j][4][0] for j in todo], [searched[j][4][1] for j in todo],
                             [searched[j][0][3] for j in todo],
                             [searched[j][0][5] + searched[j][2] for j in todo])
    for j, value in zip(todo, values, strict=True):
        out[j] = value
    return out


def _share_curves(searches: list[tuple], widths: list[int], h: int) -> dict[int, list[tuple]]:
    """Group the searches (i, ..., lo, hi, ...) by the length n of one batched curve each can use:
    a short range [lo, hi] is widened to n candidates [lo', lo' + n - 1] when its right image holds
    them and n is at most twice its own (the extra candidates are computed, then ignored), so the
    usual few range lengths need one product. Items gain lo' at index 9."""
    groups: dict[int, list[tuple]] = defaultdict(list)
    for it in sorted(searches, key=lambda it: it[6] - it[5], reverse=True):
        i, xi, lo, hi = it[0], it[3], it[5], it[6]
        d_min, d_max = xi + h + 1 - widths[i], xi - h           # candidates inside the right image
        for n in groups:
            start = max(d_min, hi - n + 1)
            if n <= 2 * (hi - lo + 1) and start <= lo and start + n - 1 <= d_max:
                groups[n].append(it + (start,))
                break
        else:
            groups[hi - lo + 1].append(it + (lo,))
    return groups


def _curve_minima(curves: np.ndarray, first: np.ndarray, last: np.ndarray) -> tuple[list[int], list[float]]:
    """First minimum (relative to `first`) and `match.second_best_ratio` of each curve's part
    [first, last] (its ends count as minima)."""
    k = np.arange(curves.shape[1])[None, :]
    inside = (k >= first[:, None]) & (k <= last[:, None])
    k0 = np.where(inside, curves, _NO_COST).argmin(axis=1)
    not_above_right = np.ones(curves.shape, dtype=bool)
    np.less_equal(curves[:, :-1], curves[:, 1:], out=not_above_right[:, :-1])
    not_above_left = np.ones(curves.shape, dtype=bool)
    np.less_equal(curves[:, 1:], curves[:, :-1], out=not_above_left[:, 1:])
    is_min = (inside & (not_above_right | (k == last[:, None])) & (not_above_left | (k == first[:, None]))
              & (np.abs(k - k0[:, None]) > 1))
    ratios = _ratios(curves, is_min, curves[np.arange(len(k0)), k0].tolist())
    return (k0 - first).tolist(), ratios


def _match_site(left: object, right: object, x: object, y: object, pred: object,
                h: int) -> tuple[float, float, int, int] | None:
    """(x, y, round(x), round(y)) of a point the fast path of `match_points` takes, else None."""
    if check_images(left, right):
        return None
    try:
        xf, yf = float(x), float(y)                   # type: ignore[arg-type]
        if pred is not None and not math.isfinite(float(pred)):   # type: ignore[arg-type]
            return None
    except (TypeError, ValueError):
        return None
    if not (math.isfinite(xf) and math.isfinite(yf)):
        return None
    height, width = left.shape                         # type: ignore[attr-defined]
    xi, yi = round_half_away(xf), round_half_away(yf)
    if yi - h < 0 or yi + h >= height or xi - h - 1 < 0 or xi + h + 1 >= width:
        return None
    return xf, yf, xi, yi


__all__ = ["batch_costs", "match_points", "track_points"]
