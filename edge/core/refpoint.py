"""Sub-pixel reference point: follow a left-image point from one frame to the next.

The thesis kept the left (reference) point at whole pixels, so every re-anchoring of the track
jumped the window by up to half a pixel (docs/method.md, "What the thesis measured", item 3). Here the
point moves at sub-pixel precision:

1. integer 2-D search: ZSSD of the previous frame's window (at the rounded point) against every
   offset (u, v) in a (2r+1)^2 neighbourhood of the current frame (exact integer costs, one
   row curve per v), optionally around a predicted motion;
2. validity: minimum strictly inside the square, best other local minimum at least min_ratio x
   the best, texture enough in both directions;
3. separable sub-pixel fits with the same machinery as the stereo matcher (`match.refine`):
   along x on the rows at the best v, and along y on the transposed images at the best u,
   each with the both-way half-pixel cancellation by default.

Convention: cur(x + dx, y + dy) = prev(x, y); the motion found for the window at
(round(x), round(y)) is attributed to (x, y) (as in `match_point`), so the new point is
(x + dx, y + dy).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from edge.core.costs import cost_curve, gradient_energy
from edge.core.fixedpoint import SUBPIX_BITS, from_q
from edge.core.match import NO_BRACKET, CostArithmetic, check_images, refine, round_half_away


@dataclass(frozen=True)
class FollowResult:
    """Result of `follow_point`: the point's position in the current frame."""

    valid: bool
    x_px: float
    y_px: float
    dx_px: float
    dy_px: float
    cost: float = math.nan
    sigma_x_px: float = math.inf
    sigma_y_px: float = math.inf
    reason: str = ""


def _fail(reason: str, x: float = math.nan, y: float = math.nan, sx: float = math.inf,
          sy: float = math.inf) -> FollowResult:
    return FollowResult(False, x, y, math.nan, math.nan, math.nan, sx, sy, reason)


def _second_ratio_2d(costs: np.ndarray, iy: int, ix: int) -> float:
    """Best 4-neighbour local minimum outside the 3x3 around (iy, ix), over the best cost."""
    padded = np.pad(costs.astype(np.float64), 1, constant_values=np.inf)
    c = padded[1:-1, 1:-1]
    is_min = ((c <= padded[:-2, 1:-1]) & (c <= padded[2:, 1:-1])
              & (c <= padded[1:-1, :-2]) & (c <= padded[1:-1, 2:]))
    is_min[max(0, iy - 1):iy + 2, max(0, ix - 1):ix + 2] = False
    if not is_min.any():
        return math.inf
    second, best = float(c[is_min].min()), float(costs[iy, ix])
    if best <= 0:
        return math.inf if second > 0 else 1.0
    return second / best


def _axis_fit(arith: CostArithmetic, a_band: np.ndarray, b_band: np.ndarray, xa: int, d0: int,
              method: str) -> tuple[float | None, str]:
    """Sub-pixel shift d (b(x - d) = a(x)) around the integer d0, in px."""
    # only the parabola needs the plain 3-point curve; cancellation builds its own passes
    costs = arith.curve(a_band, b_band, xa, d0 - 1, d0 + 1) if method == "parabola" else np.zeros(3)
    value, reason = refine(arith, a_band, b_band, xa, d0 - 1, costs, 1, method)
    if value is None:
        return None, reason
    return (float(value) if arith.is_float else from_q(int(value), SUBPIX_BITS)), ""


def _curve_fit(arith: CostArithmetic, a_band: np.ndarray, b_band: np.ndarray, xa: int, d0: int,
               costs: np.ndarray) -> tuple[float | None, str]:
    """`_axis_fit` (parabola) on the 3-point curve for d0 - 1 .. d0 + 1 already at hand."""
    value, reason = refine(arith, a_band, b_band, xa, d0 - 1, costs, 1, "parabola")
    if value is None:
        return None, reason
    return (float(value) if arith.is_float else from_q(int(value), SUBPIX_BITS)), ""


@dataclass(frozen=True, slots=True)
class FollowSite:
    """Where one follow searches: the point, its window centre and the rounded predicted motion."""

    xf: float
    yf: float
    xi: int
    yi: int
    pu: int
    pv: int


def follow_site(prev: np.ndarray, cur: np.ndarray, x: float, y: float, window: int, search_radius: int,
                predicted_dx: float, predicted_dy: float) -> FollowSite | FollowResult:
    """The search of `follow_point` for (x, y), or the failed FollowResult saying why there is none."""
    if window < 3 or window % 2 == 0 or search_radius < 1:
        raise ValueError("window must be odd >= 3 and search_radius >= 1")
    problem = check_images(prev, cur)
    if problem:
        return _fail(problem)
    try:
        xf, yf = float(x), float(y)
        pu, pv = round_half_away(float(predicted_dx)), round_half_away(float(predicted_dy))
    except (TypeError, ValueError, OverflowError):
        return _fail("point or prediction is not a finite number")
    if not (math.isfinite(xf) and math.isfinite(yf)):
        return _fail("point is not finite", xf, yf)
    height, width = prev.shape
    h, r = window // 2, search_radius
    xi, yi = round_half_away(xf), round_half_away(yf)
    m = h + 4                       # window + the half-pixel passes' margin + the second fit
    if (min(xi, xi + pu) - r - m < 0 or max(xi, xi + pu) + r + m >= width
            or min(yi, yi + pv) - r - m < 0 or max(yi, yi + pv) + r + m >= height):
        return _fail("point too close to the image border for window and search", xf, yf)
    return FollowSite(xf, yf, xi, yi, pu, pv)


def texture_sigmas(gx: int, gy: int, noise_dn: float) -> tuple[float, float]:
    """Predicted 1-sigma of the follow in x and y from the window's gradient energies
    (sum G^2, G = 2 I' as `gradient_energy` gives it)."""
    sx = noise_dn * math.sqrt(8.0 / gx) if gx else math.inf        # sqrt(2 / sum Ix^2)
    sy = noise_dn * math.sqrt(8.0 / gy) if gy else math.inf
    return sx, sy


def follow_point(prev: np.ndarray, cur: np.ndarray, x: float, y: float, *, window: int = 15,
                search_radius: int = 4, predicted_dx: float = 0.0, predicted_dy: float = 0.0,
                subpixel: str = "cancel", noise_dn: float = 1.0, min_ratio: float = 1.1,
                max_sigma_px: float = 0.3, impl: str = "int") -> FollowResult:
    """Where did point (x, y) of `prev` go in `cur`? See the module doc."""
    site = follow_site(prev, cur, x, y, window, search_radius, predicted_dx, predicted_dy)
    if isinstance(site, FollowResult):
        return site
    xi, yi, h, r = site.xi, site.yi, window // 2, search_radius
    gx = gradient_energy(prev[yi - h:yi + h + 1], xi - h, window)
    gy = gradient_energy(prev.T[xi - h:xi + h + 1], yi - h, window)
    sx, sy = texture_sigmas(gx, gy, noise_dn)
    if not (sx <= max_sigma_px and sy <= max_sigma_px):
        return _fail("too little texture in x or y", site.xf, site.yf, sx, sy)

    arith = CostArithmetic(impl, "zssd")
    template = prev[yi - h:yi + h + 1, xi - h:xi + h + 1]
    x0 = xi + site.pu - r - h
    rows = cur[yi + site.pv - r - h:yi + site.pv + r + h + 1, x0:x0 + window + 2 * r]
    bands = sliding_window_view(rows, window, axis=0).transpose(0, 2, 1)   # (2r+1, w, w+2r)
    if impl == "int":
        costs = cost_curve(template, bands, "zssd")                # [v index, u index], one call
    else:
        costs = np.stack([arith.curve_fn(template.astype(arith.dtype), band.astype(arith.dtype))
                          for band in bands])
    return finish_follow(prev, cur, site, costs, (sx, sy), arith, window=window,
                         search_radius=search_radius, subpixel=subpixel, min_ratio=min_ratio)


def finish_follow(prev: np.ndarray, cur: np.ndarray, site: FollowSite, costs: np.ndarray,
                  sigmas: tuple[float, float], arith: CostArithmetic, *, window: int, search_radius: int,
                  subpixel: str, min_ratio: float, best: tuple[int, int] | None = None,
                  ratio: float | None = None, curves_from_costs: bool = False,
                  axis_fits: tuple[list, list] | None = None) -> FollowResult:
    """`follow_point` after the integer search: validity gates and the separable sub-pixel fits.

    costs[v index, u index] is the (2r+1)^2 cost square; `best` (the (v, u) index of its first
    minimum) and `ratio` (its second-best ratio) when already known. curves_from_costs: take the
    parabola fits' 3-point curves from the square (the same integers: ZSSD of the transposed
    windows is that of the windows) instead of recomputing them. axis_fits (parabola only): those
    fits already made, `refine`'s Q8 values ([[rows v0 - 1 .. v0 + 1], [columns u0 - 1 .. u0 + 1]],
    [the same: whether each has one]); edge.core.batchmatch fits many points at once."""
    xf, yf, xi, yi = site.xf, site.yf, site.xi, site.yi
    sx, sy = sigmas
    h, r = window // 2, search_radius
    if best is None:
        # cast: costs is 2-D, so unravel_index gives (v, u); numpy's stubs cannot say so
        best = cast(tuple[int, int],
                    tuple(int(i) for i in np.unravel_index(int(np.argmin(costs)), costs.shape)))
    iy, ix = best
    if not (0 < iy < 2 * r and 0 < ix < 2 * r):
        return _fail("minimum on the edge of the search square", xf, yf, sx, sy)
    if ratio is None:
        ratio = _second_ratio_2d(costs, iy, ix)
    if ratio < min_ratio:
        return _fail(f"ambiguous: second-best cost only {ratio:.3f}x the best", xf, yf, sx, sy)
    u0, v0 = site.pu - r + ix, site.pv - r + iy
    a_rows, prev_t, cur_t = prev[yi - h:yi + h + 1], prev.T, cur.T
    from_costs = curves_from_costs and subpixel == "parabola"

    def along_x(v: int) -> tuple[float | None, str]:      # motion u on the rows at offset v
        if axis_fits is not None and subpixel == "parabola":
            return _negated(_q8_fit(axis_fits[0][0][v - v0 + 1], axis_fits[1][0][v - v0 + 1]))
        b_rows = cur[yi + v - h:yi + v + h + 1]
        if from_costs:                                     # d = -u ascending: u = u0+1, u0, u0-1
            k = v - site.pv + r
            return _negated(_curve_fit(arith, a_rows, b_rows, xi, -u0, costs[k, ix - 1:ix + 2][::-1]))
        return _negated(_axis_fit(arith, a_rows, b_rows, xi, -u0, subpixel))

    def along_y(u: int) -> tuple[float | None, str]:      # motion v on the columns at offset u
        if axis_fits is not None and subpixel == "parabola":
            return _negated(_q8_fit(axis_fits[0][1][u - u0 + 1], axis_fits[1][1][u - u0 + 1]))
        a_cols, b_cols = prev_t[xi - h:xi + h + 1], cur_t[xi + u - h:xi + u + h + 1]
        if from_costs:
            k = u - site.pu + r
            return _negated(_curve_fit(arith, a_cols, b_cols, yi, -v0, costs[iy - 1:iy + 2, k][::-1]))
        return _negated(_axis_fit(arith, a_cols, b_cols, yi, -v0, subpixel))

    # separable fits at the integer offsets, then again one row/column further towards the
    # fractional offset; the estimate is linear in the cross-axis offset for a quadratic cost
    # surface, so interpolating the two removes the cross-term bias (note §1.6)
    u_a, why_u = along_x(v0)
    v_a, why_v = along_y(u0)
    if u_a is None or v_a is None:
        return _fail(why_u or why_v, xf, yf, sx, sy)
    ty, tx = v_a - v0, u_a - u0
    u_b, why_u = along_x(v0 + (1 if ty >= 0 else -1))
    v_b, why_v = along_y(u0 + (1 if tx >= 0 else -1))
    if u_b is None or v_b is None:
        return _fail(why_u or why_v, xf, yf, sx, sy)
    u = u_a + abs(ty) * (u_b - u_a)
    v = v_a + abs(tx) * (v_b - v_a)
    cost = float(costs[iy, ix]) * (window * window if arith.is_float else 1)
    return FollowResult(True, xf + u, yf + v, u, v, cost, sx, sy, "")


def _q8_fit(value: int, ok: bool) -> tuple[float | None, str]:
    """`_curve_fit`'s result from refine's Q8 parabola fit (not ok: the curve brackets no minimum)."""
    return (from_q(value, SUBPIX_BITS), "") if ok else (None, NO_BRACKET)


def _negated(fit: tuple[float | None, str]) -> tuple[float | None, str]:
    d, why = fit
    return (None if d is None else -d), why
