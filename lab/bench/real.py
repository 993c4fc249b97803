"""Real-imagery section of tools/bench-core: the Middlebury 2014 motorcycle pair (quarter size,
ground-truth disparity) that scikit-image bundles, our matcher vs OpenCV StereoBM at the same
well-textured points. scikit-image is a bench/test-only dependency; without it the section is
skipped with a note. Also used by tests/edge/core/test_match.py."""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from edge.core.match import match_point
from edge.core.prefilter import xsobel, xsobel_normalised

WINDOW = 15
MAX_SPREAD_PX = 3.0        # ground truth varies by at most this within the window (no depth edges)


@dataclass(frozen=True)
class RealPair:
    left: np.ndarray
    right: np.ndarray
    truth: np.ndarray        # disparity, NaN/inf where unknown; x_right = x_left - d


def load_motorcycle() -> RealPair | None:
    try:
        from skimage import data
    except ImportError:
        return None
    left, right, truth = data.stereo_motorcycle()
    grey = [cv2.cvtColor(im, cv2.COLOR_RGB2GRAY) for im in (left, right)]
    return RealPair(grey[0], grey[1], np.where(np.isfinite(truth), truth, np.nan).astype(np.float64))


def textured_points(pair: RealPair, step: int) -> list[tuple[int, int, float]]:
    """Grid points whose window has ground truth everywhere, spread <= MAX_SPREAD_PX, and enough
    texture (predicted sigma <= 0.1 px at 1 DN); returns (x, y, spread)."""
    h = WINDOW // 2
    height, width = pair.left.shape
    pts = []
    for y in range(h + 2, height - h - 2, step):
        for x in range(80, width - h - 4, step):                 # 80: room for the search
            g = pair.truth[y - h:y + h + 1, x - h:x + h + 1]
            if np.isnan(g).any() or g.max() - g.min() > MAX_SPREAD_PX:
                continue
            pts.append((x, y, float(g.max() - g.min())))
    return pts


def stereo_bm(pair: RealPair) -> np.ndarray:
    """StereoBM with its defaults (x-Sobel prefilter, cap 31, SAD), 15x15, 64 disparities, 1/16 px."""
    bm = cv2.StereoBM_create(numDisparities=64, blockSize=WINDOW)  # type: ignore[attr-defined]  # not in cv2's stubs
    d = bm.compute(pair.left, pair.right).astype(np.float64) / 16.0
    return np.where(d >= 0, d, np.nan)


def evaluate(pair: RealPair, pts: list[tuple[int, int, float]]) -> dict[str, np.ndarray]:
    """Errors (estimate - truth) per method at the points; NaN where a method said invalid."""
    bm = stereo_bm(pair)
    pre_l, pre_r = xsobel(pair.left), xsobel(pair.right)
    norm_l, norm_r = xsobel_normalised(pair.left), xsobel_normalised(pair.right)
    caps = {cap: (xsobel(pair.left, cap), xsobel(pair.right, cap)) for cap in (31, 63, 127)}
    methods: dict[str, tuple[np.ndarray, np.ndarray, dict[str, Any]]] = {
        "SSD+parabola (thesis)": (pair.left, pair.right, {"cost": "ssd", "subpixel": "parabola"}),
        "ZSSD+cancel (raw)": (pair.left, pair.right, {"subpixel": "cancel"}),
        "xsobel15 + ZSSD+parabola": (pre_l, pre_r, {"subpixel": "parabola"}),
        "xsobel15 + ZSSD+cancel": (pre_l, pre_r, {"subpixel": "cancel"}),
        "ZSSD+cancel6-gauss (raw, default)": (pair.left, pair.right, {"subpixel": "cancel6-gauss"}),
        "xsobel15 + ZSSD+cancel6-gauss": (pre_l, pre_r, {"subpixel": "cancel6-gauss"}),
        "xsobel31 + ZSSD+cancel6-gauss": (*caps[31], {"subpixel": "cancel6-gauss"}),
        "xsobel63 + ZSSD+cancel6-gauss": (*caps[63], {"subpixel": "cancel6-gauss"}),
        "xsobel127 + ZSSD+cancel6-gauss": (*caps[127], {"subpixel": "cancel6-gauss"}),
        "normalised x-Sobel + ZSSD+cancel6-gauss": (norm_l, norm_r, {"subpixel": "cancel6-gauss"}),
    }
    truth = np.array([pair.truth[y, x] for x, y, _ in pts])
    errors = {"OpenCV StereoBM (1/16 px)": np.array([bm[y, x] for x, y, _ in pts]) - truth}
    for name, (lft, rgt, kw) in methods.items():
        est = []
        for x, y, _ in pts:
            m = match_point(lft, rgt, x, y, max_disparity=70, max_sigma_px=10.0, **kw)
            est.append(m.disparity_px if m.valid else np.nan)
        errors[name] = np.array(est) - truth
    return errors


def summary(errors: dict[str, np.ndarray], sel: np.ndarray) -> list[list[str]]:
    """Rows: method, share of the selected points it gave a value for (valid), then on the points
    where every method gave a value (so all are judged on the same points): n, gross rate
    (|e| > 1 px), RMS (gross excluded), median |e|, p90 |e|, mean e."""
    common = sel & np.all([np.isfinite(e) for e in errors.values()], axis=0)
    rows = []
    for name, e in errors.items():
        v = e[common]
        gross = np.abs(v) > 1.0
        a = np.abs(v[~gross])
        rows.append([name, f"{np.isfinite(e[sel]).mean():.3f}", str(v.size), f"{gross.mean():.4f}",
                     f"{np.sqrt(np.mean(a**2)):.3f}", f"{np.median(a):.3f}", f"{np.percentile(a, 90):.3f}",
                     f"{np.mean(v[~gross]):+.3f}"])
    return rows


def attribution(pair: RealPair, pts: list[tuple[int, int, float]], errors: dict[str, np.ndarray],
                sel: np.ndarray) -> list[list[str]]:
    """Where the error comes from: a window fit measures the disparity averaged over the window
    with weights ~ (its image's x-gradient)^2, while the truth is the centre's. Per single-image
    method: RMS of e (gross excluded), RMS of that weighted ground truth minus the centre's
    (the attribution offset the weights imply), their correlation, and the RMS of e minus it."""
    h = WINDOW // 2
    grads = {"ZSSD+cancel6-gauss (raw, default)": _xgrad(pair.left.astype(np.float64)),
             "xsobel15 + ZSSD+cancel6-gauss": xsobel(pair.left).astype(np.float64) - 15,
             "normalised x-Sobel + ZSSD+cancel6-gauss": xsobel_normalised(pair.left).astype(np.float64) - 128}
    rows = []
    for name, g in grads.items():
        offset = []
        for x, y, _ in pts:
            w = g[y - h:y + h + 1, x - h:x + h + 1] ** 2
            gt = pair.truth[y - h:y + h + 1, x - h:x + h + 1] - pair.truth[y, x]
            offset.append(float((w * gt).sum() / max(w.sum(), 1e-9)))
        e, o = errors[name], np.array(offset)
        ok = sel & np.isfinite(e) & (np.abs(np.nan_to_num(e)) <= 1.0)
        rms = [f"{np.sqrt(np.mean(v[ok] ** 2)):.3f}" for v in (e, o, e - o)]
        rows.append([name, rms[0], rms[1], f"{np.corrcoef(e[ok], o[ok])[0, 1]:.2f}", rms[2]])
    return rows


def _xgrad(image: np.ndarray) -> np.ndarray:
    g = np.zeros_like(image)
    g[:, 1:-1] = image[:, 2:] - image[:, :-2]
    return g


def section_real(args: argparse.Namespace, out: list[str]) -> None:
    from lab.bench.common import table
    pair = load_motorcycle()
    if pair is None:
        out.append("Real imagery: skipped (scikit-image not installed: .venv/bin/pip install scikit-image)\n")
        return
    pts = textured_points(pair, 8 if args.quick else 4)
    errors = evaluate(pair, pts)
    spread = np.array([p[2] for p in pts])
    headers = ["method", "valid", "n", "gross", "RMS", "median", "p90", "mean"]
    out.append("Real imagery: Middlebury 2014 motorcycle (quarter size, scikit-image), 15x15 windows with "
               "ground truth everywhere; errors in px against ground truth; same points for every method")
    for label, sel in ((f"all points (GT spread in window <= {MAX_SPREAD_PX:g} px)", spread <= MAX_SPREAD_PX),
                       ("near fronto-parallel (spread <= 1 px)", spread <= 1.0)):
        out.append(f"\n{label}")
        out.append(table(headers, summary(errors, sel)))
    out.append("\nwhere the error comes from (all points, gross excluded): e vs the ground truth averaged "
               "over the window with the method's weights (x-gradient^2 of its image) minus the centre's")
    out.append(table(["method", "RMS e", "RMS offset", "corr", "RMS e - offset"],
                     attribution(pair, pts, errors, spread <= MAX_SPREAD_PX)))
    out.append("")
