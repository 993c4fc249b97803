"""Study section of tools/bench-core (`--sections study`): float64 sketches of sub-pixel
estimators that were considered for closing the gap to the Cramer-Rao bound, measured on the
*tuning* seeds (5000+) so that choosing among them never looks at the evaluation seeds
(`--study-seeds evaluation` reruns it on 1000+ as a check of a choice already made).

Not product code: none of these is in edge/core. They answer "would it help?" before anyone
writes an integer version:

- Gauss-Newton (Lucas-Kanade) steps on the raw windows, symmetric split (left sampled at
  x + f/2, right at x - d0 - f/2), gradient of the mean of both, offset removed, contrast
  equalised; the samples at fractional positions come from linear, Keys cubic or Lanczos-3
  interpolation, started from the cancellation estimate or from the plain parabola;
- six-pass cancellation (`subpixel="cancel6"`) with other 3-point models of the curve than the
  parabola: a cosine through the cross-correlation (exact for a single sinusoid) and a
  Gaussian through the normalised cross-correlation (exact for a Gaussian autocorrelation;
  the sketch that led to match_point's default "cancel6-gauss", which differs only in
  choosing the centre sample on the model curve and in its integer arithmetic);
- the Gaussian six-pass estimator with other kernels, fits and windows (`_variant`): the
  half-pixel passes with a [-1 9 9 -1]/16 (cubic) or [1 3 3 1] kernel, the integer passes
  unsmoothed or with [1 2 1] on both views (to bring the two spectra closer), a least-squares
  parabola through all five -log NCC samples, tapered window columns (edge effects), and
  unequal weights of the integer and half-pixel groups (within each group the passes are
  mirror images, so equal weights there are already the inverse-variance ones).
  None of them beat the default on every condition (the tapers and [1 2 1] trade
  noise for bias: lower error at 0-1 DN, higher at 4 DN and in fog);
- shift-and-refit (lab/subpix/refit.py, match_point subpixel="refit") and its variants: which
  first stage, and the [1 6 1] smoothing never / always / by predicted sigma without the
  check that the aligned views match to the noise (the product's adds that check).
"""

from __future__ import annotations

import argparse
import math
from typing import cast

import numpy as np

import lab.subpix  # noqa: F401  (registers the research sub-pixel methods, "refit")
from edge.core.match import Match, match_point
from edge.sim.synth import Condition, sweep_many
from lab.subpix.refit import refit_float

TUNE_SEED0 = 5000
EVAL_SEED0 = 1000                        # bench-core's evaluation seeds (only with --study-seeds)
H = 7                                    # 15x15 window


def _keys(a: float) -> tuple[np.ndarray, np.ndarray]:
    def k(t: float) -> float:
        t = abs(t)
        if t <= 1:
            return 1.5 * t**3 - 2.5 * t**2 + 1
        return -0.5 * t**3 + 2.5 * t**2 - 4 * t + 2 if t < 2 else 0.0
    return np.array([k(a + 1), k(a), k(1 - a), k(2 - a)]), np.arange(-1, 3)


def _linear(a: float) -> tuple[np.ndarray, np.ndarray]:
    return np.array([1 - a, a]), np.arange(2)


def _lanczos3(a: float) -> tuple[np.ndarray, np.ndarray]:
    taps = np.arange(-2, 4)
    w = np.sinc(taps - a) * np.sinc((taps - a) / 3)
    return w / w.sum(), taps


def _sample(rows: np.ndarray, cols: np.ndarray, shift: float, kernel) -> np.ndarray:
    base = math.floor(shift)
    weights, taps = kernel(shift - base)
    return sum(wt * rows[:, cols + base + t] for wt, t in zip(weights, taps, strict=True))


def gauss_newton_step(left: np.ndarray, right: np.ndarray, x: int, y: int, d: float, kernel) -> float:
    d0 = math.floor(d + 0.5)
    f = d - d0
    rows = slice(y - H, y + H + 1)
    cols = np.arange(x - H - 1, x + H + 2)
    ls = _sample(left[rows].astype(float), cols, f / 2, kernel)
    rs = _sample(right[rows].astype(float), cols - d0, -f / 2, kernel)
    lc, rc = ls[:, 1:-1] - ls[:, 1:-1].mean(), rs[:, 1:-1] - rs[:, 1:-1].mean()
    rs = rs * math.sqrt((lc * lc).sum() / max((rc * rc).sum(), 1e-12))
    mean = (ls + rs) / 2
    g = (mean[:, 2:] - mean[:, :-2]) / 2
    r = (ls - rs)[:, 1:-1]
    g, r = g - g.mean(), r - r.mean()
    return d - float((r * g).sum() / (g * g).sum())      # r ~ (f - f_true) * g


def _gn(start: str, steps: int, kernel):
    def run(left, right, x, y):
        m = match_point(left, right, x, y, max_disparity=12, subpixel=start, impl="float")
        if not m.valid:
            return m
        d = m.disparity_px
        for _ in range(steps):
            d = gauss_newton_step(left, right, x, y, d, kernel)
        return Match(True, d, m.cost, m.sigma_px)
    return run


def _windows(a: np.ndarray, cols: list[int]) -> np.ndarray:
    return np.stack([a[:, c - H:c + H + 1] for c in cols])


def _pass(template: np.ndarray, cands: np.ndarray) -> tuple[np.ndarray, float, np.ndarray, np.ndarray]:
    t = template - template.mean()
    c = cands - cands.mean(axis=(1, 2), keepdims=True)
    ssd = ((t - c) ** 2).sum(axis=(1, 2))
    return (t * c).sum(axis=(1, 2)), float((t * t).sum()), (c * c).sum(axis=(1, 2)), ssd


def six_passes(left, right, x, y, d0):
    """(cross, E_template, E_candidates, ZSSD) of the six passes at five candidates each, with the
    disparity of the centre candidate (candidate k is centre + k - 2)."""
    rows = slice(y - H, y + H + 1)
    lf, rf = left[rows].astype(float), right[rows].astype(float)
    lh, rh = lf[:, :-1] + lf[:, 1:], rf[:, :-1] + rf[:, 1:]
    xr = x - d0
    lr = [x - d0 + 2 - k for k in range(5)]
    rl = [xr + d0 - 2 + k for k in range(5)]
    win = lambda a, c: a[:, c - H:c + H + 1]            # noqa: E731
    return [(_pass(win(lh, x), _windows(rh, lr)), d0),
            (_pass(win(lh, x), _windows(2 * rf, lr)), d0 + 0.5),
            (_pass(win(rh, xr), _windows(lh, rl)), d0),
            (_pass(win(rh, xr), _windows(2 * lf, rl)), d0 - 0.5),
            (_pass(win(2 * lf, x), _windows(rh, lr)), d0 - 0.5),
            (_pass(win(2 * rf, xr), _windows(lh, rl)), d0 + 0.5)]


def _fit3(model: str, cross, e_t, e_c, ssd) -> float:
    if model == "parabola":
        cm, c0, cp = ssd
        return (cm - cp) / (2 * (cm - 2 * c0 + cp))
    if model == "gauss":
        rho = cross / np.sqrt(e_t * e_c)
        if (rho <= 0).any():
            return math.nan
        cm, c0, cp = -np.log(rho)
        return (cm - cp) / (2 * (cm - 2 * c0 + cp))
    rm, r0, rp = (np.mean(e_t + e_c) - ssd) / 2               # cosine through the correlation
    om = math.acos(min(max((rm + rp) / (2 * r0), -1.0), 1.0))
    if om < 1e-6:
        return (rp - rm) / (2 * (2 * r0 - rm - rp))
    return math.atan2(rp - rm, 2 * r0 * math.sin(om)) / om


def _six(model: str):
    def run(left, right, x, y):
        m = match_point(left, right, x, y, max_disparity=12, subpixel="parabola", impl="float")
        if not m.valid:
            return m
        est = []
        for (cross, e_t, e_c, ssd), centre in six_passes(left, right, x, y, m.disparity_int):
            k = int(np.argmin(ssd[1:4])) + 1
            sl = slice(k - 1, k + 2)
            est.append(centre + k - 2 + _fit3(model, cross[sl], e_t, e_c[sl], ssd[sl]))
        d = (est[0] + est[2]) / 4 + (est[1] + est[3] + est[4] + est[5]) / 8
        return Match(math.isfinite(d), d, m.cost, m.sigma_px)
    return run


def _filter(a: np.ndarray, kernel: tuple) -> np.ndarray:
    """sum_t w_t a[:, j + t] for (taps, weights) = kernel (wraps at the edges, far from any window)."""
    return sum(wt * np.roll(a, -t, axis=1) for t, wt in zip(*kernel, strict=True))


HALF = {"binom": ([0, 1], [1, 1]), "cubic": ([-1, 0, 1, 2], [-1, 9, 9, -1]),
        "b3": ([-1, 0, 1, 2], [1, 3, 3, 1])}
WHOLE = {"binom": ([0, 1], [1, 1]), "raw": ([0], [1]), "b121": ([-1, 0, 1], [1, 2, 1])}


def _variant_passes(left, right, x, y, d0, half: str, whole: str):
    """(template, candidates, centre disparity, is-integer-pass) of the six passes with the
    half-pixel kernel `half` (one view) and the kernel `whole` on both views of the integer passes."""
    rows = slice(y - H, y + H + 1)
    lf, rf = left[rows].astype(float), right[rows].astype(float)
    lh, rh = _filter(lf, HALF[half]), _filter(rf, HALF[half])
    la, ra = _filter(lf, WHOLE[whole]), _filter(rf, WHOLE[whole])
    xr = x - d0
    lr = [x - d0 + 2 - k for k in range(5)]
    rl = [xr + d0 - 2 + k for k in range(5)]
    t = lambda a, c: a[:, c - H:c + H + 1]            # noqa: E731
    return [(t(la, x), _windows(ra, lr), d0, True), (t(lh, x), _windows(rf, lr), d0 + 0.5, False),
            (t(ra, xr), _windows(la, rl), d0, True), (t(rh, xr), _windows(lf, rl), d0 - 0.5, False),
            (t(lf, x), _windows(rh, lr), d0 - 0.5, False), (t(rf, xr), _windows(lh, rl), d0 + 0.5, False)]


def _log_ncc(template: np.ndarray, cands: np.ndarray, col_w: np.ndarray) -> np.ndarray:
    """-2 log NCC + const of each candidate (nan where the correlation is not positive), with
    column weights col_w."""
    w = np.broadcast_to(col_w / (col_w.sum() * template.shape[0]), template.shape)
    t = template - (w * template).sum()
    c = cands - (w * cands).sum(axis=(1, 2), keepdims=True)
    cross = (w * t * c).sum(axis=(1, 2))
    with np.errstate(invalid="ignore", divide="ignore"):             # nan where cross <= 0
        return np.log((w * c * c).sum(axis=(1, 2))) - 2 * np.log(np.where(cross > 0, cross, np.nan))


def _variant(half: str = "binom", whole: str = "binom", five: bool = False, taper: tuple = (),
             a_weight: float = 0.5):
    col_w = np.r_[taper, np.ones(2 * H + 1 - 2 * len(taper)), taper[::-1]]

    def run(left, right, x, y):
        m = match_point(left, right, x, y, max_disparity=12, subpixel="parabola", impl="float")
        if not m.valid:
            return m
        est: dict[bool, list[float]] = {True: [], False: []}
        passes = _variant_passes(left, right, x, y, m.disparity_int, half, whole)
        for tmpl, cands, centre, whole_pass in passes:
            yv = _log_ncc(tmpl, cands, col_w)
            k = int(np.argmin(np.nan_to_num(yv[1:4], nan=np.inf))) + 1
            if five and k == 2 and np.isfinite(yv).all():
                c2, c1, _ = np.polyfit(np.arange(-2.0, 3.0), yv, 2)
                est[whole_pass].append(centre - c1 / (2 * c2))
            else:
                ym, y0, yp = yv[k - 1:k + 2]
                est[whole_pass].append(centre + k - 2 + (ym - yp) / (2 * (ym - 2 * y0 + yp)))
        # cast: numpy's stubs type np.mean as floating, not float (np.float64 is a float)
        d = cast(float, a_weight * np.mean(est[True]) + (1 - a_weight) * np.mean(est[False]))
        return Match(math.isfinite(d), d, m.cost, m.sigma_px)
    return run


METHODS = {
    "ZSSD+cancel (previous default, float)": lambda lft, rgt, x, y: match_point(
        lft, rgt, x, y, max_disparity=12, subpixel="cancel", impl="float"),
    "cancel6, parabola (float)": _six("parabola"),
    "cancel6, cosine fit": _six("cosine"),
    "cancel6, Gaussian fit (NCC; ~ the default)": _six("gauss"),
    "cancel + 1 GN step, linear": _gn("cancel", 1, _linear),
    "cancel + 1 GN step, Keys cubic": _gn("cancel", 1, _keys),
    "cancel + 1 GN step, Lanczos-3": _gn("cancel", 1, _lanczos3),
    "parabola + 2 GN steps, Lanczos-3": _gn("parabola", 2, _lanczos3),
    "gauss6 sketch, [1 1] half / [1 1] whole": _variant(),
    "gauss6, weight 0.45 on integer passes": _variant(a_weight=0.45),
    "gauss6, weight 0.55 on integer passes": _variant(a_weight=0.55),
    "gauss6, 5-sample LS fit": _variant(five=True),
    "gauss6, cubic half / raw whole": _variant("cubic", "raw"),
    "gauss6, cubic half / [1 1] whole": _variant("cubic", "binom"),
    "gauss6, [1 1] half / [1 2 1] whole": _variant("binom", "b121"),
    "gauss6, [1 3 3 1] half / [1 2 1] whole": _variant("b3", "b121"),
    "gauss6, taper 1/3 2/3": _variant(taper=(1 / 3, 2 / 3)),
    "gauss6, taper 1/4 1/2 3/4": _variant(taper=(0.25, 0.5, 0.75)),
}
def _refit(start: str, noise_dn: float, smooth: str):
    """match_point's "refit" stage (float) from `start`, with the [1 6 1] smoothing never, always,
    or only below predicted sigma 0.01 px but without the mismatch check (a huge noise for it)."""
    def run(left, right, x, y):
        m = match_point(left, right, x, y, max_disparity=12, subpixel=start, impl="float", noise_dn=noise_dn)
        if not m.valid:
            return m
        gate = {"never": None, "always": 1e6, "sigma": 1e6 if m.sigma_px <= 0.01 else None}[smooth]
        d = refit_float(left[y - H:y + H + 1], right[y - H:y + H + 1], x, m.disparity_px, gate)
        return Match(d is not None, math.nan if d is None else d, m.cost, m.sigma_px)
    return run


def _refit_rows(noise_dn: float) -> dict:
    return {
        "cancel + refit (float; match_point's)": lambda lft, rgt, x, y: match_point(
            lft, rgt, x, y, max_disparity=12, subpixel="refit", impl="float", noise_dn=noise_dn),
        "cancel + refit, never smoothed": _refit("cancel", noise_dn, "never"),
        "cancel + refit, smoothed if sigma <= 0.01, no mismatch check": _refit("cancel", noise_dn, "sigma"),
        "cancel + refit, always smoothed": _refit("cancel", noise_dn, "always"),
        "parabola + refit, never smoothed": _refit("parabola", noise_dn, "never"),
        "cancel6-gauss + refit, never smoothed": _refit("cancel6-gauss", noise_dn, "never"),
    }


CONDITIONS = [Condition("textured, 1 DN"), Condition("textured, 0 DN (bias)", noise_dn=0.0),
              Condition("textured, 4 DN", noise_dn=4.0),
              Condition("sharp (aliased), 1 DN", kind="sharp", psf_sigma_px=0.25),
              Condition("fog t=0.15, 1 DN", fog_t=0.15),
              Condition("vertical offset 0.25 px", vertical_8ths=2)]


def section_study(args: argparse.Namespace, out: list[str]) -> None:
    from lab.bench.common import table
    n_seeds, n_frac = (6, 8) if args.quick else (12, 16)
    seed0 = TUNE_SEED0
    if getattr(args, "study_seeds", "tuning") == "evaluation":       # a check, never for choosing
        seed0, n_seeds = EVAL_SEED0, 2 * n_seeds
    seeds = range(seed0, seed0 + n_seeds)
    rows = []
    for cond in CONDITIONS:
        res = sweep_many(cond, seeds, {**METHODS, **_refit_rows(cond.noise_dn)}, n_fractions=n_frac)
        crb = float(np.sqrt(np.mean(res[next(iter(METHODS))].crb_px ** 2)))
        for name, sw in res.items():
            e = sw.errors
            ok = np.isfinite(e) & (np.abs(np.nan_to_num(e)) <= 1.0)
            good = np.where(ok, e, np.nan)
            rms = float(np.sqrt(np.nanmean(good**2)))
            bias = float(np.nanmax(np.abs(np.nanmean(good, axis=0))))
            rows.append([cond.name, name, f"{rms:.4f}", f"{bias:.4f}", f"{1 - ok.mean():.3f}", f"{crb:.4f}",
                         f"{rms / crb:.2f}"])
    kind = "tuning" if seed0 == TUNE_SEED0 else "EVALUATION"
    out.append(f"Study (float sketches, {kind} seeds {seeds.start}..{seeds.stop - 1} x {n_frac} fractions; "
               "not product code): other estimators against the Cramer-Rao bound")
    headers = ["condition", "method", "RMS", "max|bias|", "gross+invalid", "CRB", "RMS/CRB"]
    out.append(table(headers, rows) + "\n")
