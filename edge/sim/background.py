"""Sky and sea of one camera, integrated over each pixel once, animated cheaply per frame.

Per pixel, computed once per camera:

- pixels whose four corners all see sky (or all see sea) integrate the smooth
  radiance with a cubature exact to degree 3 (corners 1/12 each, centre 2/3);
- pixels the horizon crosses (corners disagree) average 64 multi-jittered
  rays, so the horizon's sub-pixel position is honest in both views;
- the wave texture is a sum of deep-water sinusoids over world (x, z). For a
  pixel, its footprint on the sea is the parallelogram spanned by the corner
  hit points, and the exact box average of a sinusoid of phase gradient g
  over it is S(g_u / 2) S(g_v / 2) with S(x) = sin(x) / x: far waves fade
  instead of aliasing.

Because a sinusoid's time dependence factors out, cos(phi - w t) =
cos(phi) cos(w t) + sin(phi) sin(w t), each frame's sea is one matrix-vector
product `basis @ coeffs(t)` added to the static image.
"""

from __future__ import annotations

import numpy as np

from edge.sim.rays import EDGE_SAMPLES, CameraRays
from edge.sim.scene import World


def _sinc(x: np.ndarray) -> np.ndarray:
    """sin(x) / x (unnormalised), 1 at 0; float32 in, float32 out."""
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.sin(x) / x
    out[x == 0.0] = 1.0
    return out


class Background:
    """The static sky/sea radiance of one camera plus its per-frame wave term."""

    def __init__(self, rays: CameraRays, world: World) -> None:
        self.rays, self.world = rays, world
        h, w = rays.height, rays.width
        origin = rays.origin
        corner_dirs = np.concatenate([rays.lut, np.ones((h + 1, w + 1, 1))], axis=-1)
        t_corner = world.sea_hit(origin, corner_dirs)
        sea_corner = np.isfinite(t_corner)
        rad_corner, _, hit_corner = self._radiance(corner_dirs, t_corner)
        lut = rays.lut  # pixel centres: the mean of the four corners (the exact bilinear value)
        centre_xy = 0.25 * (lut[:-1, :-1] + lut[:-1, 1:] + lut[1:, :-1] + lut[1:, 1:])
        centre_dirs = np.concatenate([centre_xy, np.ones((h, w, 1))], axis=-1)
        t_centre = world.sea_hit(origin, centre_dirs)
        rad_centre, scale_centre, hit_centre = self._radiance(centre_dirs, t_centre)

        n_sea = (
            sea_corner[:-1, :-1].astype(np.int8)
            + sea_corner[:-1, 1:]
            + sea_corner[1:, :-1]
            + sea_corner[1:, 1:]
        )
        corner_sum = rad_corner[:-1, :-1] + rad_corner[:-1, 1:] + rad_corner[1:, :-1] + rad_corner[1:, 1:]
        static = corner_sum / 12.0 + rad_centre * (2.0 / 3.0)
        horizon = (n_sea > 0) & (n_sea < 4)
        rows, cols = np.nonzero(horizon)
        static[rows, cols] = self.integrate(rows, cols)
        self.static = static.astype(np.float32)
        self.sea_mask = n_sea == 4
        self.horizon_mask = horizon

        # wave basis over sea pixels: footprint Jacobian from the corner hit points (x, z)
        xz = hit_corner[..., [0, 2]]
        d_u = 0.5 * ((xz[:-1, 1:] - xz[:-1, :-1]) + (xz[1:, 1:] - xz[1:, :-1]))
        d_v = 0.5 * ((xz[1:, :-1] - xz[:-1, :-1]) + (xz[1:, 1:] - xz[:-1, 1:]))
        self.sea_index = np.flatnonzero(self.sea_mask)
        waves = world.waves
        n = len(waves.omega)
        self.basis = np.zeros((len(self.sea_index), 2 * n), np.float32)
        k_half = (0.5 * waves.k.T).astype(np.float32)  # half phase step per pixel: box average is sin(x)/x
        for start in range(0, len(self.sea_index), 1 << 18):  # chunks bound the temporaries
            idx = self.sea_index[start : start + (1 << 18)]
            amp = _sinc(d_u.reshape(-1, 2)[idx].astype(np.float32) @ k_half)
            amp *= _sinc(d_v.reshape(-1, 2)[idx].astype(np.float32) @ k_half)
            amp *= waves.amplitude.astype(np.float32) * scale_centre.reshape(-1)[idx, None].astype(np.float32)
            phase = world.wave_phase(hit_centre.reshape(-1, 3)[idx][:, [0, 2]]).astype(np.float32)
            self.basis[start : start + len(idx), :n] = amp * np.cos(phase)
            self.basis[start : start + len(idx), n:] = amp * np.sin(phase)

    def _radiance(self, dirs: np.ndarray, t_sea: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Sky or static-sea radiance along rays; the wave scale and hit points (NaN for sky)."""
        sea = np.isfinite(t_sea)
        radiance = self.world.sky_dn(dirs)
        scale = np.zeros(t_sea.shape)
        points = np.full(t_sea.shape + (3,), np.nan)
        if sea.any():
            rad_sea, scale_sea, pts = self.world.sea_static_dn(self.rays.origin, dirs[sea], t_sea[sea])
            radiance[sea], scale[sea], points[sea] = rad_sea, scale_sea, pts
        return radiance, scale, points

    def radiance_of(self, dirs: np.ndarray, t_sea: np.ndarray) -> np.ndarray:
        """Static sky/sea radiance of individual rays (sub-pixel samples) given their sea hits, no waves."""
        return self._radiance(dirs, t_sea)[0]

    def integrate(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Static radiance of whole pixels by 64 multi-jittered rays each."""
        if len(rows) == 0:
            return np.zeros(0)
        u = cols[:, None] + EDGE_SAMPLES[None, :, 0]
        v = rows[:, None] + EDGE_SAMPLES[None, :, 1]
        dirs = self.rays.dirs(u.ravel(), v.ravel())
        t_sea = self.world.sea_hit(self.rays.origin, dirs)
        return self.radiance_of(dirs, t_sea).reshape(len(rows), -1).mean(axis=1)

    def at(self, t_s: float) -> np.ndarray:
        """The whole background radiance image at time t_s (a fresh float32 array)."""
        image = self.static.copy()
        if self.basis.shape[1]:
            image.reshape(-1)[self.sea_index] += self.basis @ self.world.wave_time_coeffs(t_s)
        return image
