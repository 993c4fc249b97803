"""The world the cameras look at: a curved sea under a sky, seen through haze or fog.

Geometry (rig frame of docs/method.md: X right, Y down, Z forward, origin at the
baseline midpoint, `height_m` above mean sea level):

- The sea is the sphere of the *effective* Earth radius R_e = R / (1 - k)
  centred at (0, h + R_e, 0). k = 0.13 is the standard optical refraction
  coefficient: rays are drawn straight over an Earth enlarged by refraction,
  the usual surveying model. k = 0 gives the purely geometric Earth. The
  horizon therefore lies at the dip angle arccos(R_e / (R_e + h)) below the
  horizontal (closed form in `horizon_dip_rad`), ships beyond the horizon sink
  hull-first, and everything is in the same (refracted) frame as the truth.
- Sky radiance falls from `horizon_dn` to `zenith_dn` with elevation.
- The sea reflects the sky with Schlick's Fresnel term on facets tilted by the
  mean wave slope, over a dark water body: the brightness gradient toward the
  horizon comes out of the physics rather than a painted ramp. Waves are a
  sum of deep-water sinusoids (omega^2 = g k) in world (x, z), so both
  cameras see the same moving surface.
- Fog and haze follow Koschmieder: I = t J + (1 - t) A with
  t = exp(-3.912 d / V) for a path of length d and meteorological visibility
  V. Paths to the sky cross a fog layer `fog_top_m` thick, so the sky fades
  to the airlight A toward the horizon.

All radiances are in DN at unit exposure (8-bit scale before noise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from edge.config.schema import setting
from edge.sim.seastate import specular_ratio

EARTH_RADIUS_M = 6_371_000.0  # mean radius
STANDARD_REFRACTION_K = 0.13  # optical coefficient of refraction (surveying standard)
KOSCHMIEDER = 3.912  # -ln(0.02): the 2 % contrast threshold that defines visibility
GRAVITY_MPS2 = 9.81
FRESNEL_F0 = 0.02  # water at normal incidence


@dataclass(frozen=True)
class Atmosphere:
    """Haze/fog and refraction. `visibility_m` is the meteorological visibility V."""

    visibility_m: float = setting(40_000.0, positive=True, doc="meteorological visibility V, metres")
    airlight_dn: float = setting(190.0, min=0.0, doc="A: radiance of an infinitely deep fog, DN")
    fog_top_m: float = setting(400.0, positive=True, doc="thickness of the hazy layer a sky ray crosses")
    refraction_k: float = setting(
        STANDARD_REFRACTION_K,
        min=0.0,
        max=0.5,
        doc="refraction coefficient (0.13 standard, 0 none): Earth radius R/(1-k)",
    )


@dataclass(frozen=True)
class Sky:
    horizon_dn: float = setting(200.0, min=0.0, doc="clear-sky radiance at the horizon, DN")
    zenith_dn: float = setting(140.0, min=0.0, doc="clear-sky radiance high up, DN")
    falloff_deg: float = setting(12.0, positive=True, doc="elevation scale of the horizon-to-zenith change")


@dataclass(frozen=True)
class Sea:
    water_dn: float = setting(35.0, min=0.0, doc="radiance of the water body (a non-reflecting sea), DN")
    slope_rad: float = setting(0.12, min=0.0, max=0.5, doc="mean wave facet slope (sets horizon contrast)")
    wave_contrast: float = setting(0.15, min=0.0, max=0.9, doc="RMS relative modulation of the wave texture")
    wind_from_deg: float = setting(30.0, doc="wave travel azimuth in the world XZ plane, from +Z toward +X")
    spread_deg: float = setting(35.0, min=0.0, max=180.0, doc="directional spread of the wave components")
    wavelength_min_m: float = setting(1.5, positive=True, doc="shortest wave component, metres")
    wavelength_max_m: float = setting(40.0, positive=True, doc="longest wave component, metres")
    components: int = setting(12, min=0, max=64, doc="number of wave components")
    seed: int = setting(7, min=0, doc="wave phases and directions")


@dataclass(frozen=True)
class Sun:
    azimuth_deg: float = setting(120.0, doc="sun azimuth in the world XZ plane, from +Z toward +X")
    elevation_deg: float = setting(35.0, min=-10.0, max=90.0, doc="sun elevation (below 0: no direct light)")
    direct_dn: float = setting(160.0, min=0.0, doc="white Lambertian surface facing the sun, beyond ambient")
    ambient_dn: float = setting(90.0, min=0.0, doc="white upward surface lit by the sky alone, DN")


@dataclass(frozen=True)
class Swell:
    """Long waves from afar: bands across the sea, foreshortened with range (off at zero height)."""

    height_m: float = setting(0.0, min=0.0, max=15.0, doc="significant height H_s of the swell, m (0: none)")
    wavelength_m: float = setting(90.0, min=10.0, max=600.0, doc="mean wavelength, m")
    from_deg: float = setting(200.0, doc="travel azimuth in the world XZ plane, from +Z toward +X")
    spread_deg: float = setting(10.0, min=0.0, max=90.0, doc="directional spread of the components")
    components: int = setting(3, min=1, max=8, doc="number of swell components")
    seed: int = setting(11, min=0, doc="swell phases and directions")


@dataclass(frozen=True)
class SwellField:
    """Swell components: wave vectors k (m, 2), omega, slope amplitude a k, phase."""

    k: np.ndarray
    omega: np.ndarray
    slope: np.ndarray
    phase: np.ndarray

    @classmethod
    def from_spec(cls, swell: Swell) -> SwellField:
        rng = np.random.default_rng([swell.seed, 0x5E11])
        m = swell.components
        wavelength = swell.wavelength_m * rng.uniform(0.8, 1.25, m)
        knum = 2.0 * np.pi / wavelength
        azimuth = np.radians(swell.from_deg + swell.spread_deg * rng.uniform(-1.0, 1.0, m))
        amplitude = swell.height_m / 4.0 * math.sqrt(2.0 / m)  # H_s = 4 RMS elevation
        return cls(
            k=np.stack([knum * np.sin(azimuth), knum * np.cos(azimuth)], axis=-1),
            omega=np.sqrt(GRAVITY_MPS2 * knum),
            slope=amplitude * knum,
            phase=rng.uniform(0.0, 2.0 * np.pi, m),
        )


def effective_radius_m(refraction_k: float) -> float:
    """R_e = R / (1 - k): straight rays over this sphere mimic refracted rays over the real Earth."""
    return EARTH_RADIUS_M / (1.0 - refraction_k)


def horizon_dip_rad(height_m: float, refraction_k: float = STANDARD_REFRACTION_K) -> float:
    """Dip of the sea horizon below the horizontal for an eye `height_m` above the sea (closed form)."""
    r_e = effective_radius_m(refraction_k)
    return math.acos(r_e / (r_e + height_m))


def transmission(distance_m: np.ndarray | float, visibility_m: float) -> np.ndarray:
    """Koschmieder transmission t = exp(-3.912 d / V)."""
    return np.exp(-KOSCHMIEDER * np.asarray(distance_m, dtype=np.float64) / visibility_m)


def sun_direction(sun: Sun) -> np.ndarray:
    """Unit world vector toward the sun (Y down: positive elevation is negative Y); zero below the horizon."""
    if sun.elevation_deg <= 0.0:
        return np.zeros(3)
    az, el = math.radians(sun.azimuth_deg), math.radians(sun.elevation_deg)
    return np.array([math.cos(el) * math.sin(az), -math.sin(el), math.cos(el) * math.cos(az)])


@dataclass(frozen=True)
class WaveField:
    """Deep-water wave components: wave vectors k (n, 2) over world (x, z), omega, amplitude, phase."""

    k: np.ndarray
    omega: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray

    @classmethod
    def from_sea(cls, sea: Sea) -> WaveField:
        rng = np.random.default_rng([sea.seed, 0x5EA])
        n = max(int(sea.components), 0)
        wavelength = np.geomspace(sea.wavelength_min_m, sea.wavelength_max_m, n) if n else np.zeros(0)
        knum = 2.0 * np.pi / np.maximum(wavelength, 1e-9)
        azimuth = np.radians(sea.wind_from_deg + sea.spread_deg * rng.uniform(-1.0, 1.0, n))
        k = np.stack([knum * np.sin(azimuth), knum * np.cos(azimuth)], axis=-1)
        weight = np.sqrt(wavelength) * rng.uniform(0.6, 1.0, n)  # longer waves carry more modulation
        if n:
            weight *= sea.wave_contrast * math.sqrt(2.0) / np.sqrt(np.sum(weight**2))  # RMS = contrast
        omega = np.sqrt(GRAVITY_MPS2 * knum)  # deep-water dispersion
        return cls(k=k, omega=omega, amplitude=weight, phase=rng.uniform(0.0, 2.0 * np.pi, n))


class World:
    """Radiance of sky and sea along rays, and the Earth sphere they hit."""

    def __init__(
        self,
        height_m: float,
        atmosphere: Atmosphere,
        sky: Sky,
        sea: Sea,
        sun: Sun,
        swell: Swell | None = None,
        glow_dn: float = 0.0,
        glow_sigma2: float = 0.01,
    ) -> None:
        """`swell`: long waves that tilt the facets (off when None or of zero height); `glow_dn`: the mean
        sun glitter's radiance at its centre (Cox-Munk slopes of variance `glow_sigma2`); `land`
        (edge.sim.land.Land, set by the simulator): opaque land and foreground in front of sea and sky."""
        if not height_m > 0.0:
            raise ValueError(f"site height must be positive, got {height_m}")
        self.height_m = float(height_m)
        self.atmosphere, self.sky, self.sea, self.sun = atmosphere, sky, sea, sun
        self.radius_m = effective_radius_m(atmosphere.refraction_k)
        self.centre = np.array([0.0, self.height_m + self.radius_m, 0.0])
        self.waves = WaveField.from_sea(sea)
        self.sun_dir = sun_direction(sun)
        self.swell = SwellField.from_spec(swell) if swell is not None and swell.height_m > 0.0 else None
        self.glow_dn, self.glow_sigma2 = float(glow_dn), float(glow_sigma2)
        self.land: Any = None  # edge.sim.land.Land, set after construction (needs the pixel scale)

    def sea_hit(self, origin: np.ndarray, dirs: np.ndarray) -> np.ndarray:
        """Ray parameter t of the first sea hit along origin + t * dirs; inf where the ray sees sky."""
        w = origin - self.centre
        a = np.einsum("...i,...i->...", dirs, dirs)
        b = dirs @ w  # half the linear coefficient
        # |w|^2 - R_e^2 without cancellation: the camera is h above the sphere (plus |x| along X).
        c = origin[0] ** 2 + origin[2] ** 2 + self.height_m * (2.0 * self.radius_m + self.height_m)
        disc = b * b - a * c
        with np.errstate(invalid="ignore", divide="ignore"):
            root = np.sqrt(disc)
            t = c / (-b + root)  # the near root, in the stable form
        return np.where((disc >= 0.0) & (b < 0.0), t, np.inf)

    def surface_y_m(self, x_m: np.ndarray | float, z_m: np.ndarray | float) -> np.ndarray:
        """World Y of the sea surface below (x, z): the waterline of a ship there."""
        r2 = np.asarray(x_m, dtype=np.float64) ** 2 + np.asarray(z_m, dtype=np.float64) ** 2
        return self.centre[1] - np.sqrt(self.radius_m**2 - r2)

    def sky_dn(self, dirs: np.ndarray) -> np.ndarray:
        """Sky radiance along rays (unit-free directions), fog applied over the hazy layer."""
        horiz = np.hypot(dirs[..., 0], dirs[..., 2])
        elev = np.arctan2(-dirs[..., 1], horiz)
        j = self._sky_clear(elev)
        atm = self.atmosphere
        horizon_path = math.sqrt(2.0 * self.radius_m * atm.fog_top_m)  # tangent path through the layer
        path = np.minimum(atm.fog_top_m / np.maximum(np.sin(elev), 1e-9), horizon_path)
        t = transmission(path, atm.visibility_m)
        return t * j + (1.0 - t) * atm.airlight_dn

    def _sky_clear(self, elev: np.ndarray) -> np.ndarray:
        s = self.sky
        frac = np.exp(-np.maximum(elev, 0.0) / math.radians(s.falloff_deg))
        return s.zenith_dn + (s.horizon_dn - s.zenith_dn) * frac

    def sea_static_dn(self, origin: np.ndarray, dirs: np.ndarray, t_hit: np.ndarray) -> tuple:
        """Sea radiance without waves at the hit points, and (fog transmission * J) to scale waves by.

        Returns (radiance, wave_scale, points) where points are the world hit points.
        """
        points = origin + t_hit[..., None] * dirs
        norm = np.linalg.norm(dirs, axis=-1)
        up = (points - self.centre) / self.radius_m  # outward normal
        cos_inc = -np.einsum("...i,...i->...", dirs, up) / norm  # cosine of the incidence angle
        j = self._reflected_j(cos_inc)
        trans = transmission(t_hit * norm, self.atmosphere.visibility_m)
        radiance = trans * j + (1.0 - trans) * self.atmosphere.airlight_dn
        if self.glow_dn > 0.0:  # the sun's glitter, averaged over the facets (Cox-Munk)
            ratio = specular_ratio(points, origin, self.sun_dir, self.centre, self.glow_sigma2)
            radiance = radiance + trans * self.glow_dn * ratio
        return radiance, trans * j, points

    def _reflected_j(self, cos_inc: np.ndarray) -> np.ndarray:
        """Sea radiance before haze for the cosine of the incidence angle on the mean surface."""
        cos_eff = np.clip(cos_inc + self.sea.slope_rad, 0.0, 1.0)  # facets tilted toward the viewer
        fresnel = FRESNEL_F0 + (1.0 - FRESNEL_F0) * (1.0 - cos_eff) ** 5
        reflected_elev = np.arcsin(np.clip(cos_inc, 0.0, 1.0)) + 2.0 * self.sea.slope_rad
        return (1.0 - fresnel) * self.sea.water_dn + fresnel * self._sky_clear(reflected_elev)

    def swell_gain(self, origin: np.ndarray, dirs: np.ndarray, t_hit: np.ndarray) -> np.ndarray:
        """Radiance change per unit of each swell component's height phase, (..., m), hazed.

        A swell tilts the facets along its travel direction by its slope a k; the sea's radiance
        changes by dJ/d(tilt) times that (the Fresnel term and the reflected sky both depend on the
        tilt toward the camera), so a swell shows as bands that are strong where the view is steep
        and fade with range, and vanish where it runs across the line of sight.
        """
        swell = self.swell
        assert swell is not None
        points = origin + t_hit[..., None] * dirs
        norm = np.linalg.norm(dirs, axis=-1)
        up = (points - self.centre) / self.radius_m
        trans = transmission(t_hit * norm, self.atmosphere.visibility_m)
        out = np.empty(t_hit.shape + (len(swell.omega),))
        eps = 1e-3
        for i, (kx, kz) in enumerate(swell.k):
            khat = np.array([kx, 0.0, kz]) / math.hypot(kx, kz)
            js = []
            for sign in (1.0, -1.0):
                tilted = up + sign * eps * khat
                tilted /= np.linalg.norm(tilted, axis=-1, keepdims=True)
                js.append(self._reflected_j(-np.einsum("...i,...i->...", dirs, tilted) / norm))
            out[..., i] = trans * (js[0] - js[1]) / (2.0 * eps) * swell.slope[i]
        return out

    def wave_phase(self, points_xz: np.ndarray) -> np.ndarray:
        """Spatial phase k_i . p + phi_i of each component at world (x, z) points: (..., n)."""
        return points_xz @ self.waves.k.T + self.waves.phase

    def wave_time_coeffs(self, t_s: float) -> np.ndarray:
        """[cos(w t), sin(w t)] so that sum a cos(phase - w t) = basis @ coeffs (see render)."""
        wt = self.waves.omega * t_s
        if self.swell is not None:  # the swell's columns follow the waves' (Background.basis)
            ws = self.swell.omega * t_s
            return np.concatenate([np.cos(wt), np.sin(wt), np.cos(ws), np.sin(ws)]).astype(np.float32)
        return np.concatenate([np.cos(wt), np.sin(wt)]).astype(np.float32)
