"""A scenario in motion: trigger times, per-camera exposure times, drops, glints, truth, frames.

`Simulation(scenario, seed)` precomputes everything random up front from the
seed (the trigger schedule with jitter and drops, the glint events), so frame
k renders the same bytes whether frames are rendered in order, out of order
or in parallel worker processes. Noise for frame k and camera c comes from a
generator seeded with (seed, k, c).

Each view is rendered at its *own* exposure time (trigger time + skew +
jitter): a moving ship is where it is when that camera exposes, as with real
unsynchronised cameras. Truth is the tracked point at the pair time `t_ns`
(the nominal trigger time), in the world frame of the calibration.

The right camera is rendered with its true rotation, the calibrated one plus
`rig_error.right_rotation_deg`; the recording states the calibrated rig.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import cast

import numpy as np

from drivers.camera.base import FramePair
from drivers.camera.virtual import VirtualSource
from edge.sim.foam import Whitecaps, wake_patches
from edge.sim.glitter import Sparkles, glitter_sigma2
from edge.sim.imaging import expose
from edge.sim.land import Land
from edge.sim.rays import CameraRays, PosedShip
from edge.sim.render import Glint, ViewRenderer
from edge.sim.scenario import Scenario, build_ships, load_scenario
from edge.sim.scene import World
from edge.sim.surface import draw_patches, foam_radiance_dn


@dataclass(frozen=True)
class Trigger:
    """One trigger of both cameras; `index` is the row in frames.csv, -1 if the pair was dropped."""

    k: int
    index: int
    t_ns: int
    seq_left: int
    seq_right: int
    t_left_ns: int
    t_right_ns: int


@dataclass(frozen=True)
class GlintEvent:
    camera: int  # 0 left, 1 right: a glint is seen by one camera only
    t0_s: float
    duration_s: float
    ship: int  # index into the ship list, or -1 for the open sea
    point: tuple[float, float, float]  # world (sea) or ship-local (a, b, h) position


class Simulation:
    """Renders the frames of one scenario for one seed."""

    def __init__(self, scenario: Scenario, seed: int = 0, marker_m: float = 0.0, marker_dn: float = 4000.0):
        self.scenario, self.seed = scenario, int(seed)
        self.marker_m, self.marker_dn = marker_m, marker_dn
        spec = scenario.spec
        self.rig = scenario.calibration.rig  # the rig the recording states (the right camera may differ)
        sigma2 = glitter_sigma2(spec.glitter, spec.sea_state)
        self.world = World(
            scenario.site.height_m, spec.atmosphere, spec.sky, spec.sea, spec.sun, spec.swell,
            spec.glitter.glow_dn, sigma2,
        )
        if spec.land or spec.foreground:
            self.world.land = Land(spec.land, spec.foreground, self.world, 1.0 / self.rig.focal_px())
        self.ships = build_ships(spec, scenario.path)
        self.triggers = self._schedule()
        self.pairs = [t for t in self.triggers if t.index >= 0]
        self.glints = self._glint_events()
        self._sea_features(sigma2)

    def _sea_features(self, sigma2: float) -> None:
        """Whitecaps, sparkles and wakes: world-space, drawn in each view (None / empty when off)."""
        spec = self.scenario.spec
        half_bearing = math.atan(self.rig.width / 2.0 / self.rig.focal_px()) + math.radians(5.0)
        self.whitecaps: Whitecaps | None = None
        if spec.sea_state is not None or spec.whitecaps.coverage is not None:
            state, wind_from = spec.sea_state or 0, spec.sea.wind_from_deg
            caps = Whitecaps(spec.whitecaps, state, wind_from, half_bearing, self.seed)
            self.whitecaps = caps if caps.coverage > 0.0 else None
        self.sparkles: Sparkles | None = None
        if spec.glitter.rate_per_m2_s > 0.0 and np.any(self.world.sun_dir):
            self.sparkles = Sparkles(
                spec.glitter, self.world, sigma2, half_bearing, self.rig.baseline_m, self.seed
            )
        self.wakes = [(i, s.wake) for i, s in enumerate(spec.ships) if s.wake > 0.0]
        self.foam_dn = foam_radiance_dn(self.world, spec.whitecaps.albedo)

    def sea_overlay(self, camera: int, t_s: float) -> np.ndarray | None:
        """Radiance added to the open sea of one view at t_s (whitecaps, wakes, sparkles); None if none."""
        if self.whitecaps is None and self.sparkles is None and not self.wakes:
            return None
        rays = self.views[camera].rays
        image = np.zeros((rays.height, rays.width), np.float32)
        patches = [self.whitecaps.patches(t_s)] if self.whitecaps is not None else []
        patches += [wake_patches(self.ships[i], w, t_s, self.world.surface_y_m) for i, w in self.wakes]
        if patches:
            x, z, half_a, half_b, heading, cover = (np.concatenate(v) for v in zip(*patches, strict=True))
            draw_patches(image, rays, self.world, x, z, half_a, half_b, heading, cover, self.foam_dn)
        if self.sparkles is not None:
            self.sparkles.draw(image, rays, t_s)
        return image

    @functools.cached_property
    def views(self) -> tuple[ViewRenderer, ViewRenderer]:
        """The two cameras' renderers, built on first use (ray tables, sky and sea integration)."""
        rig = self.rig
        error = self.scenario.spec.rig_error.right_rotation_deg
        rotation = tuple(a + e for a, e in zip(rig.right.rotation_deg, error, strict=True))
        true_right = dataclasses.replace(rig.right, rotation_deg=rotation)  # type: ignore[type-var]  # a dataclass
        half = rig.baseline_m / 2.0
        return (
            ViewRenderer(CameraRays(rig.left, rig.width, rig.height, -half), self.world),
            ViewRenderer(CameraRays(true_right, rig.width, rig.height, half), self.world),
        )

    # ---- randomness decided up front ------------------------------------------------------------
    def _schedule(self) -> list[Trigger]:
        spec = self.scenario.spec
        n = self.scenario.n_frames
        rng = np.random.default_rng([self.seed, 0x7216])
        jitter = np.rint(rng.normal(0.0, spec.trigger.jitter_ns, (n, 2))).astype(np.int64)
        # cast: numpy's stubs type .any(axis=...) as bool | ndarray
        dropped = cast(np.ndarray, (rng.random((n, 2)) < spec.trigger.drop_rate).any(axis=1))
        out, index = [], 0
        for k in range(n):
            t_ns = round(k * 1e9 / spec.fps)
            row = -1 if dropped[k] else index
            index += row >= 0
            out.append(
                Trigger(
                    k,
                    row,
                    t_ns,
                    k,
                    k,
                    t_ns + int(jitter[k, 0]),
                    t_ns + spec.trigger.skew_ns + int(jitter[k, 1]),
                )
            )
        return out

    def _glint_events(self) -> list[GlintEvent]:
        g = self.scenario.spec.glints
        duration = self.scenario.n_frames / self.scenario.spec.fps
        rng = np.random.default_rng([self.seed, 0x611])
        half_fov = math.atan(self.rig.width / 2.0 / self.rig.focal_px())
        events = []
        for _ in range(rng.poisson(g.rate_hz * duration)):
            camera, t0 = int(rng.integers(2)), float(rng.uniform(-g.duration_s[1], duration))
            life = float(rng.uniform(*g.duration_s))
            if self.ships and rng.random() < g.near_ship:
                ship = int(rng.integers(len(self.ships)))
                model = self.ships[ship].model
                a = rng.uniform(-0.4, 0.4) * model.length_m
                h = rng.uniform(0.2, 0.8) * model.extent_local[1, 2]
                events.append(GlintEvent(camera, t0, life, ship, (a, 0.0, h)))
            else:
                r = math.sqrt(rng.uniform(150.0**2, g.max_range_m**2))  # uniform over the sea area
                bearing = rng.uniform(-half_fov, half_fov)
                x, z = r * math.sin(bearing), r * math.cos(bearing)
                events.append(GlintEvent(camera, t0, life, -1, (x, float(self.world.surface_y_m(x, z)), z)))
        return events

    # ---- rendering ------------------------------------------------------------------------------
    @property
    def n_frames(self) -> int:
        return len(self.triggers)

    def posed_ships(self, t_s: float) -> list[PosedShip]:
        return [PosedShip(i, s.model, *s.pose(t_s, self.world.surface_y_m)) for i, s in enumerate(self.ships)]

    def radiance(self, camera: int, t_s: float) -> np.ndarray:
        """Noise-free float32 radiance of one view at time t_s (markers included if enabled)."""
        view = self.views[camera]
        posed = self.posed_ships(t_s)
        glints = tuple(self._glints_at(camera, t_s, view, posed))
        return view.render(t_s, posed, self.marker_m, self.marker_dn, glints, self.sea_overlay(camera, t_s))

    def _glints_at(self, camera: int, t_s: float, view: ViewRenderer, posed: list[PosedShip]):
        g = self.scenario.spec.glints
        for e in self.glints:
            age = (t_s - e.t0_s) / e.duration_s
            if e.camera != camera or not 0.0 <= age < 1.0:
                continue
            point = np.array(e.point)
            if e.ship >= 0:  # on the hull side that faces this camera
                ship = posed[e.ship]
                side = np.sign((view.rays.origin - ship.origin) @ ship.basis[1]) or 1.0
                beam = ship.model.beam_m / 2.0
                point = ship.to_world(np.array([point[0], side * beam, point[2]]))
            u, v = view.rays.project(point[None])[0]
            if np.isfinite(u) and np.isfinite(v):
                peak = g.peak_dn * math.sin(math.pi * age) ** 2  # flares up and fades
                yield Glint(float(u), float(v), g.sigma_px, peak * 2.0 * math.pi * g.sigma_px**2)

    def images(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """The two 8-bit images of trigger k (rendered whether or not the pair was dropped)."""
        trig = self.triggers[k]
        out = []
        for camera, t_ns in ((0, trig.t_left_ns), (1, trig.t_right_ns)):
            rng = np.random.default_rng([self.seed, k, camera, 0x1A6E])
            out.append(
                expose(self.radiance(camera, t_ns / 1e9), self.scenario.spec.imaging, camera == 1, rng)
            )
        return out[0], out[1]

    def truth(self, trig: Trigger) -> list[tuple[int, np.ndarray]]:
        """(ship_id, world xyz of the tracked point) for every ship at the pair time."""
        t_s = trig.t_ns / 1e9
        return [(s.ship_id, s.tracked_point(t_s, self.world.surface_y_m)) for s in self.ships]

    def pair(self, k: int) -> FramePair | None:
        """Frame pair of trigger k, or None when the scenario drops it: a live camera source."""
        trig = self.triggers[k]
        if trig.index < 0:
            return None
        left, right = self.images(k)
        return FramePair(
            left, right, trig.t_ns, trig.seq_left, trig.seq_right, trig.t_left_ns, trig.t_right_ns
        )


def live_source(
    scenario: Scenario | str, seed: int = 0, pace: bool = True, loop: bool = True
) -> VirtualSource:
    """The simulator as a live camera pair (config `cameras: {kind: virtual, ...}`).

    `scenario` is a loaded Scenario, a name in config/scenarios or a YAML path. With `pace`, pairs come
    at the scenario's frame rate stamped on CLOCK_MONOTONIC; with `loop`, the scenario starts over.
    Frames are rendered on demand, so a slow consumer makes the source skip triggers (counted).
    """
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    sim = Simulation(scenario, seed)
    return VirtualSource(sim.pair, fps=scenario.spec.fps, realtime=pace, n_triggers=sim.n_frames, loop=loop)
