"""bench-core's "aliasing" section (issue 16): sharp optics on periodic detail, and how well each
candidate detector of the resulting bias separates aliased from clean windows.

Pairs are `edge.sim.synth` exact-shift renders, d = 4 + k/8 px, 15x15 window, 1 DN noise. The
aliased set is `periodic` texture (rows of dark windows on a 1.05-2.5 px pitch over faint hull
paint) with no PSF (only the pixel's area: a sharp lens, no anti-aliasing filter); the clean
sets are the usual textured hull with the usual PSF and without any, the `sharp` random
texture, and the periodic texture behind the usual PSF. Per window the default matcher's error
and predicted sigma are kept with three detector statistics:

- `nyquist L1`: sum |x[i] - 2x[i+1] + x[i+2]| / sum |x[i+1] - x[i]| over the template's rows
  (integer sums; 2 at Nyquist, small for smooth texture);
- `FFT high band`: share of the rows' (mean-removed) spectral energy at >= 0.35 cycles/px;
- `window disagreement`: |d(15) - d(9)|, the second match the pipeline's check makes
  (edge.measure.aliascheck), searched +-2 px around the first.

A window counts as biased when |error| > 0.1 px. The detector table gives, per false-alarm rate
on all clean windows, the threshold and the share of biased windows flagged. The accuracy table
gives per set the RMS error, the biased share and the share beyond 3 sigma of the matcher's
predicted sigma, alone and with the check's additive term (GAIN x |d15 - d11| above DEADZONE_PX,
the single-pair form of AliasCheck.sigma_px's persistent disagreement). The steady table runs
the real `AliasCheck` over 5 noisy pairs at one disparity (a ship at a steady range) and gives the
share of cases whose mean error lies beyond 3 sigma for several GAINs (0: the check off).
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from edge.core.match import Match, match_point
from edge.measure.aliascheck import DEADZONE_PX, GAIN, AliasCheck, check_window
from edge.sim import synth
from lab.bench.common import table

WINDOW = 15
SETS = (  # name, scene kind, PSF sigma (px), aliased?
    ("periodic, no PSF (aliased)", "periodic", 0.0, True),
    ("periodic, PSF 0.6", "periodic", 0.6, False),
    ("textured, no PSF", "hull", 0.0, False),
    ("textured, PSF 0.35", "hull", 0.35, False),
    ("sharp random, PSF 0.25", "sharp", 0.25, False),
)
FALSE_ALARMS = (0.01, 0.05, 0.10)
BIASED_PX = 0.1


def nyquist_l1(template: np.ndarray) -> float:
    """sum |second difference| / sum |first difference| along the rows (integer sums)."""
    t = template.astype(np.int32)
    d1 = np.abs(np.diff(t, axis=1)).sum()
    d2 = np.abs(t[:, :-2] - 2 * t[:, 1:-1] + t[:, 2:]).sum()
    return float(d2) / max(float(d1), 1.0)


def high_band(template: np.ndarray, cutoff: float = 0.35) -> float:
    """Share of the mean-removed rows' spectral energy at >= cutoff cycles/px."""
    t = template.astype(np.float64)
    power = np.abs(np.fft.rfft(t - t.mean(axis=1, keepdims=True), axis=1)) ** 2
    f = np.fft.rfftfreq(t.shape[1])
    return float(power[:, f >= cutoff].sum() / max(power[:, 1:].sum(), 1e-9))


def samples(kind: str, psf: float, seeds: range, n_fractions: int = 8) -> np.ndarray:
    """Rows (error, sigma, nyquist L1, high band, |d15 - d11|) of the valid default matches."""
    whole, h = 4, WINDOW // 2
    size_y, size_x = WINDOW + 6, WINDOW + 2 * whole + 22
    xc, yc = size_x - h - 5, size_y // 2
    small = check_window(WINDOW)
    rows = []
    for seed in seeds:
        scene = synth.make_scene(np.random.default_rng([seed, 1]), size_y + 2 * synth.MARGIN_PX + 2,
                                 size_x + whole + 2 * synth.MARGIN_PX + 4, kind)
        noise = np.random.default_rng([seed, 2])
        for k in range(n_fractions):
            pair = synth.render_pair(scene, noise, whole * synth.SAMPLES_PER_PX + k * synth.SAMPLES_PER_PX
                                     // n_fractions, height_px=size_y, width_px=size_x,
                                     x0_px=synth.MARGIN_PX + 1, psf_sigma_px=psf, noise_dn=1.0)
            m = match_point(pair.left, pair.right, xc, yc, window=WINDOW, max_disparity=12, noise_dn=1.0,
                            max_sigma_px=0.5)
            if not m.valid:
                continue
            c = match_point(pair.left, pair.right, xc, yc, window=small, max_disparity=12, noise_dn=1.0,
                            max_sigma_px=0.5, predicted_disparity=m.disparity_px, search_radius=2)
            template = pair.left[yc - h:yc + h + 1, xc - h - 1:xc + h + 2]
            rows.append((m.disparity_px - pair.disparity_px, m.sigma_px, nyquist_l1(template),
                         high_band(template[:, 1:-1]), abs(m.disparity_px - c.disparity_px) if c.valid
                         else math.inf))
    return np.array(rows)


def steady_cases(kind: str, psf: float, seeds: range, eighths: tuple[int, ...] = (2, 3, 5),
                 repeats: int = 5) -> np.ndarray:
    """A ship at a steady range: per seed and fraction (eighths of a px), `repeats` noisy pairs at
    one disparity fed to an `AliasCheck`. Rows (|mean error|, max predicted sigma, the check's
    persistent disagreement) of the cases with >= 3 valid matches (whole-pixel slips left out)."""
    whole, h = 4, WINDOW // 2
    size_y, size_x = WINDOW + 6, WINDOW + 2 * whole + 22
    xc, yc = size_x - h - 5, size_y // 2
    rows = []
    for seed in seeds:
        scene = synth.make_scene(np.random.default_rng([seed, 1]), size_y + 2 * synth.MARGIN_PX + 2,
                                 size_x + whole + 2 * synth.MARGIN_PX + 4, kind)
        noise = np.random.default_rng([seed, 3])
        for k in eighths:
            check, errors, sigmas = AliasCheck(), [], []
            for _ in range(repeats):
                pair = synth.render_pair(scene, noise, whole * synth.SAMPLES_PER_PX + k * synth.SAMPLES_PER_PX
                                         // 8, height_px=size_y, width_px=size_x, x0_px=synth.MARGIN_PX + 1,
                                         psf_sigma_px=psf, noise_dn=1.0)
                m = match_point(pair.left, pair.right, xc, yc, window=WINDOW, max_disparity=12,
                                noise_dn=1.0, max_sigma_px=0.5)
                if not m.valid or abs(m.disparity_px - pair.disparity_px) >= 1.0:
                    continue
                c: Match = match_point(pair.left, pair.right, xc, yc, window=check_window(WINDOW),
                                       max_disparity=12, noise_dn=1.0, max_sigma_px=0.5,
                                       predicted_disparity=m.disparity_px, search_radius=2)
                check.add(m, c)
                errors.append(m.disparity_px - pair.disparity_px)
                sigmas.append(m.sigma_px)
            if len(errors) >= 3:
                rows.append((abs(float(np.mean(errors))), max(sigmas), check.persistent_px() or 0.0))
    return np.array(rows)


def section_aliasing(args: argparse.Namespace, out: list[str]) -> None:
    seeds = range(1000, 1000 + (16 if args.quick else 48))
    data = {name: samples(kind, psf, seeds) for name, kind, psf, _ in SETS}
    acc = []
    for name, _, _, _ in SETS:
        a = data[name]
        e, s, dis = np.abs(a[:, 0]), a[:, 1], a[:, 4]
        alias = np.where(np.isfinite(dis) & (dis > DEADZONE_PX), GAIN * dis, 0.0)
        alias = np.where(np.isfinite(dis), alias, GAIN * 0.5)  # no check match: half a pixel
        widened = np.hypot(s, alias)
        acc.append([name, str(len(a)), f"{np.sqrt(np.mean(e ** 2)):.3f}", f"{np.mean(e > BIASED_PX):.3f}",
                    f"{np.mean(e > 3 * s):.3f}", f"{np.mean(e > 3 * widened):.3f}",
                    f"{np.mean(alias > 0):.3f}"])
    out.append(f"Aliasing (issue 16): {len(seeds)} seeds x 8 fractions per set, 15x15 window, 1 DN; "
               f"'> 3 sigma' against the matcher's sigma, and with the window check's term "
               f"(GAIN {GAIN} x |d15 - d11| above {DEADZONE_PX} px)")
    out.append(table(["set", "windows", "RMS px", f"|e|>{BIASED_PX}", "> 3 sigma", "> 3 sigma checked",
                      "term on"], acc))
    aliased = data[SETS[0][0]]
    biased = np.abs(aliased[:, 0]) > BIASED_PX
    clean = np.concatenate([data[name] for name, _, _, flag in SETS if not flag])
    rows = []
    for col, label in ((2, "nyquist L1 (2nd/1st differences)"), (3, "FFT high band (>= 0.35 c/px)"),
                       (4, "window disagreement |d15 - d11|")):
        cells = [label]
        for far in FALSE_ALARMS:
            thr = float(np.quantile(clean[:, col], 1.0 - far))
            cells.append(f"{np.mean(aliased[biased, col] > thr):.2f} (> {thr:.3f})")
        rows.append(cells)
    out.append(f"Detectors: share of the {int(biased.sum())} biased windows (|e| > {BIASED_PX} px, aliased "
               f"set) flagged at a false-alarm rate of 1/5/10 % on the {len(clean)} clean windows")
    out.append(table(["detector", "at 1 % FA", "at 5 % FA", "at 10 % FA"], rows))
    steady_seeds = range(1000, 1000 + (8 if args.quick else 24))
    gains = (0.0, 0.5, GAIN, 2.0, 4.0)
    rows = []
    for name, kind, psf, _ in SETS:
        a = steady_cases(kind, psf, steady_seeds)
        bias, sigma, persistent = a[:, 0], a[:, 1], a[:, 2]
        cells = [name, str(len(a))]
        for g in gains:
            term = np.where(persistent > DEADZONE_PX, g * persistent, 0.0)
            cells.append(f"{np.mean(bias > 3 * np.hypot(sigma, term)):.3f}")
        cells.append(f"{np.mean(persistent > DEADZONE_PX):.3f}")
        rows.append(cells)
    out.append(f"Steady disparity (a ship at one range): {len(steady_seeds)} seeds x fractions 2/8, 3/8, 5/8 "
               "px, 5 noisy pairs each; share of cases whose mean error lies beyond 3 sigma, the sigma "
               "widened by GAIN x the check's persistent disagreement (AliasCheck; GAIN 0: off)")
    out.append(table(["set", "cases", *(f"GAIN {g:g}" for g in gains), "term on"], rows) + "\n")
