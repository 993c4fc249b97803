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
        rad_corner, _, hit_corner, land_corner = self._radiance(corner_dirs, t_corner)
        lut = rays.lut  # pixel centres: the mean of the four corners (the exact bilinear value)
        centre_xy = 0.25 * (lut[:-1, :-1] + lut[:-1, 1:] + lut[1:, :-1] + lut[1:, 1:])
        centre_dirs = np.concatenate([centre_xy, np.ones((h, w, 1))], axis=-1)
        t_centre = world.sea_hit(origin, centre_dirs)
        rad_centre, scale_centre, hit_centre, land_centre = self._radiance(centre_dirs, t_centre)

        if land_corner is not None:  # land in front of sea or sky: its pixels are neither
            sea_corner &= ~land_corner
        n_sea = (
            sea_corner[:-1, :-1].astype(np.int8)
            + sea_corner[:-1, 1:]
            + sea_corner[1:, :-1]
            + sea_corner[1:, 1:]
        )
        corner_sum = rad_corner[:-1, :-1] + rad_corner[:-1, 1:] + rad_corner[1:, :-1] + rad_corner[1:, 1:]
        static = corner_sum / 12.0 + rad_centre * (2.0 / 3.0)
        horizon = (n_sea > 0) & (n_sea < 4)
        if land_corner is not None and land_centre is not None:  # land outlines: integrated like the horizon
            n_land = (
                land_corner[:-1, :-1].astype(np.int8)
                + land_corner[:-1, 1:]
                + land_corner[1:, :-1]
                + land_corner[1:, 1:]
            )
            horizon |= (n_land > 0) & (n_land < 4)
            n_sea = np.where(land_centre, 0, n_sea)  # the corners may all miss a thin post
        rows, cols = np.nonzero(horizon)
        static[rows, cols] = self.integrate(rows, cols)
        self.static = static.astype(np.float32)
        self.sea_mask = n_sea == 4
        self.horizon_mask = horizon
        self.sea_cover = (n_sea / 4.0).astype(np.float32)  # share of each pixel that is open sea (corners)

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
            self.basis[start : start + len(idx), n : 2 * n] = amp * np.sin(phase)
        if world.swell is not None:
            swell = self._swell_basis(d_u, d_v, hit_centre, t_centre)
            self.basis = np.concatenate([self.basis, swell], axis=1)

    def _swell_basis(
        self, d_u: np.ndarray, d_v: np.ndarray, hit_centre: np.ndarray, t_centre: np.ndarray
    ) -> np.ndarray:
        """Columns [cos | sin] of the swell components over the sea pixels, box-averaged like the waves."""
        swell = self.world.swell
        assert swell is not None
        m = len(swell.omega)
        out = np.zeros((len(self.sea_index), 2 * m), np.float32)
        k_half = 0.5 * swell.k.T
        centre_dirs = np.concatenate([self.rays.lut, np.ones(self.rays.lut.shape[:-1] + (1,))], axis=-1)
        c = centre_dirs
        centre_dirs = 0.25 * (c[:-1, :-1] + c[:-1, 1:] + c[1:, :-1] + c[1:, 1:])
        for start in range(0, len(self.sea_index), 1 << 18):
            idx = self.sea_index[start : start + (1 << 18)]
            amp = _sinc(d_u.reshape(-1, 2)[idx] @ k_half) * _sinc(d_v.reshape(-1, 2)[idx] @ k_half)
            dirs, t_hit = centre_dirs.reshape(-1, 3)[idx], t_centre.reshape(-1)[idx]
            amp *= self.world.swell_gain(self.rays.origin, dirs, t_hit)
            phase = hit_centre.reshape(-1, 3)[idx][:, [0, 2]] @ swell.k.T + swell.phase
            out[start : start + len(idx), :m] = amp * np.cos(phase)
            out[start : start + len(idx), m:] = amp * np.sin(phase)
        return out

    def _radiance(
        self, dirs: np.ndarray, t_sea: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
        """Sky, static-sea or land radiance along rays; the wave scale, sea hit points (NaN for sky) and
        where land is in front (None: the scene has no land)."""
        sea = np.isfinite(t_sea)
        radiance = self.world.sky_dn(dirs)
        scale = np.zeros(t_sea.shape)
        points = np.full(t_sea.shape + (3,), np.nan)
        if sea.any():
            rad_sea, scale_sea, pts = self.world.sea_static_dn(self.rays.origin, dirs[sea], t_sea[sea])
            radiance[sea], scale[sea], points[sea] = rad_sea, scale_sea, pts
        if self.world.land is not None:
            t_land, rad_land = self.world.land.hit(self.rays.origin, dirs.reshape(-1, 3))
            on_land = (t_land < t_sea.reshape(-1)).reshape(t_sea.shape)
            radiance[on_land] = rad_land.reshape(t_sea.shape)[on_land]
            scale[on_land] = 0.0
            return radiance, scale, points, on_land
        return radiance, scale, points, None

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
