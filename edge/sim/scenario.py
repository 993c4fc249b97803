"""Scenario files (config/scenarios/*.yaml): what the simulator renders, validated like any config.

A scenario names a calibration (a path relative to the scenario file, or the
mapping inline), the site when the calibration has none, the frame rate and
duration, the weather, the sensor, trigger faults, glints and the ships with
their tracks. The dataclasses below are the schema; `edge.config.schema` turns every
mistake into a `ConfigError` naming the file and key (exit 78 from the CLI).

`load_scenario("akashi-crossing")` finds config/scenarios/akashi-crossing.yaml;
anything with a slash or a .yaml suffix is taken as a path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from edge.config.calibration import Calibration, calibration_ref, optional_site
from edge.config.schema import load_dataclass, load_yaml, setting
from edge.core.site import Site
from edge.errors import ConfigError
from edge.sim.foam import WhitecapSpec
from edge.sim.glitter import GlitterSpec
from edge.sim.imaging import ImagingSpec
from edge.sim.land import ForegroundSpec, LandSpec
from edge.sim.routes import KNOT_MPS, Route
from edge.sim.scene import Atmosphere, Sea, Sky, Sun, Swell
from edge.sim.seastate import MAX_STATE
from edge.sim.shipdetail import periodic_detail
from edge.sim.ships import KINDS, ShipModel

SCENARIO_DIR = Path(__file__).resolve().parents[2] / "config" / "scenarios"


def _calibration(value: Any, file: Any, key: str) -> Calibration:
    """A calibration file path (relative to the scenario) or an inline calibration mapping; required."""
    cal = calibration_ref(value, file, key)
    if cal is None:
        raise ConfigError(file, key, "a calibration file path or an inline calibration mapping", value)
    return cal


@dataclass(frozen=True)
class TrackSpec:
    waypoints_m: tuple[tuple[float, float], ...] = setting(
        min_items=2, doc="world (x, z) waypoints in metres: X right along the baseline, Z forward"
    )
    speed_kn: tuple[float, ...] = setting(
        positive=True, min_items=1, doc="speed per leg (one value: every leg)"
    )
    turn_radius_m: float = setting(0.0, min=0.0, doc="turn radius at each waypoint; 0: two ship lengths")
    start_s: float = setting(0.0, doc="when the ship passes the first waypoint (negative: already under way)")
    holds_s: tuple[float, ...] = setting(
        (), min=0.0, doc="stop this long at each waypoint (one per waypoint)"
    )


@dataclass(frozen=True)
class ShipAisSpec:
    """The AIS transponder a ship carries (edge.sim.ais; issue 17)."""

    mmsi: int = setting(min=100_000_000, max=999_999_999, doc="the ship's MMSI (9 digits)")
    ais_class: Literal["A", "B"] = setting("A", doc="class A (type 1 and 5) or B (CS: type 18 and 24)")
    name: str = setting("", pattern="[A-Z0-9 @.,-]{0,20}", doc="ship name in the static data (20 characters)")
    accurate: bool = setting(True, doc="position accuracy flag: 1 = better than 10 m (DGNSS)")
    gnss_sigma_m: float | None = setting(
        None, positive=True, doc="GNSS error per axis, m; null: by the flag (1.5 m accurate, 6 m otherwise)")
    antenna_m: tuple[float, float, float, float] | None = setting(
        None, min=0.0, doc="A/B/C/D: antenna to bow, stern, port, starboard, m; null: on the bridge")
    static_interval_s: float = setting(360.0, positive=True, doc="static data (type 5 / 24) every, s")
    interval_s: float | None = setting(
        None, positive=True, doc="position report interval, s; null: by speed per ITU-R M.1371")


@dataclass(frozen=True)
class ShipSpec:
    id: int = setting(min=1, max=9999, doc="ship id in truth.csv")
    kind: Literal[KINDS] = setting(doc="hull and superstructure preset")  # type: ignore[valid-type]
    length_m: float = setting(min=5.0, max=400.0, doc="length overall, metres")
    track: TrackSpec = setting(doc="scripted track")
    paint_seed: int = setting(0, min=0, doc="varies the paint between ships of one kind")
    motion: float = setting(1.0, min=0.0, max=5.0, doc="roll/pitch/heave scale (0: flat calm)")
    detail: Literal["preset", "periodic"] = setting(
        "preset", doc="superstructure paint: the preset's, or periodic (regular windows, railing)"
    )
    detail_pitch_m: float = setting(2.0, min=0.5, max=10.0, doc="window/railing pitch of detail: periodic")
    ais: ShipAisSpec | None = setting(None, doc="the AIS transponder it carries; null: none (a dark ship)")
    wake: float = setting(0.0, min=0.0, max=2.0, doc="whiteness of its wake (0: none, 1: a planing boat's)")


@dataclass(frozen=True)
class TriggerSpec:
    skew_ns: int = setting(
        0, min=-1_000_000_000, max=1_000_000_000, doc="constant right-minus-left exposure offset, ns"
    )
    jitter_ns: float = setting(
        0.0, min=0.0, max=1e9, doc="RMS random exposure-time jitter of each camera, ns"
    )
    drop_rate: float = setting(0.0, min=0.0, max=0.5, doc="probability that a camera loses a frame")


@dataclass(frozen=True)
class RigErrorSpec:
    right_rotation_deg: tuple[float, float, float] = setting(
        (0.0, 0.0, 0.0),
        min=-5.0,
        max=5.0,
        doc="true minus calibrated right-camera rotation: rx vertical misalignment, ry yaw (disparity bias)",
    )
    heading_deg: float = setting(
        0.0, min=-10.0, max=10.0,
        doc="true minus stated site heading: the AIS positions are on the true one (issue 17's monitor)")


@dataclass(frozen=True)
class GlintSpec:
    rate_hz: float = setting(0.0, min=0.0, max=1000.0, doc="new glints per second, each in one view only")
    near_ship: float = setting(
        0.0, min=0.0, max=1.0, doc="fraction placed on a ship's hull, not the open sea"
    )
    peak_dn: float = setting(600.0, positive=True, doc="peak radiance, DN (saturates at 255)")
    sigma_px: float = setting(0.7, positive=True, max=10.0, doc="spot size (Gaussian sigma), pixels")
    duration_s: tuple[float, float] = setting((0.1, 0.4), positive=True, doc="shortest and longest lifetime")
    max_range_m: float = setting(3000.0, positive=True, doc="open-sea glints lie within this range")


@dataclass(frozen=True, kw_only=True)
class ScenarioSpec:
    description: str = setting("", doc="what the scenario exercises")
    calibration: Calibration = setting(
        load=_calibration,
        accepts="a calibration file path or mapping",
        doc="the rig (path relative to the scenario file, or inline)",
    )
    site: Site | None = setting(
        None,
        load=optional_site,
        accepts="a site mapping or null",
        doc="lat_deg, lon_deg, height_m, heading_deg; overrides the calibration's",
    )
    fps: float = setting(positive=True, max=240.0, doc="frame (trigger) rate")
    duration_s: float = setting(positive=True, max=86_400.0, doc="length of the recording, seconds")
    atmosphere: Atmosphere = setting(default_factory=Atmosphere)
    sky: Sky = setting(default_factory=Sky)
    sea: Sea = setting(default_factory=Sea)
    sun: Sun = setting(default_factory=Sun)
    imaging: ImagingSpec = setting(default_factory=ImagingSpec)
    trigger: TriggerSpec = setting(default_factory=TriggerSpec)
    rig_error: RigErrorSpec = setting(default_factory=RigErrorSpec)
    glints: GlintSpec = setting(default_factory=GlintSpec)
    sea_state: int | None = setting(
        None, min=0, max=MAX_STATE, doc="Douglas sea state 0-6: whitecaps and glitter width (null: none)"
    )
    whitecaps: WhitecapSpec = setting(default_factory=WhitecapSpec, doc="tuning of the sea_state's whitecaps")
    glitter: GlitterSpec = setting(default_factory=GlitterSpec, doc="sun glitter (off by default)")
    swell: Swell = setting(default_factory=Swell, doc="long-wave swell bands (off by default)")
    land: tuple[LandSpec, ...] = setting((), doc="coasts, breakwaters, piers: opaque land on the sea")
    foreground: tuple[ForegroundSpec, ...] = setting((), doc="vegetation, railings, walls near the cameras")
    ships: tuple[ShipSpec, ...] = setting((), doc="the ships and their tracks")


@dataclass(frozen=True)
class Scenario:
    """A validated scenario: its spec, where it came from, the calibration and site to render with."""

    name: str
    path: Path
    spec: ScenarioSpec
    calibration: Calibration  # what the recording states (the rig the pipeline will use)
    site: Site

    @property
    def n_frames(self) -> int:
        return max(1, round(self.spec.duration_s * self.spec.fps))

    @property
    def horizontal_fov_deg(self) -> float:
        rig = self.calibration.rig
        return math.degrees(2.0 * math.atan(rig.width / 2.0 / rig.focal_px()))


def scenario_path(name_or_path: str | Path) -> Path:
    """config/scenarios/NAME.yaml for a bare name, else the path as given."""
    text = str(name_or_path)
    if "/" in text or text.endswith((".yaml", ".yml")):
        return Path(text)
    path = SCENARIO_DIR / f"{text}.yaml"
    if not path.is_file():
        known = ", ".join(sorted(p.stem for p in SCENARIO_DIR.glob("*.yaml"))) or "none"
        raise ConfigError(text, "", f"a scenario name in {SCENARIO_DIR} (one of: {known}) or a YAML path")
    return path


def build_ships(spec: ScenarioSpec, file: Any) -> list:
    """The scenario's ships on their tracks; track geometry errors name the ship's key."""
    from edge.sim.ships import Ship

    ships = []
    for i, s in enumerate(spec.ships):
        key = f"ships[{i}]"
        model = ShipModel.build(s.kind, s.length_m, seed=s.paint_seed * 1000 + s.id)
        if s.detail == "periodic":
            model = periodic_detail(model, s.detail_pitch_m)
        t = s.track
        radius = t.turn_radius_m if t.turn_radius_m > 0.0 else 2.0 * s.length_m
        try:
            speeds = [v * KNOT_MPS for v in t.speed_kn]
            if len(speeds) not in (1, len(t.waypoints_m) - 1):
                raise ValueError(f"give one speed or one per leg ({len(t.waypoints_m) - 1})")
            track = Route(t.waypoints_m, speeds, radius, t.start_s, list(t.holds_s) or None)
        except ValueError as exc:
            raise ConfigError(file, f"{key}.track", f"a valid track ({exc})") from None
        ships.append(Ship(s.id, model, track, s.motion))
    return ships


def scenario_from_dict(data: Any, file: str | Path, name: str | None = None) -> Scenario:
    spec = load_dataclass(ScenarioSpec, data, file)
    ids = [s.id for s in spec.ships]
    for i, ship_id in enumerate(ids):
        if ship_id in ids[:i]:
            raise ConfigError(file, f"ships[{i}].id", "an id no other ship uses", ship_id)
    site = spec.site or spec.calibration.site
    if site is None:
        raise ConfigError(file, "site", "a site (here or in the calibration): the height sets the horizon")
    if not site.height_m > 0.5:
        key = "site.height_m" if spec.site is not None else "calibration"
        raise ConfigError(file, key, "a camera height above the sea of more than 0.5 m", site.height_m)
    if spec.sea.wavelength_min_m > spec.sea.wavelength_max_m:
        raise ConfigError(
            file, "sea.wavelength_min_m", "at most sea.wavelength_max_m", spec.sea.wavelength_min_m
        )
    for key, (lo, hi) in (
        ("glints.duration_s", spec.glints.duration_s),
        ("glitter.duration_s", spec.glitter.duration_s),
        ("glitter.max_range_m", (spec.glitter.min_range_m, spec.glitter.max_range_m)),
        ("whitecaps.life_s", spec.whitecaps.life_s),
        ("whitecaps.max_range_m", (spec.whitecaps.min_range_m, spec.whitecaps.max_range_m)),
    ):
        if lo > hi:
            raise ConfigError(file, key, "[shortest, longest] (a range above min_range_m)", [lo, hi])
    mmsis = [s.ais.mmsi for s in spec.ships if s.ais is not None]
    for i, mmsi in enumerate(mmsis):
        if mmsi in mmsis[:i]:
            raise ConfigError(file, "ships[].ais.mmsi", "an MMSI no other ship uses", mmsi)
    build_ships(spec, file)  # track errors surface at load time, not mid-render
    path = Path(file)
    return Scenario(name or path.stem, path, spec, spec.calibration, site)


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Read and validate a scenario by name (config/scenarios) or path."""
    path = scenario_path(name_or_path)
    return scenario_from_dict(load_yaml(path), path)
