"""Camera rays and exact ray casting against the ships' convex parts.

`CameraRays` holds, for one camera, the world-frame normalised direction
(eq. 3.9/3.10: rotation-compensated, divided by z) of every pixel *corner*,
computed once through the calibration's `pixel_to_normalised`. Any sub-pixel
sample's ray is the bilinear interpolation of its four surrounding corners;
over one pixel the mapping is smooth enough that this differs from calling
the camera model directly by less than 1e-3 px (tests/edge/sim/test_rays.py
measures it for strong distortion), and it keeps rendering independent of
the model's (iterative) inverse.

`cast` clips rays against each part's half-spaces (Kay-Kajiya slabs
generalised to any convex polyhedron): a ray is inside a part between the
last entering plane and the first exiting one (computed as reciprocal ray
parameters, see `_reciprocal_params`). It returns the nearest hit
over all ships, with the face (entering plane) for shading and the local
surface coordinates for texture.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from edge.core.camera import CameraModel
from edge.sim.ships import ShipModel

# Canonical multi-jittered 8x8 pattern (Kensler): 64 samples, one per 1/64 column and row, one per
# 1/8 x 1/8 stratum, so straight edges near either axis are resolved to 1/64 px.
_I, _J = np.meshgrid(np.arange(8), np.arange(8), indexing="ij")
EDGE_SAMPLES = np.stack([(_I + (_J + 0.5) / 8) / 8 - 0.5, (_J + (_I + 0.5) / 8) / 8 - 0.5], -1).reshape(-1, 2)


class CameraRays:
    """World-frame ray directions (x, y, 1) for any (u, v) inside the image, and the camera centre."""

    def __init__(self, camera: CameraModel, width: int, height: int, centre_x_m: float) -> None:
        self.camera, self.width, self.height = camera, int(width), int(height)
        self.origin = np.array([centre_x_m, 0.0, 0.0])
        u = np.arange(self.width + 1, dtype=np.float64) - 0.5
        lut = np.empty((self.height + 1, self.width + 1, 2))
        for r0 in range(0, self.height + 1, 256):  # bounded memory for the Newton inverse
            v = np.arange(r0, min(r0 + 256, self.height + 1), dtype=np.float64) - 0.5
            uu, vv = np.meshgrid(u, v)
            lut[r0 : r0 + len(v)] = camera.pixel_to_normalised(np.stack([uu, vv], -1))
        if not np.all(np.isfinite(lut)):
            raise ValueError("the camera model cannot map every pixel of the image to a ray")
        self.lut = lut
        self.focal_px = float(camera.focal_px())

    def normalised(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(N, 2) normalised directions at pixel coordinates inside [-0.5, W-0.5] x [-0.5, H-0.5]."""
        fu = np.clip(np.asarray(u, np.float64) + 0.5, 0.0, self.width)
        fv = np.clip(np.asarray(v, np.float64) + 0.5, 0.0, self.height)
        i0 = np.minimum(fv.astype(np.int64), self.height - 1)
        j0 = np.minimum(fu.astype(np.int64), self.width - 1)
        wv, wu = (fv - i0)[..., None], (fu - j0)[..., None]
        lut = self.lut
        top = lut[i0, j0] * (1 - wu) + lut[i0, j0 + 1] * wu
        bottom = lut[i0 + 1, j0] * (1 - wu) + lut[i0 + 1, j0 + 1] * wu
        return top * (1 - wv) + bottom * wv

    def dirs(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        xy = self.normalised(u, v)
        return np.concatenate([xy, np.ones(xy.shape[:-1] + (1,))], axis=-1)

    def project(self, points_m: np.ndarray) -> np.ndarray:
        """World points (..., 3) -> pixels (..., 2) through the camera model; NaN behind the camera."""
        rel = np.asarray(points_m, np.float64) - self.origin
        with np.errstate(divide="ignore", invalid="ignore"):
            xy = rel[..., :2] / rel[..., 2:3]
        xy = np.where(rel[..., 2:3] > 0.0, xy, np.nan)
        return self.camera.normalised_to_pixel(xy)


@dataclass
class PosedShip:
    """A ship model at one instant: local = (world - origin) @ basis.T."""

    index: int  # position in the scene's ship list (face ids are offset by it)
    model: ShipModel
    origin: np.ndarray
    basis: np.ndarray

    def __post_init__(self) -> None:
        planes = [p.planes for p in self.model.parts]
        self.normals = np.concatenate([p[:, :3] for p in planes])
        self.offsets = np.concatenate([p[:, 3] for p in planes])
        self.part_bounds = np.cumsum([0] + [len(p) for p in planes])

    def to_local(self, points: np.ndarray) -> np.ndarray:
        return (points - self.origin) @ self.basis.T

    def to_world(self, local: np.ndarray) -> np.ndarray:
        return self.origin + local @ self.basis

    def face_normal_world(self, plane: np.ndarray) -> np.ndarray:
        return self.normals[plane] @ self.basis


FACES_PER_SHIP = 64  # face id = 2 + ship index * FACES_PER_SHIP + plane index; 0 = sky, 1 = sea


@dataclass
class Hits:
    t: np.ndarray  # (N,) ray parameter of the nearest ship hit (inf: none)
    ship: np.ndarray  # (N,) index into the posed-ship list, -1 for none
    part: np.ndarray  # (N,) part index within that ship
    plane: np.ndarray  # (N,) plane index within that ship (the face hit)
    local: np.ndarray  # (N, 3) local surface coordinates of the hit

    def face_id(self) -> np.ndarray:
        return np.where(self.ship >= 0, 2 + self.ship * FACES_PER_SHIP + self.plane, -1)


def _reciprocal_params(o_l: np.ndarray, d_l: np.ndarray, normals: np.ndarray, offsets: np.ndarray):
    """Reciprocal plane parameters of rays o_l + t d_l against half-spaces n . p <= c.

    All rays leave the same camera centre, so num = c - n . o is one number per plane: negative when
    the camera is outside that half-space (the ray must *enter* it), positive when inside (the plane
    can only be an exit). The ray meets the plane at t = num / den with den = n . d; we return
    r = den / num = 1 / t from one matrix product. Entering planes have r > 0 when the ray enters
    ahead of the camera; an exit plane bounds the ray where r > 0. A ray parallel to a plane has r = 0,
    which is the exact limit: it never enters (outside) or is never bounded (inside).
    Returns (r (planes, rays) float32, outside (planes,) bool).
    """
    num = offsets - normals @ o_l
    r = ((normals / num[:, None]).astype(np.float32)) @ d_l.T.astype(np.float32)
    return r, num < 0.0


def _part_hit(r: np.ndarray, outside: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For one convex part: (hit mask, 1/t_in). Inside the part from t_in = 1 / min r_enter to
    t_out = 1 / max r_exit, so the ray hits ahead of the camera iff min r_enter > max(r_exit, 0)."""
    r_in = r[outside].min(axis=0)
    r_out = r[~outside].max(axis=0, initial=0.0)
    return r_in > r_out, r_in


_BOX_NORMALS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
_BOX_MARGIN_M = 0.01  # rays grazing a part's face are never cut by the bounding box


def cast(origin: np.ndarray, dirs: np.ndarray, ships: list[PosedShip]) -> Hits:
    """Nearest hit of rays origin + t * dirs with any part of any ship."""
    n = len(dirs)
    best = Hits(
        np.full(n, np.inf), np.full(n, -1), np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros((n, 3))
    )
    best_r = np.zeros(n, np.float32)  # 1 / t of the nearest hit so far (0: none)
    for ship in ships:
        o_l = ship.to_local(origin)
        d_l = dirs @ ship.basis.T
        lo, hi = ship.model.extent_local
        offsets = np.concatenate([hi, -lo])[[0, 3, 1, 4, 2, 5]] + _BOX_MARGIN_M
        r, outside = _reciprocal_params(o_l, d_l, _BOX_NORMALS, offsets)
        if not outside.any():
            raise ValueError(f"a camera is inside ship {ship.index}'s bounding box")
        idx = np.flatnonzero(_part_hit(r, outside)[0])
        if idx.size == 0:
            continue
        d_near = d_l[idx]
        r, outside = _reciprocal_params(o_l, d_near, ship.normals, ship.offsets)
        for part in range(len(ship.model.parts)):
            s0, s1 = ship.part_bounds[part], ship.part_bounds[part + 1]
            hit, r_in = _part_hit(r[s0:s1], outside[s0:s1])
            hit = np.flatnonzero(hit & (r_in > best_r[idx]))
            if hit.size == 0:
                continue
            rows = idx[hit]
            best_r[rows] = r_in[hit]
            best.t[rows] = 1.0 / r_in[hit].astype(np.float64)
            best.ship[rows] = ship.index
            best.part[rows] = part
            enter_rows = s0 + np.flatnonzero(outside[s0:s1])
            best.plane[rows] = enter_rows[np.argmin(r[enter_rows][:, hit], axis=0)]
            best.local[rows] = o_l + best.t[rows, None] * d_near[hit]
    return best


def sphere_coverage(origin: np.ndarray, dirs: np.ndarray, centre: np.ndarray, radius_m: float) -> np.ndarray:
    """True where the ray passes within `radius_m` of `centre` in front of the camera."""
    w = centre - origin
    dd = np.einsum("ij,ij->i", dirs, dirs)
    tca = dirs @ w / dd
    miss2 = w @ w - tca**2 * dd
    return (tca > 0.0) & (miss2 <= radius_m**2)
