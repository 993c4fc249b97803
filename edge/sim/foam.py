"""White water: whitecaps by sea state and the wakes of moving craft.

Whitecaps (`whitecaps:` with the scenario's `sea_state`): breaking crests
are born at random over the sea (edge.sim.surface's Poisson wedge), flash
white within a fraction of a second and fade as foam over their life. They
are ellipses elongated across the wind. Their birth rate is set so that the
time-averaged white fraction of the sea equals Monahan's cover for the sea
state's wind (edge.sim.seastate), or `coverage` when given: so a state-4 sea
has ~0.8 % of its surface white, a state-6 sea ~4 %.

Wakes (a ship's `wake:` > 0): foam laid along the ship's past track, at a
grid of past instants fixed in absolute time (so a patch stays where it was
laid while the ship moves on): the turbulent stern wash, widening and
fading behind the stern; the two arms of the Kelvin wedge at 19.47 deg to
the track; a bow wave. Whiteness grows with speed (a drifting boat leaves
none).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from edge.config.schema import setting
from edge.sim.seastate import whitecap_fraction, wind_mps
from edge.sim.ships import Ship, hash01
from edge.sim.surface import BlockCache, Wedge

RISE_S = 0.15  # a crest breaks (turns white) this fast
KELVIN_RAD = math.asin(1.0 / 3.0)  # 19.47 deg: the half-angle of a deep-water ship wake


@dataclass(frozen=True)
class WhitecapSpec:
    coverage: float | None = setting(
        None, min=0.0, max=0.5, doc="white fraction of the sea; null: Monahan's for the sea_state's wind"
    )
    size_m: float = setting(2.5, positive=True, max=50.0, doc="median crest length across the wind, m")
    life_s: tuple[float, float] = setting(
        (1.5, 5.0), positive=True, doc="shortest and longest foam decay time"
    )
    albedo: float = setting(0.75, min=0.0, max=1.0, doc="albedo of fresh foam")
    min_range_m: float = setting(40.0, positive=True, doc="whitecaps lie beyond this range, m")
    max_range_m: float = setting(3500.0, positive=True, doc="and within this one, m (beyond: sub-pixel)")
    seed: int = setting(0, min=0, doc="added to the render seed")


def envelope(age_s: np.ndarray, life_s: np.ndarray) -> np.ndarray:
    """Whiteness of a whitecap over its age: a fast break, then exponential fading; 0 outside its life."""
    on = (age_s >= 0.0) & (age_s < 4.0 * life_s)
    return np.where(on, (1.0 - np.exp(-np.maximum(age_s, 0.0) / RISE_S)) * np.exp(-age_s / life_s), 0.0)


def growth(age_s: np.ndarray, life_s: np.ndarray) -> np.ndarray:
    """Linear size of a whitecap's foam relative to its crest: it spreads as it fades."""
    return 0.6 + 0.4 * np.minimum(age_s / life_s, 1.0)


def white_area_time_s(life_s: np.ndarray) -> np.ndarray:
    """Integral over a whitecap's life of its whiteness times its relative area (trapezoid, 400 steps)."""
    life = np.asarray(life_s, np.float64)[:, None]
    age = np.linspace(0.0, 4.0, 401)[None, :] * life
    f = envelope(age, life) * growth(age, life) ** 2
    return np.sum(0.5 * (f[:, 1:] + f[:, :-1]) * np.diff(age, axis=1), axis=1)


class Whitecaps:
    """The whitecap events of one scenario and seed, and the patches alive at any instant."""

    ASPECT = 0.4  # width along the wind over length across it

    def __init__(
        self, spec: WhitecapSpec, sea_state: int, wind_from_deg: float, half_bearing_rad: float, seed: int
    ):
        self.spec, self.seed = spec, seed + spec.seed
        self.coverage = spec.coverage if spec.coverage is not None else whitecap_fraction(wind_mps(sea_state))
        self.wedge = Wedge(spec.min_range_m, spec.max_range_m, half_bearing_rad)
        self.across_rad = math.radians(wind_from_deg + 90.0)
        # expected white area-time of one whitecap: Monte Carlo over the size and life laws (fixed draw)
        probe = self._draw(np.random.default_rng([self.seed, 0xC0FF]), 4000)
        area_time = np.mean(np.pi * probe["half_a"] * probe["half_b"] * white_area_time_s(probe["life"]))
        self.birth_rate_per_m2_s = self.coverage / area_time  # so that the mean white fraction = coverage
        self.cache = BlockCache(self._block)

    def _draw(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        lo, hi = self.spec.life_s
        length = self.spec.size_m * np.exp(0.4 * rng.standard_normal(n))
        return {"half_a": 0.5 * length, "half_b": 0.5 * self.ASPECT * length, "life": rng.uniform(lo, hi, n)}

    def _block(self, b: int) -> dict[str, np.ndarray]:
        rng = np.random.default_rng([self.seed, 0xF0A3, b + (1 << 40)])
        n = int(rng.poisson(self.birth_rate_per_m2_s * self.wedge.area_m2))
        x, z = self.wedge.sample(rng, n)
        out = self._draw(rng, n)
        out.update(x=x, z=z, t0=b + rng.uniform(0.0, 1.0, n), skew=rng.uniform(-0.3, 0.3, n))
        return out

    def patches(self, t_s: float) -> tuple[np.ndarray, ...]:
        """(x, z, half_along, half_across, heading, cover) of the whitecaps alive at t_s."""
        ev = self.cache.alive(t_s, 4.0 * self.spec.life_s[1])
        age = t_s - ev["t0"]
        cover = envelope(age, ev["life"])
        live = cover > 0.0
        grow = growth(age[live], ev["life"][live])
        heading = self.across_rad + ev["skew"][live]
        return (
            ev["x"][live],
            ev["z"][live],
            ev["half_a"][live] * grow,
            ev["half_b"][live] * grow,
            heading,
            cover[live],
        )

    def white_fraction(self, t_s: float) -> float:
        """White area over the wedge's area at t_s (the quantity `coverage` is the mean of), a check."""
        _, _, a, b, _, cover = self.patches(t_s)
        return float(np.sum(np.pi * a * b * cover) / self.wedge.area_m2)


WAKE_STEP_S = 0.25  # foam is laid at this grid of absolute times


def wake_patches(ship: Ship, strength: float, t_s: float, surface_y) -> tuple[np.ndarray, ...]:
    """(x, z, half_along, half_across, heading, cover) of one ship's wake foam at t_s."""
    model = ship.model
    length, beam = model.length_m, model.beam_m
    fade_s = 5.0 + 0.6 * length  # stern wash fades over this time
    steps = np.arange(math.floor(t_s / WAKE_STEP_S), math.floor((t_s - 4.0 * fade_s) / WAKE_STEP_S), -1)
    t_k = steps * WAKE_STEP_S
    age = t_s - t_k
    poses = np.array([ship.track.pose(float(t)) for t in t_k])
    before = np.array([ship.track.pose(float(t) - WAKE_STEP_S) for t in t_k])
    speed = np.hypot(poses[:, 0] - before[:, 0], poses[:, 1] - before[:, 1]) / WAKE_STEP_S
    heading = poses[:, 2]
    fwd = np.stack([np.sin(heading), np.cos(heading)], axis=-1)
    stbd = np.stack([np.cos(heading), -np.sin(heading)], axis=-1)
    stern = poses[:, :2] - fwd * (0.45 * length)
    white = strength * np.clip(speed / 6.0, 0.0, 1.0)
    jitter = 2.0 * hash01(ship.ship_id, steps, 0x3A4E) - 1.0
    # stern wash: a strip centred on the track, widening and fading
    wash_c = stern + stbd * (0.25 * beam * jitter * (1.0 + age / 4.0))[:, None]
    wash_len = np.maximum(speed * WAKE_STEP_S, 0.3 * beam)
    wash_w = 0.5 * beam * (0.8 + 0.35 * age)
    wash_cover = white * np.exp(-age / fade_s) * np.where(age < WAKE_STEP_S, age / WAKE_STEP_S, 1.0)
    # Kelvin arms: foam at the wedge's edges, spreading out at 19.47 deg, fading faster
    spread = speed * age * math.tan(KELVIN_RAD) + 0.5 * beam
    arm_cover = 0.5 * white * np.exp(-age / (0.4 * fade_s))
    xs, zs, ha, hb, hd, cv = [wash_c[:, 0]], [wash_c[:, 1]], [wash_len], [wash_w], [heading], [wash_cover]
    for side in (1.0, -1.0):
        arm = stern + stbd * (side * spread)[:, None]
        xs.append(arm[:, 0])
        zs.append(arm[:, 1])
        ha.append(np.maximum(speed * WAKE_STEP_S * 0.7, 0.3))
        hb.append(np.full(len(age), 0.35 + 0.02 * length))
        hd.append(heading + side * KELVIN_RAD)
        cv.append(arm_cover)
    # bow wave: white water either side of the stem, now
    x_now, z_now, h_now = ship.track.pose(t_s)
    x_ago, z_ago, _ = ship.track.pose(t_s - WAKE_STEP_S)
    v_now = math.hypot(x_now - x_ago, z_now - z_ago) / WAKE_STEP_S
    f_now = np.array([math.sin(h_now), math.cos(h_now)])
    s_now = np.array([math.cos(h_now), -math.sin(h_now)])
    for side in (1.0, -1.0):
        p = np.array([x_now, z_now]) + f_now * (0.4 * length) + s_now * (side * 0.55 * beam)
        xs.append(np.array([p[0]]))
        zs.append(np.array([p[1]]))
        ha.append(np.array([0.12 * length]))
        hb.append(np.array([0.15 * beam]))
        hd.append(np.array([h_now + side * 0.3]))
        cv.append(np.array([strength * min(v_now / 8.0, 1.0) * 0.8]))
    out = tuple(np.concatenate(v) for v in (xs, zs, ha, hb, hd, cv))
    keep = out[5] > 1e-3
    return tuple(v[keep] for v in out)
