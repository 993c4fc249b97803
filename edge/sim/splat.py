"""Drawing many small world features (foam blobs, sun sparkles) into a radiance image.

Each feature is an axis-aligned Gaussian footprint in the image: centre
(u, v), widths (sigma_u, sigma_v) in pixels and total radiance `energy`
(DN * px^2). Features narrower than `SMALL_PX` in both directions are
deposited bilinearly onto the four nearest pixel centres (energy and
centroid are exact; the optics' PSF spreads them afterwards), all at once
with `np.add.at`. Wider ones get the exact pixel integral of their Gaussian
(separable erf weights), one patch each; there are few of those (the near
ones).
"""

from __future__ import annotations

import numpy as np
from scipy.special import erf

SMALL_PX = 0.7


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
    ok &= (u > -4.0 * sigma_u - 1) & (u < w + 4.0 * sigma_u) & (v > -4.0 * sigma_v - 1) & (v < h + 4.0 * sigma_v)
    small = ok & (np.maximum(sigma_u, sigma_v) < SMALL_PX)
    if small.any():
        us, vs, es = u[small], v[small], energy[small]
        c0, r0 = np.floor(us).astype(np.int64), np.floor(vs).astype(np.int64)
        fu, fv = us - c0, vs - r0
        flat = image.reshape(-1)
        for dr, dc, wgt in ((0, 0, (1 - fu) * (1 - fv)), (0, 1, fu * (1 - fv)), (1, 0, (1 - fu) * fv), (1, 1, fu * fv)):
            r, c = r0 + dr, c0 + dc
            inside = (r >= 0) & (r < h) & (c >= 0) & (c < w)
            np.add.at(flat, r[inside] * w + c[inside], (es * wgt)[inside].astype(image.dtype))
    for i in np.flatnonzero(ok & ~small):
        _patch(image, float(u[i]), float(v[i]), float(energy[i]), float(sigma_u[i]), float(sigma_v[i]))


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
    image[r0:r1, c0:c1] += (energy * np.outer(_weights(r0, r1, v, sv), _weights(c0, c1, u, su))).astype(image.dtype)
