"""Drawing many small world features (foam blobs, sun sparkles) into a radiance image.

Each feature is an axis-aligned Gaussian footprint in the image: centre
(u, v), widths (sigma_u, sigma_v) in pixels and total radiance `energy`
(DN * px^2). A feature is deposited bilinearly onto the four nearest pixel
centres (energy and centroid exact; the optics' PSF spreads it afterwards)
if it is narrower than `STEP_PX`; a wider one is first cut into a grid of
sub-points no more than `STEP_PX` apart, weighted by its Gaussian, so all
features go in at once with `np.add.at`. The few very wide ones (more than
`MAX_POINTS` sub-points) get the exact pixel integral of their Gaussian
(separable erf weights), one patch each.
"""

from __future__ import annotations

import numpy as np
from scipy.special import erf

STEP_PX = 0.6
MAX_POINTS = 256


def splat(
    image: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    energy: np.ndarray,
    sigma_u: np.ndarray,
    sigma_v: np.ndarray,
) -> None:
    """Add the features to `image` (float, modified in place); those outside the image are dropped."""
    h, w = image.shape
    ok = np.isfinite(u) & np.isfinite(v) & (energy != 0.0)
    ok &= (
        (u > -4.0 * sigma_u - 1)
        & (u < w + 4.0 * sigma_u)
        & (v > -4.0 * sigma_v - 1)
        & (v < h + 4.0 * sigma_v)
    )
    n_u = np.where(ok, np.maximum(np.ceil(4.0 * sigma_u / STEP_PX), 1), 0).astype(np.int64)
    n_v = np.where(ok, np.maximum(np.ceil(4.0 * sigma_v / STEP_PX), 1), 0).astype(np.int64)
    grid = ok & (n_u * n_v <= MAX_POINTS)
    if grid.any():
        idx = np.flatnonzero(grid)
        counts = n_u[idx] * n_v[idx]
        owner = np.repeat(idx, counts)
        k = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)  # index within owner
        nu, nv = n_u[owner], n_v[owner]
        qu = np.where(nu > 1, 4.0 * (k % nu) / np.maximum(nu - 1, 1) - 2.0, 0.0)  # in sigmas, -2 .. 2
        qv = np.where(nv > 1, 4.0 * (k // nu) / np.maximum(nv - 1, 1) - 2.0, 0.0)
        wgt = np.exp(-0.5 * (qu**2 + qv**2))
        total = np.zeros(len(u))
        np.add.at(total, owner, wgt)
        _bilinear(
            image,
            u[owner] + qu * sigma_u[owner],
            v[owner] + qv * sigma_v[owner],
            energy[owner] * wgt / total[owner],
        )
    for i in np.flatnonzero(ok & ~grid):
        _patch(image, float(u[i]), float(v[i]), float(energy[i]), float(sigma_u[i]), float(sigma_v[i]))


def _bilinear(image: np.ndarray, u: np.ndarray, v: np.ndarray, energy: np.ndarray) -> None:
    h, w = image.shape
    c0, r0 = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
    fu, fv = u - c0, v - r0
    flat = image.reshape(-1)
    for dr, dc, wgt in (
        (0, 0, (1 - fu) * (1 - fv)),
        (0, 1, fu * (1 - fv)),
        (1, 0, (1 - fu) * fv),
        (1, 1, fu * fv),
    ):
        r, c = r0 + dr, c0 + dc
        inside = (r >= 0) & (r < h) & (c >= 0) & (c < w)
        np.add.at(flat, r[inside] * w + c[inside], (energy * wgt)[inside].astype(image.dtype))


def _weights(lo: int, hi: int, centre: float, sigma: float) -> np.ndarray:
    edges = np.arange(lo, hi + 1) - 0.5
    return 0.5 * np.diff(erf((edges - centre) / (np.sqrt(2.0) * max(sigma, 1e-3))))


def _patch(image: np.ndarray, u: float, v: float, energy: float, su: float, sv: float) -> None:
    h, w = image.shape
    ru, rv = int(np.ceil(4.0 * su)) + 1, int(np.ceil(4.0 * sv)) + 1
    r0, r1 = max(int(v) - rv, 0), min(int(v) + rv + 1, h)
    c0, c1 = max(int(u) - ru, 0), min(int(u) + ru + 1, w)
    if r0 >= r1 or c0 >= c1:
        return
    image[r0:r1, c0:c1] += (energy * np.outer(_weights(r0, r1, v, sv), _weights(c0, c1, u, su))).astype(
        image.dtype
    )
