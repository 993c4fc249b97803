"""Ships as textured 3-D bodies: a hull plus superstructure, each part a convex polyhedron.

Local ship frame: a forward (bow +), b to starboard, h up from the waterline,
metres. A part is the intersection of half-spaces n . p <= c, which a ray can
be clipped against exactly (render.py), so silhouettes are true 3-D outlines
at any range and either camera sees the same body.

Texture is a function of the *local surface coordinates* only (albedo cells
such as containers or hull plates, window grids, a boot-top band, and smooth
noise), so both views see the same paint and the paint moves with the ship.
Every discontinuity in albedo is a region boundary: `region` returns an id per
sample so the renderer can find pixels that straddle one and integrate them
finely. Smooth noise is prefiltered for the pixel footprint (a Gaussian
approximation of the box filter) so it cannot alias.

`ShipModel.build(kind, length_m)` gives the presets, from a 5 m RIB or a
fishing boat (low, dark hulls: the small craft a VTS cannot see on radar) to
a 200 m container ship; dimensions scale with length. Each has a tracked point
(the bridge, on the centreline at window height) whose world position is the
ground truth. Ship motion in a seaway (roll, pitch, heave) is a sum of slow
sinusoids scaled by `motion`.

Regular superstructure detail (a scenario's `detail: periodic`) is `edge.sim.shipdetail`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from edge.sim.routes import Route

KINDS = ("freighter", "ferry", "coaster", "tug", "boat", "rib", "fishing")
DRAFT_M = 1.0  # hull drawn this far below the waterline (the sea hides it; no gap at the waterline)


@dataclass(frozen=True)
class Style:
    """Paint of one part: base albedo, a cell grid with per-cell variation, windows, a low band."""

    albedo: float
    cell_m: tuple[float, float, float] = (math.inf, math.inf, math.inf)  # along a, h, b
    cell_variation: float = 0.0  # relative albedo spread between cells
    window: tuple[float, float] = (0.0, 0.0)  # window size (along, height) as fraction of a cell
    window_albedo: float = 0.06
    band_top_m: float = -math.inf  # below this height: the band albedo (boot-top)
    band_albedo: float = 0.0
    noise: float = 0.10  # relative amplitude of the smooth noise

    def min_feature_m(self) -> float:
        sizes = [s for s in self.cell_m if math.isfinite(s)]
        if self.window[0] > 0.0:
            sizes += [self.window[0] * self.cell_m[0], self.window[1] * self.cell_m[1]]
        return min(sizes, default=math.inf)


@dataclass(frozen=True)
class Part:
    name: str
    planes: np.ndarray  # (P, 4): unit normal (3) and offset c, inside where n . p <= c
    style: Style


def box(a0: float, a1: float, b0: float, b1: float, h0: float, h1: float) -> np.ndarray:
    """Half-spaces of an axis-aligned box in the local frame."""
    return np.array(
        [[1, 0, 0, a1], [-1, 0, 0, -a0], [0, 1, 0, b1], [0, -1, 0, -b0], [0, 0, 1, h1], [0, 0, -1, -h0]],
        dtype=np.float64,
    )


def hull(length: float, beam: float, freeboard: float, bow_len: float) -> np.ndarray:
    """Box hull with a pointed bow: two planes through the stem meeting the sides `bow_len` aft."""
    half_l, half_b = length / 2.0, beam / 2.0
    planes = list(box(-half_l, half_l, -half_b, half_b, -DRAFT_M, freeboard))
    for side in (1.0, -1.0):
        n = np.array([half_b, side * bow_len, 0.0])
        norm = np.linalg.norm(n)
        planes.append([*(n / norm), half_b * half_l / norm])
    return np.array(planes)


@dataclass(frozen=True)
class ShipModel:
    kind: str
    length_m: float
    beam_m: float
    parts: tuple[Part, ...]
    tracked_local: np.ndarray  # (3,) the bridge point in (a, b, h)
    roll_deg: float  # amplitude of roll in a moderate sea
    seed: int = 0
    extent_local: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        h_top = max(float(p.planes[p.planes[:, 2] > 0.5, 3].max()) for p in self.parts)
        ext = np.array(
            [[-self.length_m / 2, -self.beam_m / 2, -DRAFT_M], [self.length_m / 2, self.beam_m / 2, h_top]]
        )
        object.__setattr__(self, "extent_local", ext)

    @classmethod
    def build(cls, kind: str, length_m: float, seed: int = 0) -> ShipModel:
        if kind not in KINDS:
            raise ValueError(f"unknown ship kind {kind!r}; expected one of {', '.join(KINDS)}")
        if not 5.0 <= length_m <= 400.0:
            raise ValueError(f"ship length must be 5 .. 400 m, got {length_m}")
        return _PRESETS[kind](float(length_m), seed)

    def min_feature_m(self) -> float:
        """Smallest paint detail (window, cell) in metres."""
        return min(p.style.min_feature_m() for p in self.parts)

    def min_part_m(self) -> float:
        """Smallest extent of any part along a local axis: below ~1 px the grid could miss the part."""
        sizes = []
        for part in self.parts:
            for axis in range(3):
                hi = part.planes[part.planes[:, axis] > 0.999, 3]
                lo = part.planes[part.planes[:, axis] < -0.999, 3]
                if hi.size and lo.size:
                    sizes.append(float(hi.min() + lo.min()))
        return min(sizes)

    def corners_local(self) -> np.ndarray:
        """The 8 corners of the local bounding box, plus edge midpoints (for image bounding boxes)."""
        lo, hi = self.extent_local
        grid = np.stack(np.meshgrid(*[np.linspace(lo[i], hi[i], 3) for i in range(3)], indexing="ij"), -1)
        return grid.reshape(-1, 3)


def _freighter(length: float, seed: int) -> ShipModel:
    beam, fb = length / 6.5, 0.045 * length
    top = fb + 0.12 * length
    hull_style = Style(0.22, (12.0, math.inf, math.inf), 0.15, band_top_m=0.8, band_albedo=0.12)
    house = Style(0.78, (2.5, 2.8, 2.5), 0.05, window=(0.55, 0.4), noise=0.05)
    parts = (
        Part("hull", hull(length, beam, fb, 0.16 * length), hull_style),
        Part(
            "containers",
            box(-0.30 * length, 0.36 * length, -0.45 * beam, 0.45 * beam, fb, fb + 0.05 * length),
            Style(0.45, (12.2, 2.6, 2.44), 0.6, noise=0.05),
        ),
        Part("house", box(-0.40 * length, -0.34 * length, -0.32 * beam, 0.32 * beam, fb, top), house),
        Part(
            "bridge",
            box(-0.37 * length, -0.335 * length, -0.5 * beam, 0.5 * beam, top - 3.0, top + 0.5),
            Style(0.8, (1.8, 3.5, 1.8), 0.0, window=(0.7, 0.45), noise=0.03),
        ),
        Part(
            "funnel",
            box(-0.45 * length, -0.41 * length, -0.09 * beam, 0.09 * beam, fb, top + 5.0),
            Style(0.35, (math.inf, 2.0, math.inf), 0.5, noise=0.04),
        ),
    )
    return ShipModel("freighter", length, beam, parts, np.array([-0.35 * length, 0.0, top - 1.5]), 0.6, seed)


def _ferry(length: float, seed: int) -> ShipModel:
    beam, fb = length / 5.5, 0.06 * length
    top = fb + 0.11 * length
    parts = (
        Part(
            "hull",
            hull(length, beam, fb, 0.14 * length),
            Style(0.30, (8.0, math.inf, math.inf), 0.1, band_top_m=1.0, band_albedo=0.10),
        ),
        Part(
            "decks",
            box(-0.42 * length, 0.22 * length, -0.46 * beam, 0.46 * beam, fb, top),
            Style(0.82, (3.0, 2.8, 3.0), 0.04, window=(0.6, 0.4), noise=0.04),
        ),
        Part(
            "bridge",
            box(0.12 * length, 0.24 * length, -0.5 * beam, 0.5 * beam, top, top + 3.0),
            Style(0.85, (1.6, 3.0, 1.6), 0.0, window=(0.75, 0.5), noise=0.03),
        ),
        Part(
            "funnel",
            box(-0.30 * length, -0.22 * length, -0.12 * beam, 0.12 * beam, top, top + 5.0),
            Style(0.5, (math.inf, 1.5, math.inf), 0.7, noise=0.04),
        ),
    )
    return ShipModel("ferry", length, beam, parts, np.array([0.20 * length, 0.0, top + 1.6]), 0.8, seed)


def _coaster(length: float, seed: int) -> ShipModel:
    beam, fb = length / 6.0, 0.05 * length
    top = fb + 0.10 * length
    parts = (
        Part(
            "hull",
            hull(length, beam, fb, 0.15 * length),
            Style(0.18, (6.0, math.inf, math.inf), 0.2, band_top_m=0.6, band_albedo=0.30),
        ),
        Part(
            "hatch",
            box(-0.28 * length, 0.38 * length, -0.40 * beam, 0.40 * beam, fb, fb + 1.5),
            Style(0.40, (7.0, math.inf, math.inf), 0.3, noise=0.06),
        ),
        Part(
            "house",
            box(-0.46 * length, -0.32 * length, -0.42 * beam, 0.42 * beam, fb, top),
            Style(0.75, (2.2, 2.6, 2.2), 0.05, window=(0.6, 0.45), noise=0.05),
        ),
        Part(
            "funnel",
            box(-0.47 * length, -0.42 * length, -0.1 * beam, 0.1 * beam, top, top + 3.0),
            Style(0.3, (math.inf, 1.2, math.inf), 0.5, noise=0.04),
        ),
    )
    return ShipModel("coaster", length, beam, parts, np.array([-0.34 * length, 0.0, top - 1.2]), 1.2, seed)


def _tug(length: float, seed: int) -> ShipModel:
    beam, fb = length / 3.5, 0.08 * length
    top = fb + 0.10 * length
    parts = (
        Part(
            "hull",
            hull(length, beam, fb, 0.25 * length),
            Style(0.25, (3.0, math.inf, math.inf), 0.15, band_top_m=0.4, band_albedo=0.55, noise=0.08),
        ),
        Part(
            "house",
            box(-0.10 * length, 0.25 * length, -0.35 * beam, 0.35 * beam, fb, top),
            Style(0.7, (1.5, 2.2, 1.5), 0.05, window=(0.5, 0.4), noise=0.05),
        ),
        Part(
            "wheelhouse",
            box(0.02 * length, 0.22 * length, -0.30 * beam, 0.30 * beam, top, top + 0.08 * length),
            Style(0.8, (1.0, 0.08 * length, 1.0), 0.0, window=(0.75, 0.55), noise=0.03),
        ),
    )
    return ShipModel(
        "tug", length, beam, parts, np.array([0.20 * length, 0.0, top + 0.05 * length]), 2.5, seed
    )


def _boat(length: float, seed: int) -> ShipModel:
    beam, fb = length / 3.0, 0.10 * length
    top = fb + 0.12 * length
    parts = (
        Part(
            "hull",
            hull(length, beam, fb, 0.3 * length),
            Style(
                0.40, (math.inf, math.inf, math.inf), 0.0, band_top_m=0.25 * fb, band_albedo=0.15, noise=0.04
            ),
        ),
        Part(
            "cabin",
            box(-0.20 * length, 0.15 * length, -0.36 * beam, 0.36 * beam, fb, top),
            Style(0.85, (0.9, 0.12 * length, 0.9), 0.0, window=(0.7, 0.5), noise=0.03),
        ),
    )
    return ShipModel("boat", length, beam, parts, np.array([0.12 * length, 0.0, top - 0.3]), 4.0, seed)


def _rib(length: float, seed: int) -> ShipModel:
    """A rigid inflatable: dark grey tubes barely half a metre above the water, a console amidships."""
    beam, fb = length / 2.6, min(0.07 * length, 0.9)
    console_top = fb + 1.1
    parts = (
        Part(
            "tubes",
            hull(length, beam, fb, 0.25 * length),
            Style(0.10, noise=0.06, band_top_m=0.3 * fb, band_albedo=0.06),
        ),
        Part(
            "console",
            box(-0.12 * length, 0.02 * length, -0.16 * beam, 0.16 * beam, fb, console_top),
            Style(0.55, (math.inf, 0.45, math.inf), 0.3, noise=0.05),
        ),
        Part(
            "crew",
            box(-0.22 * length, -0.14 * length, -0.1 * beam, 0.1 * beam, fb, console_top + 0.5),
            Style(0.25),
        ),
    )
    return ShipModel("rib", length, beam, parts, np.array([-0.05 * length, 0.0, console_top]), 5.0, seed)


def _fishing(length: float, seed: int) -> ShipModel:
    """A small fishing boat: a dark low hull, a wheelhouse forward, a mast."""
    beam, fb = length / 3.2, 0.08 * length
    top = fb + 0.17 * length
    parts = (
        Part("hull", hull(length, beam, fb, 0.22 * length),
             Style(0.09, band_top_m=0.15 * fb, band_albedo=0.25, noise=0.05)),
        Part(
            "wheelhouse",
            box(0.05 * length, 0.28 * length, -0.32 * beam, 0.32 * beam, fb, top),
            Style(0.62, (0.8, 0.09 * length, 0.8), 0.05, window=(0.7, 0.45), noise=0.04),
        ),
        Part("mast", box(0.30 * length, 0.30 * length + 0.2, -0.1, 0.1, fb, fb + 0.45 * length), Style(0.3)),
    )
    return ShipModel("fishing", length, beam, parts, np.array([0.16 * length, 0.0, top - 0.4]), 3.5, seed)


_PRESETS = {
    "freighter": _freighter, "ferry": _ferry, "coaster": _coaster, "tug": _tug, "boat": _boat,
    "rib": _rib, "fishing": _fishing,
}


def hash01(*ints: np.ndarray | int) -> np.ndarray:
    """Deterministic uniform [0, 1) from integer cell indices (splitmix64-style mixing, wrapping)."""
    shape = np.broadcast(*[np.asarray(v) for v in ints]).shape
    h = np.zeros(shape, dtype=np.uint64)
    with np.errstate(over="ignore"):
        for i, value in enumerate(ints):
            v = np.broadcast_to(np.asarray(value).astype(np.int64), shape).astype(np.uint64)
            h ^= (v + np.uint64(0x9E3779B97F4A7C15 + i)) * np.uint64(0xBF58476D1CE4E5B9)
            h ^= h >> np.uint64(31)
        h *= np.uint64(0x94D049BB133111EB)
        h ^= h >> np.uint64(29)
    return (h >> np.uint64(11)).astype(np.float64) / float(1 << 53)


@functools.lru_cache(maxsize=256)
def _noise_field(seed: int, part_index: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Three smooth sinusoids per part: wave vectors (3, 3), phases, wavelengths."""
    rng = np.random.default_rng([seed, part_index, 0x7E47])
    wavelength = np.array([11.0, 5.3, 2.7])
    direction = rng.normal(size=(3, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return direction * (2.0 * np.pi / wavelength)[:, None], rng.uniform(0, 2 * np.pi, 3), wavelength


def _below(x: np.ndarray, edge: float, width: np.ndarray | None) -> np.ndarray:
    """Fraction of the interval [x - w/2, x + w/2] below `edge` (a point test when width is None)."""
    if width is None:
        return (x < edge).astype(np.float64)
    return np.clip((edge - x) / np.maximum(width, 1e-9) + 0.5, 0.0, 1.0)


def _in_windows(x: np.ndarray, period: float, frac: float, width: np.ndarray | None) -> np.ndarray:
    """Fraction of [x - w/2, x + w/2] inside the window band centred in every cell of `period`.

    Exact: the difference of the antiderivative F of the periodic indicator at the interval ends.
    """
    lo_edge, size = (0.5 - frac / 2.0) * period, frac * period

    def antiderivative(y: np.ndarray) -> np.ndarray:
        k = np.floor(y / period)
        return k * size + np.clip(y - k * period - lo_edge, 0.0, size)

    if width is None:
        return (np.abs(x / period - np.floor(x / period) - 0.5) < frac / 2.0).astype(np.float64)
    w = np.maximum(width, 1e-9)
    return (antiderivative(x + w / 2.0) - antiderivative(x - w / 2.0)) / w


def paint(
    model: ShipModel, part_index: int, p: np.ndarray, footprint_m: float, extent: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Albedo and paint-region id at local points p (N, 3) on one part.

    `footprint_m` (one pixel, metres) prefilters the smooth noise. `extent` (N, 3), the size along
    (a, b, h) of the small cell each point stands for, box-filters windows and the band exactly
    (separable closed forms), so sub-pixel windows need few samples; None samples points.
    Region ids are always point tests (they only locate boundaries).
    """
    style = model.parts[part_index].style
    a, b, h = p[:, 0], p[:, 1], p[:, 2]
    ext_a, ext_h = (None, None) if extent is None else (extent[:, 0], extent[:, 2])
    cell = [
        np.floor(q / s) if math.isfinite(s) else np.zeros_like(q)
        for q, s in zip((a, h, b), style.cell_m, strict=True)
    ]
    spread = 2.0 * hash01(model.seed, part_index, *cell) - 1.0
    albedo = style.albedo * (1.0 + style.cell_variation * spread)
    region = cell[0] * 7919.0 + cell[1] * 104729.0 + cell[2] * 1299709.0
    if style.window[0] > 0.0:
        cover = _in_windows(a, style.cell_m[0], style.window[0], ext_a)
        cover *= _in_windows(h, style.cell_m[1], style.window[1], ext_h)
        albedo = cover * style.window_albedo + (1.0 - cover) * albedo
        inside = _in_windows(a, style.cell_m[0], style.window[0], None) * _in_windows(
            h, style.cell_m[1], style.window[1], None
        )
        region = region * 2.0 + inside
    band = _below(h, style.band_top_m, ext_h)
    albedo = band * style.band_albedo + (1.0 - band) * albedo
    region = np.where(h < style.band_top_m, -1.0, region)
    k, phase, wavelength = _noise_field(model.seed, part_index)
    sigma2 = footprint_m**2 / 12.0  # variance of a box of the footprint's width
    amp = style.noise * np.exp(-2.0 * np.pi**2 * sigma2 / wavelength**2)
    albedo = albedo * (1.0 + np.cos(p @ k.T + phase) @ amp)
    return np.clip(albedo, 0.0, 1.0), region.astype(np.int64)


@dataclass
class Ship:
    """A ship model on a track: its pose at any time, and the world position of its tracked point."""

    ship_id: int
    model: ShipModel
    track: Route
    motion: float = 1.0  # scale of roll/pitch/heave; 0 = a flat sea

    def pose(self, t_s: float, surface_y) -> tuple[np.ndarray, np.ndarray]:
        """(origin (3,), basis (3, 3)) with world = origin + local @ basis, local = (a, b, h).

        `surface_y(x, z)` gives the sea surface height (World.surface_y_m).
        """
        x, z, heading = self.track.pose(t_s)
        rng = np.random.default_rng([self.model.seed, self.ship_id, 0x30710])
        periods, phases = rng.uniform(0.8, 1.2, 3), rng.uniform(0.0, 2 * np.pi, 3)
        base_period = 2.0 + 0.6 * math.sqrt(self.model.length_m)  # small craft roll quickly
        wt = 2.0 * np.pi * t_s / (base_period * periods) + phases
        roll = math.radians(self.motion * self.model.roll_deg) * math.sin(wt[0])
        pitch = math.radians(self.motion * self.model.roll_deg * 0.3) * math.sin(wt[1])
        heave = self.motion * 0.02 * self.model.length_m**0.5 * math.sin(wt[2])
        fwd = np.array([math.sin(heading), 0.0, math.cos(heading)])
        stbd = np.array([math.cos(heading), 0.0, -math.sin(heading)])
        up = np.array([0.0, -1.0, 0.0])
        # roll about the fore-aft axis, then pitch about the athwartships axis (small angles, exact rotation)
        stbd, up = stbd * math.cos(roll) + up * math.sin(roll), up * math.cos(roll) - stbd * math.sin(roll)
        fwd, up = fwd * math.cos(pitch) + up * math.sin(pitch), up * math.cos(pitch) - fwd * math.sin(pitch)
        origin = np.array([x, float(surface_y(x, z)) - heave, z])
        return origin, np.stack([fwd, stbd, up])

    def tracked_point(self, t_s: float, surface_y) -> np.ndarray:
        origin, basis = self.pose(t_s, surface_y)
        return origin + self.model.tracked_local @ basis
