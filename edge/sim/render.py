"""One camera's radiance image of the scene at one instant, area-integrated over every pixel.

The sky and sea come from the camera's precomputed `Background`. Ships are
re-rendered each frame inside their projected bounding boxes (overlapping
boxes are merged so ships occlude each other correctly):

1. Rays through a half-pixel grid (corners, edge midpoints and centre of every
   pixel) are cast against all ships and the sea sphere; each sample gets a
   label (sky, sea, or the ship face it hits) and a paint region id.
2. A pixel whose nine samples see one face in one paint region is smooth: its
   radiance is Simpson's rule on those nine samples (exact to degree 3).
3. Same face but a paint boundary inside (a window, a container edge), or paint
   finer than 1.5 px: the face's surface coordinates are interpolated to 64
   multi-jittered sub-samples and the paint, box-filtered over each
   sub-sample's 1/8 px cell (ships.paint), is averaged there. No new rays.
4. Otherwise the pixel straddles a silhouette or crease: 64 multi-jittered
   rays are cast and each is shaded as ship, sea or sky. A ship whose smallest
   part is under 1.5 px gets this treatment over its whole box.

The 64-sample pattern resolves straight edges to 1/64 px; it is rotated per
pixel and per frame (`_rotated_samples`) so that what remains is zero-mean
noise (~0.25 DN RMS at edges against a 1024-ray reference), not a bias that
would repeat along an edge. Everything comes from the 3-D geometry alone, in
each view separately. Ship radiance is Lambertian (sun + sky ambient) with
Koschmieder fog over the ray's length. Optional overlays: a bright marker
sphere at each tracked point (for geometry tests, drawn on top), and glints
(Gaussian spots integrated exactly over each pixel with erf).
"""

from __future__ import annotations

import typing
from dataclasses import dataclass

import numpy as np
from scipy.special import erf

from edge.sim.background import Background
from edge.sim.rays import EDGE_SAMPLES, CameraRays, PosedShip, cast, sphere_coverage
from edge.sim.scene import World, transmission
from edge.sim.ships import hash01, paint

SIMPSON = np.outer([1.0, 4.0, 1.0], [1.0, 4.0, 1.0]).ravel() / 36.0
FINE_PX = 1.5  # paint or parts smaller than this (in pixels) are always integrated finely
_M = np.arange(16) / 16 + 1 / 32 - 0.5
MARKER_SAMPLES = np.stack(np.meshgrid(_M, _M), -1).reshape(-1, 2)  # 16 x 16 per pixel


@dataclass(frozen=True)
class Glint:
    """A specular spot in one view: sub-pixel centre, Gaussian width, total radiance (DN * px^2)."""

    u: float
    v: float
    sigma_px: float
    energy: float


class ViewRenderer:
    """Renders one camera: background once, ships, markers and glints per frame."""

    def __init__(self, rays: CameraRays, world: World) -> None:
        self.rays, self.world = rays, world
        self.background = Background(rays, world)
        self.height, self.width = rays.height, rays.width

    # ---- per frame -------------------------------------------------------------------------------
    def render(
        self,
        t_s: float,
        ships: list[PosedShip],
        marker_m: float = 0.0,
        marker_dn: float = 0.0,
        glints: tuple[Glint, ...] = (),
        sea_overlay: np.ndarray | None = None,
    ) -> np.ndarray:
        """Float32 radiance image (DN at unit exposure) at time t_s. `sea_overlay`: radiance added where the
        pixel sees open sea (whitecaps, wakes, sparkles), before the ships are drawn over it."""
        image = self.background.at(t_s)
        if sea_overlay is not None:
            image += sea_overlay * self.background.sea_cover
        for group, box in self._clusters(ships):
            self._render_box(image, group, box, t_s)
        if marker_m > 0.0:
            for ship in ships:
                self._marker(image, ship.to_world(ship.model.tracked_local), marker_m, marker_dn)
        for glint in glints:
            self._glint(image, glint)
        return image

    def _box_of(self, ship: PosedShip) -> tuple[int, int, int, int] | None:
        uv = self.rays.project(ship.to_world(ship.model.corners_local()))
        if not np.all(np.isfinite(uv)):
            return None
        (u0, v0), (u1, v1) = uv.min(axis=0), uv.max(axis=0)
        r0, r1 = int(np.floor(v0)) - 2, int(np.ceil(v1)) + 3
        c0, c1 = int(np.floor(u0)) - 2, int(np.ceil(u1)) + 3
        r0, c0, r1, c1 = max(r0, 0), max(c0, 0), min(r1, self.height), min(c1, self.width)
        return (r0, r1, c0, c1) if r0 < r1 and c0 < c1 else None

    def _clusters(self, ships: list[PosedShip]) -> list[tuple[list[PosedShip], tuple[int, int, int, int]]]:
        groups = [([s], b) for s in ships if (b := self._box_of(s)) is not None]
        merged = True
        while merged:
            merged = False
            for i in range(len(groups)):
                for j in range(i + 1, len(groups)):
                    (gi, bi), (gj, bj) = groups[i], groups[j]
                    if bi[0] < bj[1] and bj[0] < bi[1] and bi[2] < bj[3] and bj[2] < bi[3]:
                        box = (min(bi[0], bj[0]), max(bi[1], bj[1]), min(bi[2], bj[2]), max(bi[3], bj[3]))
                        groups[i] = (gi + gj, box)
                        del groups[j]
                        merged = True
                        break
                if merged:
                    break
        return groups

    def _render_box(
        self, image: np.ndarray, ships: list[PosedShip], box: tuple[int, int, int, int], t_s: float
    ) -> None:
        r0, r1, c0, c1 = box
        h, w = r1 - r0, c1 - c0
        gv = r0 - 0.5 + np.arange(2 * h + 1) / 2.0
        gu = c0 - 0.5 + np.arange(2 * w + 1) / 2.0
        uu, vv = np.meshgrid(gu, gv)
        # typing.cast (`cast` here is the ray caster): numpy's stubs type the norm as floating, not float
        footprint = typing.cast(dict[int, float], {
            s.index: np.linalg.norm(s.origin - self.rays.origin) / self.rays.focal_px for s in ships
        })
        grid = self._sample(self.rays.dirs(uu.ravel(), vv.ravel()), ships, footprint)
        shape = (2 * h + 1, 2 * w + 1)

        def blocks(a: np.ndarray) -> np.ndarray:  # (h, w, 9, ...): the 3x3 samples of every pixel
            a = a.reshape(shape + a.shape[1:])
            view = np.lib.stride_tricks.sliding_window_view(a, (3, 3), axis=(0, 1))[::2, ::2]
            return np.moveaxis(view, (-2, -1), (2, 3)).reshape(h, w, 9, *a.shape[2:])

        lab9, reg9 = blocks(grid.label), blocks(grid.region)
        uniform = np.all(lab9 == lab9[..., 4:5], axis=-1)
        on_ship = uniform & (lab9[..., 4] >= 2)
        edge = ~uniform
        fine_paint = np.zeros((h, w), bool)
        for ship in ships:
            per_px = 1.0 / footprint[ship.index]
            if ship.model.min_part_m() * per_px < FINE_PX:  # parts may slip between grid samples
                b = self._box_of(ship)
                if b is not None:
                    edge[max(b[0] - r0, 0) : b[1] - r0, max(b[2] - c0, 0) : b[3] - c0] = True
            if ship.model.min_feature_m() * per_px < FINE_PX:
                fine_paint |= on_ship & (grid.ship.reshape(shape)[1::2, 1::2] == ship.index)
        paint_edge = on_ship & ~edge & (fine_paint | ~np.all(reg9 == reg9[..., 4:5], axis=-1))
        smooth = on_ship & ~edge & ~paint_edge

        out = image[r0:r1, c0:c1]
        out[smooth] = blocks(grid.radiance)[smooth] @ SIMPSON
        if paint_edge.any():
            prow, pcol = np.nonzero(paint_edge)
            centre = (2 * prow + 1) * shape[1] + 2 * pcol + 1  # grid index of the pixel centres
            offsets = self._rotated_samples(prow + r0, pcol + c0, t_s)
            out[paint_edge] = self._paint_fine(
                blocks(grid.local)[paint_edge], centre, offsets, grid, ships, footprint
            )
        rows, cols = np.nonzero(edge)
        if rows.size:
            waves = out[rows, cols] - self.background.static[rows + r0, cols + c0]  # this frame's sea term
            offsets = self._rotated_samples(rows + r0, cols + c0, t_s)
            u = (cols + c0)[:, None] + offsets[..., 0]
            v = (rows + r0)[:, None] + offsets[..., 1]
            fine = self._sample(self.rays.dirs(u.ravel(), v.ravel()), ships, footprint, cell_px=0.125)
            rad = fine.radiance.reshape(len(rows), -1)
            sea = (fine.label == 1).reshape(len(rows), -1)
            out[rows, cols] = (rad + sea * waves[:, None]).mean(axis=1)

    def _rotated_samples(self, rows: np.ndarray, cols: np.ndarray, t_s: float) -> np.ndarray:
        """EDGE_SAMPLES shifted toroidally by a per-pixel, per-frame, per-camera pseudo-random offset.

        A fixed pattern resolves a straight edge to 1/64 px with the *same* error on every row of that
        edge and every frame at that phase (a coherent bias of up to 1/128 px, visible as a staircase
        of ~0.02 px in a moving ship's centroid). The Cranley-Patterson rotation keeps the pattern
        stratified but makes each pixel's error independent and zero-mean, so it averages out along
        the edge and over time. The offset is a hash of (row, column, time, camera): reproducible.
        """
        keys = (rows, cols, round(t_s * 1e6), round(self.rays.origin[0] * 1000.0))
        shift = np.stack([hash01(*keys, 0), hash01(*keys, 1)], axis=-1)
        return (EDGE_SAMPLES[None, :, :] + 0.5 + shift[:, None, :]) % 1.0 - 0.5

    def _paint_fine(
        self,
        local9: np.ndarray,
        centre: np.ndarray,
        offsets: np.ndarray,
        grid: Samples,
        ships: list[PosedShip],
        footprint: dict[int, float],
    ) -> np.ndarray:
        """Mean paint over 64 sub-samples of pixels that lie on one face (surface coords interpolated).

        `local9` (n, 9, 3): surface coordinates at the pixel's 3x3 grid (offsets -0.5, 0, 0.5 px);
        `offsets` (n, 64, 2): the sub-sample positions in the pixel. Each sub-sample stands for a
        1/8 x 1/8 px cell, whose extent on the surface box-filters the windows (see ships.paint).
        """
        su, sv = 2.0 * (offsets[..., 0] + 0.5), 2.0 * (offsets[..., 1] + 0.5)  # 0..2 in grid steps
        iu, iv = np.minimum(su.astype(int), 1), np.minimum(sv.astype(int), 1)
        fu, fv = (su - iu)[..., None], (sv - iv)[..., None]
        k = iv * 3 + iu
        rows = np.arange(len(local9))[:, None]
        pts = (
            local9[rows, k] * (1 - fu) * (1 - fv)
            + local9[rows, k + 1] * fu * (1 - fv)
            + local9[rows, k + 3] * (1 - fu) * fv
            + local9[rows, k + 4] * fu * fv
        )
        # surface extent of a 1/8 px cell from the pixel's Jacobian (the grid spans 1 px across)
        extent = (np.abs(local9[:, 5] - local9[:, 3]) + np.abs(local9[:, 7] - local9[:, 1])) / 8.0
        extent = np.repeat(extent[:, None, :], pts.shape[1], axis=1)
        albedo = np.empty(pts.shape[:2])
        by_index = {s.index: s for s in ships}
        keys = grid.ship[centre] * 1000 + grid.part[centre]
        for key in np.unique(keys):
            sel = keys == key
            ship, part = by_index[int(key // 1000)], int(key % 1000)
            value, _ = paint(
                ship.model, part, pts[sel].reshape(-1, 3), footprint[ship.index], extent[sel].reshape(-1, 3)
            )
            albedo[sel] = value.reshape(-1, pts.shape[1])
        trans = grid.trans[centre]
        return (
            trans * grid.factor[centre] * albedo.mean(axis=1)
            + (1.0 - trans) * self.world.atmosphere.airlight_dn
        )

    def _sample(
        self, dirs: np.ndarray, ships: list[PosedShip], footprint: dict[int, float], cell_px: float = 0.0
    ) -> Samples:
        """Label, paint region and radiance of individual rays: the nearest of ship, sea and sky.

        `cell_px` > 0: each ray stands for a cell that wide, whose surface extent (taken isotropic,
        `cell_px` pixel footprints) box-filters the paint; 0 samples the paint at points.
        """
        origin, world = self.rays.origin, self.world
        hits = cast(origin, dirs, ships)
        t_sea = world.sea_hit(origin, dirs)
        on_ship = hits.t < t_sea
        n = len(dirs)
        out = Samples(
            label=np.where(on_ship, hits.face_id(), np.where(np.isfinite(t_sea), 1, 0)),
            region=np.zeros(n, np.int64),
            radiance=np.empty(n),
            ship=hits.ship,
            part=hits.part,
            local=hits.local,
            trans=np.ones(n),
            factor=np.zeros(n),
        )
        out.radiance[~on_ship] = self.background.radiance_of(dirs[~on_ship], t_sea[~on_ship])
        idx = np.flatnonzero(on_ship)
        if idx.size == 0:
            return out
        out.trans[idx] = transmission(
            hits.t[idx] * np.linalg.norm(dirs[idx], axis=1), world.atmosphere.visibility_m
        )
        albedo = np.empty(n)
        sun = world.sun
        for ship in ships:
            on = idx[hits.ship[idx] == ship.index]
            if on.size == 0:
                continue
            normal = ship.face_normal_world(hits.plane[on])
            # sky light from the upper hemisphere the face sees (Y down), plus direct sun
            out.factor[on] = sun.ambient_dn * 0.5 * (1.0 - normal[:, 1]) + sun.direct_dn * np.maximum(
                normal @ world.sun_dir, 0.0
            )
            for part in np.unique(hits.part[on]):
                sel = on[hits.part[on] == part]
                extent = None if cell_px == 0.0 else np.full((len(sel), 3), cell_px * footprint[ship.index])
                albedo[sel], out.region[sel] = paint(
                    ship.model, int(part), hits.local[sel], footprint[ship.index], extent
                )
        t = out.trans[idx]
        out.radiance[idx] = t * albedo[idx] * out.factor[idx] + (1.0 - t) * world.atmosphere.airlight_dn
        return out

    # ---- overlays --------------------------------------------------------------------------------
    def _marker(self, image: np.ndarray, centre: np.ndarray, radius_m: float, radiance_dn: float) -> None:
        uv = self.rays.project(centre[None])[0]
        if not np.all(np.isfinite(uv)):
            return
        rel = centre - self.rays.origin
        r_px = radius_m * self.rays.focal_px / rel[2] * 1.5 + 2.0
        r0, r1 = max(int(uv[1] - r_px), 0), min(int(uv[1] + r_px) + 2, self.height)
        c0, c1 = max(int(uv[0] - r_px), 0), min(int(uv[0] + r_px) + 2, self.width)
        if r0 >= r1 or c0 >= c1:
            return
        vv, uu = np.mgrid[r0:r1, c0:c1]
        u = uu.reshape(-1, 1) + MARKER_SAMPLES[None, :, 0]
        v = vv.reshape(-1, 1) + MARKER_SAMPLES[None, :, 1]
        hit = sphere_coverage(self.rays.origin, self.rays.dirs(u.ravel(), v.ravel()), centre, radius_m)
        cover = hit.reshape(uu.shape + (-1,)).mean(axis=-1)
        patch = image[r0:r1, c0:c1]
        patch[:] = patch * (1.0 - cover) + cover * radiance_dn

    def _glint(self, image: np.ndarray, g: Glint) -> None:
        reach = int(np.ceil(4.0 * g.sigma_px)) + 1
        r0, r1 = max(int(g.v) - reach, 0), min(int(g.v) + reach + 1, self.height)
        c0, c1 = max(int(g.u) - reach, 0), min(int(g.u) + reach + 1, self.width)
        if r0 >= r1 or c0 >= c1:
            return
        s = np.sqrt(2.0) * g.sigma_px

        def weights(lo: int, hi: int, centre: float) -> np.ndarray:
            edges = np.arange(lo, hi + 1) - 0.5
            return 0.5 * np.diff(erf((edges - centre) / s))  # exact pixel integral of the Gaussian

        image[r0:r1, c0:c1] += g.energy * np.outer(weights(r0, r1, g.v), weights(c0, c1, g.u))


@dataclass
class Samples:
    """Per-ray results: label (0 sky, 1 sea, >= 2 ship face), paint region, radiance, shading terms."""

    label: np.ndarray
    region: np.ndarray
    radiance: np.ndarray
    ship: np.ndarray  # global ship index, -1 where no ship was hit
    part: np.ndarray
    local: np.ndarray  # (N, 3) ship-local surface coordinates
    trans: np.ndarray  # Koschmieder transmission along the ray (ship samples)
    factor: np.ndarray  # irradiance factor of the face (ship samples)
