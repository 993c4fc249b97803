"""Sun glitter: the sun's reflection broken up by the wave facets into short, bright sparkles.

A facet sends the sun into the camera only if it is tilted by the half-angle
between the sun and the line of sight; with Gaussian facet slopes of
variance sigma^2 (Cox-Munk, from the wind; edge.sim.seastate) the density of
such facets at a sea point is exp(-tan^2(tilt) / sigma^2) relative to the
point of mirror reflection. So glitter gathers in a column below the sun's
azimuth, widest for a low sun and a rough sea, and vanishes with the sun
behind the cameras.

Two parts, both optional (`glitter:` in a scenario):

- the mean glitter (`glow_dn`): that density times `glow_dn`, added to the
  static sea radiance (edge.sim.scene.World.sea_static_dn), through the haze;
- sparkles (`rate_per_m2_s` at the glitter's centre): world-space points born
  at that rate times the density (a Poisson process thinned by the density,
  edge.sim.surface), each living tens of milliseconds (sin^2 flash). A facet
  reflects the sun's disc into a narrow cone (`cone_mrad`); each sparkle's
  cone is aimed at a random point near the baseline, so the two cameras, 8 m
  apart, both see a far sparkle (at the disparity of its range) while a near
  one is often seen by one camera only, as on a real rig.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from edge.config.schema import setting
from edge.sim.rays import CameraRays
from edge.sim.scene import World, transmission
from edge.sim.seastate import slope_variance, specular_ratio, wind_mps
from edge.sim.splat import splat
from edge.sim.surface import BlockCache, Wedge

DEFAULT_WIND_MPS = 5.0  # glitter width when neither wind_mps nor a sea_state is given
SPARKLE_SIGMA_PX = 0.45


@dataclass(frozen=True)
class GlitterSpec:
    rate_per_m2_s: float = setting(
        0.0, min=0.0, max=10.0, doc="sparkles born per m^2 per s at the glitter's centre (0: none)"
    )
    glow_dn: float = setting(
        0.0, min=0.0, max=2000.0, doc="mean glitter radiance at its centre, DN (0: none)"
    )
    wind_mps: float | None = setting(
        None, min=0.0, max=40.0, doc="wind for the facet slopes; null: the sea_state's"
    )
    peak_dn: float = setting(500.0, positive=True, doc="peak radiance of a typical sparkle, DN (saturates)")
    duration_s: tuple[float, float] = setting((0.03, 0.15), positive=True, doc="shortest and longest sparkle")
    cone_mrad: float = setting(6.0, positive=True, max=100.0, doc="spread of a facet's reflected beam, mrad")
    min_range_m: float = setting(40.0, positive=True, doc="sparkles lie beyond this range, m")
    max_range_m: float = setting(4000.0, positive=True, doc="and within this one, m")
    seed: int = setting(0, min=0, doc="added to the render seed")

    @property
    def enabled(self) -> bool:
        return self.rate_per_m2_s > 0.0 or self.glow_dn > 0.0


def glitter_sigma2(spec: GlitterSpec, sea_state: int | None) -> float:
    """Facet slope variance for the glitter: from its wind, else the sea state's, else a light breeze."""
    if spec.wind_mps is not None:
        return slope_variance(spec.wind_mps)
    return slope_variance(wind_mps(sea_state) if sea_state is not None else DEFAULT_WIND_MPS)


class Sparkles:
    """The sparkle events of one scenario and seed, drawn in either view."""

    def __init__(
        self,
        spec: GlitterSpec,
        world: World,
        sigma2: float,
        half_bearing_rad: float,
        baseline_m: float,
        seed: int,
    ) -> None:
        self.spec, self.world, self.sigma2 = spec, world, sigma2
        self.seed = seed + spec.seed
        self.baseline_m = baseline_m
        self.wedge = Wedge(spec.min_range_m, spec.max_range_m, half_bearing_rad)
        self.cache = BlockCache(self._block)

    def density(self, x: np.ndarray, z: np.ndarray) -> np.ndarray:
        """Sparkle births per m^2 per s at world (x, z), seen from the baseline's midpoint."""
        pts = np.stack([x, self.world.surface_y_m(x, z), z], axis=-1)
        ratio = specular_ratio(pts, np.zeros(3), self.world.sun_dir, self.world.centre, self.sigma2)
        return self.spec.rate_per_m2_s * ratio

    def _block(self, b: int) -> dict[str, np.ndarray]:
        rng = np.random.default_rng([self.seed, 0x6117, b + (1 << 40)])
        n = int(rng.poisson(self.spec.rate_per_m2_s * self.wedge.area_m2))  # candidates at the peak rate
        x, z = self.wedge.sample(rng, n)
        keep = rng.uniform(0.0, 1.0, n) * self.spec.rate_per_m2_s < self.density(x, z)  # thinning
        m = int(keep.sum())
        lo, hi = self.spec.duration_s
        r = np.hypot(x[keep], z[keep])
        reach = 0.5 * self.baseline_m + 2.0 * self.spec.cone_mrad * 1e-3 * r
        return {
            "x": x[keep],
            "z": z[keep],
            "t0": b + rng.uniform(0.0, 1.0, m),
            "life": rng.uniform(lo, hi, m),
            "gain": np.exp(0.6 * rng.standard_normal(m)),  # facet sizes and curvatures vary
            "aim": rng.uniform(-1.0, 1.0, m) * reach,  # X where the reflected beam's axis meets the baseline
        }

    def alive(self, t_s: float) -> dict[str, np.ndarray]:
        ev = self.cache.alive(t_s, self.spec.duration_s[1])
        age = (t_s - ev["t0"]) / ev["life"]
        live = (age >= 0.0) & (age < 1.0)
        out = {k: v[live] for k, v in ev.items()}
        out["flash"] = np.sin(np.pi * age[live]) ** 2
        return out

    def draw(self, image: np.ndarray, rays: CameraRays, t_s: float) -> None:
        """Add the sparkles alive at t_s, as this camera sees them, to a radiance image."""
        ev = self.alive(t_s)
        if len(ev["x"]) == 0:
            return
        x, z = ev["x"], ev["z"]
        pts = np.stack([x, self.world.surface_y_m(x, z), z], axis=-1)
        dist = np.linalg.norm(pts - rays.origin, axis=1)
        beam = self.spec.cone_mrad * 1e-3 * dist
        seen = np.exp(-0.5 * ((rays.origin[0] - ev["aim"]) / beam) ** 2)
        energy = (
            self.spec.peak_dn
            * 2.0
            * math.pi
            * SPARKLE_SIGMA_PX**2
            * ev["gain"]
            * ev["flash"]
            * seen
            * transmission(dist, self.world.atmosphere.visibility_m)
        )
        uv = rays.project(pts)
        sigma = np.full(len(x), SPARKLE_SIGMA_PX)
        splat(image, uv[:, 0], uv[:, 1], energy, sigma, sigma)
