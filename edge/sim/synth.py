"""Exact-shift stereo patch generator for tests and tools/bench-core (research note §6).

Why a generator of its own: sub-pixel estimators are judged on their error as a function of
the fractional disparity, and resampling one view from the other (bilinear, bicubic) adds a
fraction-dependent smoothing that both fakes errors and hides the bias of estimators that use
the same interpolator. Here both views are *crops of one fine scene* at integer sample offsets:

- the scene is sampled at S = 32 samples/px horizontally and 8 rows/px vertically (it is
  piecewise constant on cells of 1/8 px, plus sharp rectangles with edges on the 1/32 px grid),
  so disparities d = D0 + k/32 and vertical offsets of m/8 px are exact;
- each view is area-integrated to a 4x grid, blurred with a Gaussian PSF on that grid,
  area-integrated to 1 px, then gets independent read noise, rounding and clipping to uint8;
- fog follows Koschmieder, I = t*J + (1 - t)*A; the right camera may have a gain/offset mismatch.

Convention (docs/design.md, the core matcher's contract): x_right = x_left - d, i.e. right(x) = left(x + d).
Pure numpy/scipy; no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter, gaussian_filter1d

SAMPLES_PER_PX = 32        # horizontal fine grid (exact disparity step 1/32 px)
ROWS_PER_PX = 8            # vertical fine grid (exact vertical offset step 1/8 px)
CELL = SAMPLES_PER_PX // ROWS_PER_PX   # texture cells are 1/8 px wide (4 fine samples)
MARGIN_PX = 3              # rendered around each view so the PSF sees real scene at the edges
AIRLIGHT_DN = 190.0        # fog luminance A in Koschmieder's law


@dataclass(frozen=True)
class Scene:
    """One texture instance: radiance in DN on the fine grid (rows at 1/8 px, cols at 1/32 px)."""

    fine: np.ndarray
    kind: str

    @property
    def width_px(self) -> int:
        return self.fine.shape[1] // SAMPLES_PER_PX

    @property
    def height_px(self) -> int:
        return self.fine.shape[0] // ROWS_PER_PX


def make_scene(rng: np.random.Generator, height_px: int, width_px: int, kind: str = "hull") -> Scene:
    """Random scene: `hull` (band-limited noise, correlation 0.25-0.6 px, plus +-45 DN
    rectangles), `sharp` (correlation 0.15-0.25 px: aliases after sampling), `periodic` (a
    faint hull carrying 1-3 rows of dark windows on one pitch of 1.05-2.5 px: issue 16's bridge
    windows and railings, `periodic_scene`) or `sea` (low-contrast noise with horizontal wave
    streaks)."""
    if kind == "periodic":
        return periodic_scene(rng, height_px, width_px)
    rows, cells = height_px * ROWS_PER_PX, width_px * ROWS_PER_PX
    if kind == "hull":
        corr_px = rng.uniform(0.25, 0.6)
        amplitude = 26.0
    elif kind == "sharp":
        corr_px = rng.uniform(0.15, 0.25)
        amplitude = 22.0
    elif kind == "sea":
        corr_px = rng.uniform(0.5, 1.0)
        amplitude = 6.0
    else:
        raise ValueError(f"unknown scene kind {kind!r}")
    noise = gaussian_filter(rng.standard_normal((rows, cells)), corr_px * ROWS_PER_PX, mode="wrap")
    noise *= amplitude / max(float(noise.std()), 1e-9)
    if kind == "sea":
        streaks = gaussian_filter1d(rng.standard_normal(rows), 0.7 * ROWS_PER_PX, mode="wrap")
        noise += 8.0 * streaks[:, None] / max(float(streaks.std()), 1e-9)
    fine = np.repeat(110.0 + noise, CELL, axis=1)
    if kind != "sea":
        for _ in range(max(1, (height_px * width_px) // 120)):
            h = int(rng.integers(2 * ROWS_PER_PX, 8 * ROWS_PER_PX))
            w = int(rng.integers(2 * SAMPLES_PER_PX, 8 * SAMPLES_PER_PX))
            r0 = int(rng.integers(0, max(1, fine.shape[0] - h)))
            c0 = int(rng.integers(0, max(1, fine.shape[1] - w)))
            fine[r0:r0 + h, c0:c0 + w] += rng.choice([-45.0, 45.0])
    return Scene(fine=fine, kind=kind)


def periodic_scene(rng: np.random.Generator, height_px: int, width_px: int) -> Scene:
    """`make_scene(kind="periodic")`: a `hull` scene at 10-60 % of its contrast (white paint) with
    1-3 horizontal rows, 3-9 px high, of dark windows 30-60 DN deep on one pitch of 1.05-2.5 px
    (duty 35-65 %, random phase) across the whole width: regular detail near and under two pixels."""
    hull = make_scene(rng, height_px, width_px, "hull")
    fine = 110.0 + rng.uniform(0.1, 0.6) * (hull.fine - 110.0)
    pitch_px, duty = rng.uniform(1.05, 2.5), rng.uniform(0.35, 0.65)
    phase_px, depth_dn = rng.uniform(0.0, pitch_px), rng.uniform(30.0, 60.0)
    x = (np.arange(fine.shape[1]) + 0.5) / SAMPLES_PER_PX
    dark = ((x - phase_px) / pitch_px) % 1.0 < duty
    for _ in range(int(rng.integers(1, 4))):
        h = int(rng.integers(3 * ROWS_PER_PX, 9 * ROWS_PER_PX))
        r0 = int(rng.integers(0, fine.shape[0] - h))
        fine[r0:r0 + h, dark] -= depth_dn
    return Scene(fine=fine, kind="periodic")


def render_view(scene: Scene, x0_samples: int, y0_rows: int, height_px: int, width_px: int,
                psf_sigma_px: float = 0.35) -> np.ndarray:
    """Noise-free float image of `height_px` x `width_px` pixels whose top-left pixel starts at
    fine sample (y0_rows, x0_samples) of the scene (both integers: exact)."""
    s, r = SAMPLES_PER_PX, ROWS_PER_PX
    m = MARGIN_PX
    ys, xs = y0_rows - m * r, x0_samples - m * s
    hh, ww = height_px + 2 * m, width_px + 2 * m
    if ys < 0 or xs < 0 or ys + hh * r > scene.fine.shape[0] or xs + ww * s > scene.fine.shape[1]:
        raise ValueError("view falls outside the scene")
    crop = scene.fine[ys:ys + hh * r, xs:xs + ww * s]
    grid4 = crop.reshape(hh * 4, r // 4, ww * 4, s // 4).mean(axis=(1, 3))   # area-integrate to 4x
    if psf_sigma_px > 0:
        grid4 = gaussian_filter(grid4, psf_sigma_px * 4, mode="nearest")
    px = grid4.reshape(hh, 4, ww, 4).mean(axis=(1, 3))                      # area-integrate to 1 px
    return px[m:m + height_px, m:m + width_px]


def sensor(clean: np.ndarray, rng: np.random.Generator, noise_dn: float, *, fog_t: float = 1.0,
           gain: float = 1.0, offset_dn: float = 0.0) -> np.ndarray:
    """Fog (Koschmieder), radiometric gain/offset, independent read noise, round, clip to uint8."""
    radiance = fog_t * clean + (1.0 - fog_t) * AIRLIGHT_DN
    signal = gain * radiance + offset_dn + noise_dn * rng.standard_normal(clean.shape)
    return np.clip(np.floor(signal + 0.5), 0, 255).astype(np.uint8)


@dataclass(frozen=True)
class Pair:
    """A rendered pair with its truth: right(x) = left(x + disparity_px)."""

    left: np.ndarray
    right: np.ndarray
    clean_left: np.ndarray
    clean_right: np.ndarray
    disparity_px: float


def render_pair(scene: Scene, rng: np.random.Generator, disparity_32nds: int, *,
                height_px: int, width_px: int, x0_px: int = MARGIN_PX, y0_px: int = MARGIN_PX,
                vertical_offset_8ths: int = 0, psf_sigma_px: float = 0.35, noise_dn: float = 1.0,
                fog_t: float = 1.0, gain: float = 1.0, offset_dn: float = 0.0) -> Pair:
    """Left view at pixel (x0_px, y0_px) of the scene; right view cropped `disparity_32nds`/32 px
    further right (and `vertical_offset_8ths`/8 px lower), so right(x) = left(x + d) exactly.
    Gain/offset apply to the right camera only."""
    xl, yl = x0_px * SAMPLES_PER_PX, y0_px * ROWS_PER_PX
    clean_l = render_view(scene, xl, yl, height_px, width_px, psf_sigma_px)
    clean_r = render_view(scene, xl + disparity_32nds, yl + vertical_offset_8ths, height_px, width_px,
                          psf_sigma_px)
    left = sensor(clean_l, rng, noise_dn, fog_t=fog_t)
    right = sensor(clean_r, rng, noise_dn, fog_t=fog_t, gain=gain, offset_dn=offset_dn)
    return Pair(left, right, fog_t * clean_l, fog_t * clean_r, disparity_32nds / SAMPLES_PER_PX)


@dataclass(frozen=True)
class Condition:
    """One row of the evaluation protocol (research note §6)."""

    name: str
    kind: str = "hull"
    noise_dn: float = 1.0
    fog_t: float = 1.0
    gain: float = 1.0
    offset_dn: float = 0.0
    vertical_8ths: int = 0
    psf_sigma_px: float = 0.35


@dataclass(frozen=True)
class Sweep:
    """Errors (measured - true, px; NaN where the matcher said invalid) for seeds x fractions,
    and the per-seed Cramer-Rao bound sigma = noise * sqrt(2 / sum Ix^2) of the clean window."""

    errors: np.ndarray
    crb_px: np.ndarray
    fractions: np.ndarray


def sweep(condition: Condition, seeds: list[int] | range, matcher, *, n_fractions: int = 32,
          whole_px: int = 4, window: int = 15) -> Sweep:
    """Run `matcher(left, right, x, y) -> Match` on exact-shift pairs d = whole_px + k/n_fractions
    (k = 0 .. n-1; n divides 32) for every texture seed; see `sweep_many`."""
    return sweep_many(condition, seeds, {"m": matcher}, n_fractions=n_fractions, whole_px=whole_px,
                      window=window)["m"]


def sweep_many(condition: Condition, seeds: list[int] | range, matchers: dict, *, n_fractions: int = 32,
               whole_px: int = 4, window: int = 15) -> dict[str, Sweep]:
    """Like `sweep` for several matchers on the very same pairs (rendered once). Noise uses
    seed-derived streams apart from the texture stream, so a seed list fully determines the
    result."""
    step = SAMPLES_PER_PX // n_fractions
    size_y, size_x = window + 6, window + 2 * whole_px + 12
    xc, yc = size_x - window // 2 - 5, size_y // 2
    errors = {name: np.full((len(seeds), n_fractions), np.nan) for name in matchers}
    crb = np.empty(len(seeds))
    noise_eff = float(np.hypot(condition.noise_dn, np.sqrt(1 / 12)))      # + uint8 rounding
    for i, seed in enumerate(seeds):
        scene = make_scene(np.random.default_rng([seed, 1]), size_y + 2 * MARGIN_PX + 2,
                           size_x + whole_px + 2 * MARGIN_PX + 4, condition.kind)
        noise_rng = np.random.default_rng([seed, 2])
        x0_px = MARGIN_PX + 1
        xs, ys = x0_px * SAMPLES_PER_PX, MARGIN_PX * ROWS_PER_PX
        grad = (render_view(scene, xs + 1, ys, size_y, size_x, condition.psf_sigma_px)
                - render_view(scene, xs - 1, ys, size_y, size_x, condition.psf_sigma_px))
        h = window // 2
        ix = grad[yc - h:yc + h + 1, xc - h:xc + h + 1] * (SAMPLES_PER_PX / 2) * condition.fog_t
        crb[i] = noise_eff * np.sqrt(2.0 / max(float((ix * ix).sum()), 1e-12))
        for k in range(n_fractions):
            pair = render_pair(scene, noise_rng, whole_px * SAMPLES_PER_PX + k * step,
                               height_px=size_y, width_px=size_x, x0_px=x0_px,
                               vertical_offset_8ths=condition.vertical_8ths,
                               psf_sigma_px=condition.psf_sigma_px, noise_dn=condition.noise_dn,
                               fog_t=condition.fog_t, gain=condition.gain, offset_dn=condition.offset_dn)
            for name, matcher in matchers.items():
                m = matcher(pair.left, pair.right, xc, yc)
                if m.valid:
                    errors[name][i, k] = m.disparity_px - pair.disparity_px
    fractions = np.arange(n_fractions) / n_fractions
    return {name: Sweep(e, crb, fractions) for name, e in errors.items()}
