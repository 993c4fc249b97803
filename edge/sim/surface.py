"""Where short-lived sea features are born, and how a foam patch on the sea is drawn in one view.

Whitecaps and sun sparkles are world-space events on the sea sphere: a
point (x, z), a birth time and a life. They are drawn from a Poisson process
over a wedge of sea in front of the rig (ranges `min_range_m` to
`max_range_m`, bearings covering the field of view with a margin), one
second of births at a time: block b holds the events born in [b, b + 1) s,
drawn from a generator seeded with (seed, tag, b). A frame needs only the
few blocks whose events can still be alive, so a frame renders the same
bytes in any order and a 10-minute scenario never holds all its events.

`draw_patches` puts elliptical foam patches (whitecaps, wakes) into one
view: each is projected through that camera (so both views see it with the
disparity of its range), its brightness is the foam's radiance minus the
sea's there, both through the haze of that path, and its pixel footprint is
the projected ellipse's (vertically squashed by the grazing view).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from edge.sim.rays import CameraRays
from edge.sim.scene import World, transmission
from edge.sim.splat import splat


@dataclass(frozen=True)
class Wedge:
    """The sea area events are drawn over: ranges (m), bearings (rad, from +Z toward +X) from the origin."""

    min_range_m: float
    max_range_m: float
    half_bearing_rad: float

    @property
    def area_m2(self) -> float:
        return self.half_bearing_rad * (self.max_range_m**2 - self.min_range_m**2)

    def sample(self, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
        """n points uniform over the wedge's area: world (x, z)."""
        r = np.sqrt(rng.uniform(self.min_range_m**2, self.max_range_m**2, n))
        bearing = rng.uniform(-self.half_bearing_rad, self.half_bearing_rad, n)
        return r * np.sin(bearing), r * np.cos(bearing)


class BlockCache:
    """Events by one-second birth block, generated on demand and kept for the last few blocks."""

    def __init__(self, make, keep: int = 64) -> None:
        self.make, self.keep = make, keep
        self.blocks: dict[int, dict[str, np.ndarray]] = {}

    def alive(self, t_s: float, max_life_s: float) -> dict[str, np.ndarray]:
        """All events of the blocks that may hold one alive at t_s, concatenated (caller filters by age)."""
        first, last = math.floor(t_s - max_life_s), math.floor(t_s)
        parts = []
        for b in range(first, last + 1):
            if b not in self.blocks:
                if len(self.blocks) >= self.keep:
                    self.blocks.pop(next(iter(self.blocks)))
                self.blocks[b] = self.make(b)
            parts.append(self.blocks[b])
        return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}


def foam_radiance_dn(world: World, albedo: float) -> float:
    """Radiance of level white foam (before haze), DN: a diffuse surface under the whole sky (the mean of
    its horizon and zenith radiance) plus the direct sun on a level surface."""
    sun, sky = world.sun, world.sky
    sky_dn = 0.5 * (sky.horizon_dn + sky.zenith_dn)
    return albedo * (sky_dn + sun.direct_dn * max(math.sin(math.radians(sun.elevation_deg)), 0.0))


def _pinhole_offsets(rel: np.ndarray, step: np.ndarray, focal_px: float) -> np.ndarray:
    """Image displacement (n, 2) of a small world step at camera-relative points (first order, pinhole,
    axes of the world frame; the tilt of a real camera is a degree or two): the patch's size, not place."""
    z = rel[:, 2:3]
    return focal_px * (step[:, :2] / z - rel[:, :2] * step[:, 2:3] / z**2)


def draw_patches(
    image: np.ndarray,
    rays: CameraRays,
    world: World,
    x: np.ndarray,
    z: np.ndarray,
    half_along_m: np.ndarray,
    half_across_m: np.ndarray,
    heading_rad: np.ndarray,
    cover: np.ndarray,
    foam_dn: float,
) -> None:
    """Add foam patches to `image` (radiance, float32). `cover` (0..1): how white each patch is now;
    a patch is an ellipse on the sea with semi-axes along `heading_rad` (azimuth) and across it."""
    if len(x) == 0:
        return
    y = world.surface_y_m(x, z)
    centre = np.stack([x, y, z], axis=-1)
    along = np.stack([np.sin(heading_rad), np.zeros_like(x), np.cos(heading_rad)], axis=-1)
    across = np.stack([np.cos(heading_rad), np.zeros_like(x), -np.sin(heading_rad)], axis=-1)
    c = rays.project(centre)  # exact: the disparity of the patch is that of its centre
    a, b = (
        _pinhole_offsets(centre - rays.origin, along * half_along_m[:, None], rays.focal_px),
        _pinhole_offsets(centre - rays.origin, across * half_across_m[:, None], rays.focal_px),
    )
    area_px = np.pi * np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    sigma_u = 0.5 * np.hypot(a[:, 0], b[:, 0])  # a uniform ellipse's spread (variance: semi-axis^2 / 4)
    sigma_v = 0.5 * np.hypot(a[:, 1], b[:, 1])
    dirs = centre - rays.origin
    dirs = dirs / dirs[:, 2:3]  # the renderer's ray form (x, y, 1)
    t_hit = world.sea_hit(rays.origin, dirs)
    t_hit = np.where(
        np.isfinite(t_hit), t_hit, np.linalg.norm(centre - rays.origin, axis=1) / np.linalg.norm(dirs, axis=1)
    )
    _, sea_scale, _ = world.sea_static_dn(rays.origin, dirs, t_hit)  # transmission * sea radiance
    trans = transmission(t_hit * np.linalg.norm(dirs, axis=1), world.atmosphere.visibility_m)
    contrast = trans * foam_dn - sea_scale
    splat(image, c[:, 0], c[:, 1], contrast * cover * area_px, sigma_u, sigma_v)
