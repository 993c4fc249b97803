"""Stereo correspondence for one tracked point: integer (Z)SSD search along the epipolar row,
validity gates, and sub-pixel refinement (eq. 3.8/5.1, 5.2 + half-pixel cancellation).

Contract (docs/design.md): `match_point(left, right, x, y, ...) -> Match` on 8-bit rectified images;
Match.disparity_px = x_left - x_right (sub-pixel), Match.cost, Match.valid, plus sigma_px
(predicted 1-sigma), reason (why invalid) and diagnostics.

Sub-pixel left point: the window is centred on the pixel (round(x), round(y)) (half away from
zero) and the disparity found for that window is attributed to (x, y). Disparity is locally
constant on a fronto-parallel hull, so the fraction of x does not change d; it moves the right
point: x_right = x - d (on a slanted surface with disparity gradient g the attribution error is
at most g/2 px).

Sub-pixel methods (`subpixel=`), all on the integer search's outcome (`refine`, so a caller that
searches many points at once reuses it per point):
- "cancel6-gauss" (default): the six symmetric half-pixel passes of `subpixel.symmetric6_q8`,
  each fitted with a Gaussian model of its NCC curve (`subpixel.ncc_log_curves`; ZSSD only,
  with cost="ssd" it is "cancel6"), falling back to the parabola fits where a correlation is not
  positive or a model curve has no interior minimum. Pixel locking cancels without interpolation.
- "cancel": the four Shimizu-Okutomi passes run both ways (left window against the right image,
  and back) and averaged: the one-way version's edge-of-window bias flips sign in the reverse
  direction, so the average removes it. "cancel6": plus the mirrored passes.
- research methods registered by the lab (`register_refiner`): `lab.subpix` adds "refit" (the
  "cancel" estimate, then a resampled refit around zero where pixel locking vanishes). They are not
  in the appliance; asking for one the lab has not registered is a ValueError like any unknown name.
- "parabola" (eq. 5.2, the thesis) and "none" (whole pixel): the thesis's stages.
What each costs and gains is measured by tools/bench-core (docs/decisions.md has the history).

Validity gates (research note §5): enough texture (predicted sigma <= max_sigma_px), a minimum
strictly inside the searched range, the best other local minimum at least `min_ratio` times
the best cost, and a cost curve that brackets the minimum (den > 0). Failures come back as
`valid=False` with a reason, never as an exception; only programming errors (an unknown cost or
method name) raise ValueError.

Real camera pairs: a window fit weights each pixel by ~Ix^2, so on a slanted or curved surface it
reports the disparity at the window's strongest edges, not at its centre. `edge.core.prefilter`'s
x-Sobel prefilters even the weights; they cost accuracy on renders, so they are opt-in (docs/limits.md,
"Real imagery").

`impl` picks the arithmetic: "int" (default, exact integers with the fast cross-correlation),
"int-ref" (the plain int64 definition: bit-identical, slower) or "float" (float64 reference
with mean-subtracted windows and float fits). `match_point_float` is impl="float".
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from edge.core import subpixel as sp
from edge.core.costs import COSTS, cost_curve, cost_curve_float, cost_curve_reference, gradient_energy
from edge.core.fixedpoint import SUBPIX_BITS, from_q

SUBPIXEL_METHODS = ("cancel", "cancel6", "cancel6-gauss", "cancel-oneway", "parabola", "none")
IMPLS = ("int", "int-ref", "float")
DEFAULT_SEARCH_RADIUS = 4
NO_BRACKET = "cost curve does not bracket the minimum (den <= 0)"  # refine's parabola failure


@dataclass(frozen=True)
class Match:
    """Result of `match_point`. Invalid matches carry NaN disparity and a reason."""

    valid: bool
    disparity_px: float
    cost: float
    sigma_px: float
    reason: str = ""
    disparity_q8: int | None = None       # Q8 px (integer paths only)
    disparity_int: int | None = None      # whole-pixel minimum of the search
    second_ratio: float = math.nan        # best other local minimum / best cost
    texture: float = math.nan             # sum of Ix^2 over the left window (DN^2/px^2)
    x_px: float = math.nan
    y_px: float = math.nan

    @property
    def x_right_px(self) -> float:
        """Right-image column of the point: x_left - d."""
        return self.x_px - self.disparity_px


def _invalid(reason: str, x: float = math.nan, y: float = math.nan, **extra: float) -> Match:
    sigma = extra.pop("sigma_px", math.inf)
    cost = extra.pop("cost", math.nan)
    # extra holds Match's float fields and disparity_int (an int): mypy checks every field against float
    return Match(False, math.nan, cost, sigma, reason, x_px=x, y_px=y, **extra)  # type: ignore[arg-type]


def round_half_away(v: float) -> int:
    """Nearest integer, halves away from zero (the window-centre rule for sub-pixel points)."""
    return int(math.copysign(math.floor(abs(v) + 0.5), v))


def check_images(left: object, right: object) -> str:
    """Why a pair of images cannot be matched ('' if it can): 2-D uint8 arrays of one shape."""
    for name, img in (("left", left), ("right", right)):
        if not isinstance(img, np.ndarray):
            return f"{name} image is not a numpy array"
        if img.dtype != np.uint8:
            return f"{name} image must be uint8, got {img.dtype}"
        if img.ndim != 2:
            return f"{name} image must be 2-D (grey), got {img.ndim}-D"
    if left.shape != right.shape:                      # type: ignore[attr-defined]
        return f"image shapes differ: {left.shape} vs {right.shape}"   # type: ignore[attr-defined]
    return ""


class CostArithmetic:
    """The three arithmetic back-ends behind `impl`."""

    def __init__(self, impl: str, cost: str) -> None:
        self.is_float = impl == "float"
        fn = {"int": cost_curve, "int-ref": cost_curve_reference, "float": cost_curve_float}[impl]
        self.curve_fn = partial(fn, cost=cost)
        self.cost = cost
        self.dtype = np.float64 if self.is_float else np.int64

    def curve(self, a_band: np.ndarray, b_band: np.ndarray, xa: int, d_lo: int, d_hi: int) -> np.ndarray:
        """Costs for d = d_lo .. d_hi of the window at column xa of a_band against b_band
        (candidate window at column xa - d)."""
        h = a_band.shape[0] // 2
        template = a_band[:, xa - h:xa + h + 1]
        band = b_band[:, xa - h - d_hi:xa + h + 1 - d_lo]
        if self.is_float:
            template, band = template.astype(np.float64), band.astype(np.float64)
        return self.curve_fn(template, band)[::-1]

    def fit(self, costs: np.ndarray, d_first: int) -> float | int | None:
        return (sp.fit_curve_float if self.is_float else sp.fit_curve_q)(costs, d_first)


Refiner = Callable[..., tuple[float | int | None, str]]
_RESEARCH: dict[str, Refiner] = {}  # research methods the lab registers; none on the appliance


def register_refiner(name: str, refiner: Refiner) -> None:
    """Add a research sub-pixel method: `refiner(arith, a_band, b_band, xa, d_lo, costs, k0, sigma_px,
    noise_dn)` returns what `refine` returns, and may call `refine` for a product method."""
    _RESEARCH[name] = refiner


def subpixel_methods() -> tuple[str, ...]:
    """The product's sub-pixel methods and the research ones registered so far."""
    return SUBPIXEL_METHODS + tuple(_RESEARCH)


def refine(arith: CostArithmetic, a_band: np.ndarray, b_band: np.ndarray, xa: int, d_lo: int,
           costs: np.ndarray, k0: int, method: str, sigma_px: float = math.inf,
           noise_dn: float = 1.0) -> tuple[float | int | None, str]:
    """Sub-pixel disparity around the integer minimum costs[k0] (d0 = d_lo + k0); sigma_px (the
    predicted sigma) and noise_dn (the read noise) are for the research methods (module doc).

    Returns (Q8 int or float px, reason). Cancellation needs d0 - 2 .. d0 + 2 to be searchable."""
    d0 = d_lo + k0
    if method in _RESEARCH:
        return _RESEARCH[method](arith, a_band, b_band, xa, d_lo, costs, k0, sigma_px, noise_dn)
    if method == "none":
        return (float(d0) if arith.is_float else d0 << SUBPIX_BITS), ""
    if method == "parabola":
        fit = arith.fit(costs[k0 - 1:k0 + 2], d0 - 1)
        if fit is None:
            return None, NO_BRACKET
        return (fit if arith.is_float else sp.fit_to_q8(fit)), ""  # type: ignore[arg-type]
    if method == "cancel6-gauss" and arith.cost == "zssd":
        value = _gauss6(arith, a_band, b_band, xa, d0)
        if value is not None:
            return value, ""
        method = "cancel6"                  # no Gaussian through this window: parabola fits
    curves = sp.cancellation_costs(a_band, b_band, xa, d0, arith.cost, arith.is_float,
                                   six=method.startswith("cancel6"))
    a, b, ra, rb = curves[:4]
    fit_a, fit_b = arith.fit(a, d0 - 2), arith.fit(b, d0 - 2)
    if fit_a is None or fit_b is None:
        return None, "half-pixel cancellation pass has no interior minimum"
    if method == "cancel-oneway":
        return (sp.cancel_float(fit_a, fit_b) if arith.is_float else sp.cancel_q8(fit_a, fit_b)), ""  # type: ignore[arg-type]
    fit_ra, fit_rb = arith.fit(ra, -d0 - 2), arith.fit(rb, -d0 - 2)
    if fit_ra is None or fit_rb is None:
        return None, "right-to-left cancellation pass has no interior minimum"
    if method.startswith("cancel6"):
        fit_m, fit_rm = arith.fit(curves[4], d0 - 2), arith.fit(curves[5], -d0 - 2)
        if fit_m is not None and fit_rm is not None:      # else: the four-pass result
            six = sp.symmetric6_float if arith.is_float else sp.symmetric6_q8
            return six(fit_a, fit_b, -fit_ra, -fit_rb, fit_m, -fit_rm), ""  # type: ignore[arg-type]
    if arith.is_float:
        return sp.symmetric_float(fit_a, fit_b, -fit_ra, -fit_rb), ""
    return sp.symmetric_q8(fit_a, fit_b, -fit_ra, -fit_rb), ""  # type: ignore[arg-type]


def _gauss6(arith: CostArithmetic, a_band: np.ndarray, b_band: np.ndarray, xa: int,
            d0: int) -> float | int | None:
    """Six-pass cancellation with the Gaussian model of each pass's NCC curve (Q8 int or float
    px), or None if any pass has no such fit."""
    models = sp.ncc_log_curves(a_band, b_band, xa, d0, arith.is_float)
    if models is None:
        return None
    fit = sp.gauss_fit_float if arith.is_float else sp.gauss_fit_q
    firsts = (d0 - 2, d0 - 2, -d0 - 2, -d0 - 2, d0 - 2, -d0 - 2)
    fits = [fit(m, f) for m, f in zip(models, firsts, strict=True)]
    if any(f is None for f in fits):
        return None
    da, db, ra, rb, dm, rm = fits
    six = sp.symmetric6_float if arith.is_float else sp.symmetric6_q8
    # none is None (checked above); Q8 ints or floats as in refine
    return six(da, db, -ra, -rb, dm, -rm)  # type: ignore[arg-type, operator]


def second_best_ratio(costs: np.ndarray, k0: int) -> float:
    """Best local minimum (or curve end) other than k0 and its neighbours, over costs[k0]."""
    c = costs
    is_min = np.empty(len(c), dtype=bool)
    np.less_equal(c[:-1], c[1:], out=is_min[:-1])          # not above the right neighbour
    is_min[-1] = True
    is_min[1:] &= c[1:] <= c[:-1]                          # not above the left neighbour
    is_min[max(0, k0 - 1):k0 + 2] = False
    others = c[is_min]
    if others.size == 0:
        return math.inf
    second = float(others.min())
    best = float(c[k0])
    if best <= 0:
        return math.inf if second > 0 else 1.0      # two perfect matches: ambiguous
    return second / best


def search_range(x_int: int, width: int, window: int, min_disparity: int, max_disparity: int,
                 predicted_disparity: float | None, search_radius: int | None) -> tuple[int, int]:
    """Evaluated disparities [lo, hi]: the requested range widened by one on each side for the
    fit, clipped to what the right image holds (one spare column for the half-pixel sums)."""
    h = window // 2
    lo, hi = min_disparity, max_disparity
    if predicted_disparity is not None:
        centre = round_half_away(predicted_disparity)
        radius = DEFAULT_SEARCH_RADIUS if search_radius is None else search_radius
        lo, hi = max(lo, centre - radius), min(hi, centre + radius)
    return max(lo - 1, x_int + h + 2 - width), min(hi + 1, x_int - h)


def match_point(left: np.ndarray, right: np.ndarray, x: float, y: float, *, window: int = 15,
                max_disparity: int = 128, min_disparity: int = 0,
                predicted_disparity: float | None = None, search_radius: int | None = None,
                cost: str = "zssd", subpixel: str = "cancel6-gauss", noise_dn: float = 1.0,
                min_ratio: float = 1.1, max_sigma_px: float = 0.3, impl: str = "int") -> Match:
    """Find the right-image match of left point (x, y) along the same row; see the module doc.

    noise_dn: camera read noise (DN) for sigma_px = noise * sqrt(2 / sum Ix^2) (note §1.4).
    predicted_disparity + search_radius (default 4) narrow the search around a prediction
    (intersected with [min_disparity, max_disparity])."""
    if cost not in COSTS or subpixel not in subpixel_methods() or impl not in IMPLS:
        raise ValueError(f"cost must be one of {COSTS}, subpixel one of {subpixel_methods()}, "
                         f"impl one of {IMPLS}")
    if window < 3 or window % 2 == 0:
        raise ValueError(f"window must be odd and >= 3, got {window}")
    if search_radius is not None and predicted_disparity is None:
        raise ValueError("search_radius needs predicted_disparity")
    problem = check_images(left, right)
    if problem:
        return _invalid(problem)
    try:
        xf, yf = float(x), float(y)
    except (TypeError, ValueError):
        return _invalid(f"point ({x!r}, {y!r}) is not numeric")
    if not (math.isfinite(xf) and math.isfinite(yf)):
        return _invalid("point is not finite", xf, yf)
    if predicted_disparity is not None:
        try:
            predicted_disparity = float(predicted_disparity)
        except (TypeError, ValueError):
            return _invalid("predicted disparity is not numeric", xf, yf)
        if not math.isfinite(predicted_disparity):
            return _invalid("predicted disparity is not finite", xf, yf)
    height, width = left.shape
    xi, yi, h = round_half_away(xf), round_half_away(yf), window // 2
    if yi - h < 0 or yi + h >= height or xi - h - 1 < 0 or xi + h + 1 >= width:
        return _invalid("point too close to the image border for the window", xf, yf)
    a_band, b_band = left[yi - h:yi + h + 1], right[yi - h:yi + h + 1]

    g2 = gradient_energy(a_band, xi - h, window)
    texture = g2 / 4.0
    sigma = noise_dn * math.sqrt(8.0 / g2) if g2 > 0 else math.inf     # sqrt(2 / sum Ix^2)
    extra = {"sigma_px": sigma, "texture": texture}
    if not sigma <= max_sigma_px:
        return _invalid(f"too little texture (predicted sigma {sigma:.3g} px > {max_sigma_px})",
                        xf, yf, **extra)
    lo, hi = search_range(xi, width, window, int(min_disparity), int(max_disparity),
                          predicted_disparity, search_radius)
    if hi - lo < 2:
        return _invalid("empty search range (disparity limits or image border)", xf, yf, **extra)

    arith = CostArithmetic(impl, cost)
    costs = arith.curve(a_band, b_band, xi, lo, hi)
    return finish_match(arith, a_band, b_band, xf, yf, xi, lo, costs, sigma, texture, width=width,
                        subpixel=subpixel, min_ratio=min_ratio, noise_dn=noise_dn)


def finish_match(arith: CostArithmetic, a_band: np.ndarray, b_band: np.ndarray, xf: float, yf: float,
                 xi: int, lo: int, costs: np.ndarray, sigma: float, texture: float, *, width: int,
                 subpixel: str, min_ratio: float, k0: int | None = None, ratio: float | None = None,
                 noise_dn: float = 1.0, refined: tuple[float | int | None, str] | None = None) -> Match:
    """`match_point` after its integer search: the gates (`match_gate`) and `refine`.
    `costs` in ascending disparity from lo for the window at column xi of the bands (image rows
    yi - h .. yi + h), `width` the images' width; k0 (the first minimum) and ratio
    (`second_best_ratio`) when the caller has them (edge.core.batchmatch computes them for many
    points at once), `refined` when it has `refine`'s result (edge.core.batchsubpix); noise_dn as
    in `match_point` (research methods use it)."""
    k0 = int(np.argmin(costs)) if k0 is None else k0
    d0 = lo + k0
    best = float(costs[k0]) * (a_band.shape[0] ** 2 if arith.is_float and arith.cost == "zssd" else 1)
    ratio = second_best_ratio(costs, k0) if ratio is None else ratio
    extra = {"sigma_px": sigma, "texture": texture, "disparity_int": d0, "second_ratio": ratio, "cost": best}
    reason = match_gate(a_band.shape[0], xi, lo, len(costs), k0, ratio, width=width, subpixel=subpixel,
                        min_ratio=min_ratio)
    if reason:
        return _invalid(reason, xf, yf, **extra)
    value, reason = refine(arith, a_band, b_band, xi, lo, costs, k0, subpixel, sigma, noise_dn) \
        if refined is None else refined
    if value is None:
        return _invalid(reason, xf, yf, **extra)
    if arith.is_float:
        return Match(True, float(value), best, sigma, "", None, d0, ratio, texture, xf, yf)
    return Match(True, from_q(int(value), SUBPIX_BITS), best, sigma, "", int(value), d0, ratio,
                 texture, xf, yf)


def match_gate(window: int, xi: int, lo: int, n_costs: int, k0: int, ratio: float, *, width: int,
               subpixel: str, min_ratio: float) -> str:
    """Why the search's minimum costs[k0] (d0 = lo + k0, window at column xi, images `width` wide)
    gives no match ('' if it passes): at the edge of the search, ambiguous, or too near the border
    for the half-pixel passes (columns xi - h - 2 .. xi + h + 3 in both images)."""
    h, d0 = window // 2, lo + k0
    if not 0 < k0 < n_costs - 1:
        return "minimum at the edge of the search range"
    if ratio < min_ratio:
        return f"ambiguous: second-best cost only {ratio:.3f}x the best"
    if subpixel not in ("parabola", "none") and (xi - h - 2 < 0 or xi + h + 3 >= width
                                                 or d0 + 2 > xi - h or d0 - 2 < xi + h + 4 - width):
        return "half-pixel passes run off the image (point or match near the border)"
    return ""


match_point_float = partial(match_point, impl="float")
match_point_float.__doc__ = "Float64 reference of `match_point` (impl='float')."

__all__ = ["CostArithmetic", "Match", "check_images", "finish_match", "match_gate", "match_point",
           "match_point_float", "refine", "round_half_away", "second_best_ratio", "search_range"]
