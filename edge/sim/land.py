"""Land the cameras see: coasts and breakwaters out on the sea, and clutter in the foreground.

Two kinds of opaque world geometry, both defined in world (x, z) so each view
sees them from its own centre (a far coast has near-zero disparity, a railing
a few metres away a huge one):

- `LandSpec` (`land:` in a scenario): a shore polyline; land lies on the left
  of the walk from vertex to vertex seen on a map (X right, Z up), so a coast
  walked from left to right (as the cameras see it) lies beyond it, and a closed polygon walked
  anticlockwise is an island or a pier. A ray is over land from where it
  crosses the shore inward to where it crosses outward. The land rises from
  the sea as a cliff face to a plateau whose height varies along the shore
  (`height_m` plus `hills_m` of smooth relief over `hill_scale_m`): the ray
  hits the face if it is below that height at the shore, else the plateau
  (a sphere `height` above the sea, so the far coast sinks behind the
  Earth's curvature like the sea does). The relief is a function of where
  the ray crosses the shore, so it makes a hilly skyline for a far coast;
  near land seen from above should be flat (`hills_m: 0`), or its plateau
  warps from ray to ray.
- `ForegroundSpec` (`foreground:`): a vertical curtain along a polyline, from
  below the sea to a top profile: shore vegetation (a bumpy top, dense), a
  railing (posts and rails, see-through between them) or a wall.

Radiance is a Lambertian albedo texture (smooth sinusoids of the surface
coordinates, prefiltered for the pixel footprint like the ships' paint) lit by
the sky and sun, seen through the same Koschmieder haze as the sea.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from edge.config.schema import setting
from edge.sim.scene import transmission
from edge.sim.ships import hash01


@dataclass(frozen=True)
class LandSpec:
    shore_m: tuple[tuple[float, float], ...] = setting(
        min_items=2, doc="world (x, z) shore vertices, m; land on the left of the walk (map view)"
    )
    closed: bool = setting(False, doc="join the last vertex to the first (an island, a pier)")
    height_m: float = setting(20.0, min=0.5, max=3000.0, doc="mean height of the land above the sea, m")
    hills_m: float = setting(0.0, min=0.0, max=3000.0, doc="relief along the shore (peak to mean), m")
    hill_scale_m: float = setting(800.0, positive=True, doc="horizontal scale of the relief, m")
    albedo: float = setting(0.18, min=0.0, max=1.0, doc="mean albedo (dark vegetation ~0.1, concrete ~0.35)")
    seed: int = setting(0, min=0, doc="varies relief and texture")


@dataclass(frozen=True, kw_only=True)
class ForegroundSpec:
    line_m: tuple[tuple[float, float], ...] = setting(
        min_items=2, doc="world (x, z) vertices of the curtain, m"
    )
    kind: Literal["vegetation", "railing", "wall"] = setting("vegetation", doc="what stands there")
    top_m: float = setting(doc="height of its top above the sea (vegetation: of the lowest crowns), m")
    variation_m: float = setting(0.0, min=0.0, doc="vegetation: crowns rise up to this much above top_m")
    scale_m: float = setting(2.0, positive=True, doc="vegetation crown size; railing post spacing, m")
    albedo: float = setting(0.12, min=0.0, max=1.0, doc="mean albedo")
    seed: int = setting(0, min=0, doc="varies the top profile and texture")


CHUNK = 1 << 16
BLOCK_M = 23.0  # land cover patches on a plateau (roofs, fields, stands of trees)
RAIL_THICK_M = 0.06  # railing tube diameter
RAIL_ROWS_M = (0.0, 0.5)  # rails at the top and half a metre below it
RAILING_DEPTH_M = 1.1  # the railing stands this high; below it the quay edge (a wall)


def _segments(vertices: tuple[tuple[float, float], ...], closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """Segment starts (n, 2), vectors (n, 2) of a polyline in world (x, z)."""
    pts = np.asarray(vertices, np.float64)
    if closed:
        pts = np.concatenate([pts, pts[:1]])
    return pts[:-1], np.diff(pts, axis=0)


def _crossings(origin: np.ndarray, dirs: np.ndarray, start: np.ndarray, vec: np.ndarray):
    """Ray parameters t (rays, segs) where rays cross each segment (inf: none), the arc length s of each
    crossing along the polyline, and whether the ray goes inward (from the right of the walk to its left)."""
    dx, dz = dirs[:, 0:1], dirs[:, 2:3]
    ex, ez = vec[None, :, 0], vec[None, :, 1]
    wx, wz = start[None, :, 0] - origin[0], start[None, :, 1] - origin[2]
    den = dx * ez - dz * ex  # cross(d, e)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (wx * ez - wz * ex) / den
        u = (wx * dz - wz * dx) / den
    ok = (den != 0.0) & (t > 0.0) & (u >= 0.0) & (u <= 1.0)
    t = np.where(ok, t, np.inf)
    seg_len = np.hypot(vec[:, 0], vec[:, 1])
    s = np.concatenate([[0.0], np.cumsum(seg_len)[:-1]])[None, :] + np.clip(u, 0.0, 1.0) * seg_len[None, :]
    # map view (x right, z up): the walk e's left is (-ez, ex), and d . left = -cross(d, e)
    inward = den < 0.0  # the ray runs from the walk's right side to its left side: into the land
    return t, s, inward


def _profile(s: np.ndarray, scale_m: float, seed: int, tag: int) -> np.ndarray:
    """Smooth relief in [-1, 1] along arc length s: three sinusoids of seeded phases."""
    rng = np.random.default_rng([seed, tag, 0x1A4D])
    waves = np.array([1.0, 0.43, 0.19])
    phase = rng.uniform(0.0, 2.0 * np.pi, 3)
    out = sum(w * np.sin(2.0 * np.pi * s / (scale_m * w) + p) for w, p in zip(waves, phase, strict=True))
    return np.asarray(out) / waves.sum()


def _texture(p: np.ndarray, q: np.ndarray, footprint_m: np.ndarray, seed: int) -> np.ndarray:
    """Relative albedo variation at surface coordinates (p, q), prefiltered for the pixel footprint."""
    rng = np.random.default_rng([seed, 0x7E7])
    out = np.zeros(np.shape(p))
    for wavelength in (37.0, 11.0, 3.1, 0.9):
        angle, phase = rng.uniform(0.0, np.pi), rng.uniform(0.0, 2.0 * np.pi)
        amp = 0.18 * np.exp(-2.0 * np.pi**2 * footprint_m**2 / 12.0 / wavelength**2)
        out += amp * np.sin(2.0 * np.pi * (p * math.cos(angle) + q * math.sin(angle)) / wavelength + phase)
    return out


class Land:
    """All land of a scenario: which rays it stops, where, and with what radiance."""

    def __init__(
        self,
        land: tuple[LandSpec, ...],
        foreground: tuple[ForegroundSpec, ...],
        world,  # edge.sim.scene.World (the sphere, sun and haze)
        rad_per_px: float,
    ) -> None:
        self.land, self.foreground, self.world = land, foreground, world
        self.rad_per_px = float(rad_per_px)
        self._land_geo = [_segments(spec.shore_m, spec.closed) for spec in land]
        self._fg_geo = [_segments(spec.line_m, False) for spec in foreground]
        sun = world.sun
        sin_el = max(math.sin(math.radians(sun.elevation_deg)), 0.0)
        self.top_light_dn = sun.ambient_dn + sun.direct_dn * sin_el  # a level surface
        self.face_light_dn = 0.5 * sun.ambient_dn + 0.5 * sun.direct_dn * math.cos(
            math.radians(sun.elevation_deg)
        )

    def _height_above_sea(self, origin: np.ndarray, dirs: np.ndarray, t: np.ndarray) -> np.ndarray:
        pts = origin + t[:, None] * dirs
        return np.linalg.norm(pts - self.world.centre, axis=1) - self.world.radius_m

    def _sphere_hit(self, origin: np.ndarray, dirs: np.ndarray, height_m: np.ndarray) -> np.ndarray:
        """Near ray parameter where rays meet the sphere `height_m` above the sea (inf: never)."""
        w = self.world
        r = w.radius_m + height_m
        centre = w.centre
        oc = origin - centre
        a = np.einsum("ij,ij->i", dirs, dirs)
        b = dirs @ oc
        c = oc @ oc - r * r
        disc = b * b - a * c
        with np.errstate(invalid="ignore", divide="ignore"):
            t = c / (-b + np.sqrt(disc))
        return np.where((disc >= 0.0) & (b < 0.0) & (c > 0.0), t, np.inf)

    def hit(self, origin: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(t, radiance) of the nearest land or foreground along each ray (t = inf: none)."""
        dirs = np.asarray(dirs, np.float64).reshape(-1, 3)
        t, radiance = np.empty(len(dirs)), np.empty(len(dirs))
        for start in range(0, len(dirs), CHUNK):  # bounded temporaries (rays x segments)
            t[start : start + CHUNK], radiance[start : start + CHUNK] = self._hit(
                origin, dirs[start : start + CHUNK]
            )
        return t, radiance

    def _hit(self, origin: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = len(dirs)
        best_t, radiance = np.full(n, np.inf), np.zeros(n)
        norm = np.linalg.norm(dirs, axis=1)
        for spec, (start, vec) in zip(self.land, self._land_geo, strict=True):
            t, s, inward = _crossings(origin, dirs, start, vec)
            t_in = np.where(inward, t, np.inf)
            k = np.argmin(t_in, axis=1)
            rows = np.arange(n)
            t_enter, s_enter = t_in[rows, k], s[rows, k]
            t_out = np.where(~inward & (t > t_enter[:, None]), t, np.inf).min(axis=1)
            live = np.isfinite(t_enter)
            if not live.any():
                continue
            idx = np.flatnonzero(live)
            te, se, to = t_enter[idx], s_enter[idx], t_out[idx]
            height = np.maximum(
                spec.height_m + spec.hills_m * _profile(se, spec.hill_scale_m, spec.seed, 1), 0.5
            )
            d = dirs[idx]
            at_shore = self._height_above_sea(origin, d, te)
            face = at_shore <= height
            t_top = self._sphere_hit(origin, d, height)
            top = ~face & (t_top >= te) & (t_top <= to)
            t_hit = np.where(face, te, np.where(top, t_top, np.inf))
            closer = t_hit < best_t[idx]
            if not closer.any():
                continue
            sel = idx[closer]
            dist = t_hit[closer] * norm[sel]
            foot = dist * self.rad_per_px
            hit_xz = origin[[0, 2]] + t_hit[closer, None] * dirs[sel][:, [0, 2]]
            # face: along the shore and up; plateau: world (x, z) with blocks (fields, roofs, trees)
            p = np.where(face[closer], se[closer], hit_xz[:, 0])
            q = np.where(face[closer], at_shore[closer], hit_xz[:, 1])
            cells = [np.floor(hit_xz[:, i] / (BLOCK_M * scale)) for scale in (1.0, 0.31) for i in (0, 1)]
            block = 0.9 * (hash01(spec.seed, *cells[:2]) - 0.5) + 0.5 * (hash01(spec.seed, *cells[2:]) - 0.5)
            on_face = face[closer]
            albedo = spec.albedo * (
                1.0
                + np.where(on_face, 1.0, 0.25) * _texture(p, q, foot, spec.seed)
                + np.where(on_face, 0.0, block)
            )
            light = np.where(face[closer], self.face_light_dn, self.top_light_dn)
            best_t[sel] = t_hit[closer]
            radiance[sel] = self._hazed(albedo * light, dist)
        for fg, (start, vec) in zip(self.foreground, self._fg_geo, strict=True):
            t, s, _ = _crossings(origin, dirs, start, vec)
            k = np.argmin(t, axis=1)
            rows = np.arange(n)
            tc, sc = t[rows, k], s[rows, k]
            live = np.isfinite(tc) & (tc < best_t)
            idx = np.flatnonzero(live)
            if idx.size == 0:
                continue
            h = self._height_above_sea(origin, dirs[idx], tc[idx])
            below = fg.top_m - h  # depth below the top, m
            if fg.kind == "vegetation":
                crown = 0.7 * (0.5 + 0.5 * _profile(sc[idx], fg.scale_m * 4.0, fg.seed, 2))
                crown += 0.3 * np.sqrt(np.abs(np.sin(np.pi * sc[idx] / fg.scale_m)))  # one round crown each
                solid = below + fg.variation_m * crown >= 0.0
            elif fg.kind == "railing":
                post = np.abs((sc[idx] / fg.scale_m + 0.5) % 1.0 - 0.5) * fg.scale_m < RAIL_THICK_M
                rail = np.zeros(idx.size, bool)
                for row in RAIL_ROWS_M:
                    rail |= np.abs(below - row - RAIL_THICK_M / 2) < RAIL_THICK_M / 2
                solid = (below >= 0.0) & ((below > RAILING_DEPTH_M) | post | rail)
            else:
                solid = below >= 0.0
            if not solid.any():
                continue
            sel = idx[solid]
            dist = tc[sel] * norm[sel]
            foot = dist * self.rad_per_px
            albedo = fg.albedo * (1.0 + 2.0 * _texture(sc[sel], h[solid], foot, fg.seed))
            best_t[sel] = tc[sel]
            radiance[sel] = self._hazed(np.clip(albedo, 0.0, 1.0) * self.face_light_dn, dist)
        return best_t, radiance

    def _hazed(self, j: np.ndarray, dist_m: np.ndarray) -> np.ndarray:
        atm = self.world.atmosphere
        t = transmission(dist_m, atm.visibility_m)
        return t * j + (1.0 - t) * atm.airlight_dn
