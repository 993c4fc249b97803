"""The real-sea effects (issue 24): their statistics, their stereo geometry, determinism, defaults off.

Small inline scenarios on the ideal 720 px rig (no rotation, no distortion), so that a world point at
depth Z has disparity f B / Z exactly and the checks are about the effects, not the camera model.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.errors import ConfigError
from edge.sim.foam import Whitecaps, WhitecapSpec, wake_patches
from edge.sim.land import Land, LandSpec
from edge.sim.scenario import load_scenario, scenario_from_dict
from edge.sim.scene import KOSCHMIEDER
from edge.sim.seastate import MAX_STATE, whitecap_fraction, wind_mps
from edge.sim.simulator import Simulation
from edge.sim.surface import draw_patches, foam_radiance_dn


def _sim(sim_tools, ships=(), seed: int = 3, **extra) -> Simulation:
    data = sim_tools.scenario(sim_tools.calibration("ideal-720"), ships, **extra)
    return Simulation(scenario_from_dict(data, "/virtual/sea.yaml"), seed=seed)


# ---- sea state -----------------------------------------------------------------------------------
def test_monahan_cover_at_10_mps_and_rising_with_the_douglas_state() -> None:
    assert whitecap_fraction(10.0) == pytest.approx(3.84e-6 * 10**3.41)  # ~1 %: the published curve
    covers = [whitecap_fraction(wind_mps(s)) for s in range(MAX_STATE + 1)]
    assert covers[0] == 0.0 and all(b > a for a, b in zip(covers, covers[1:], strict=False))
    assert 0.004 < covers[4] < 0.012 and 0.02 < covers[6] < 0.06


@given(st.floats(0.0, 30.0), st.floats(0.01, 10.0))
def test_whitecap_cover_grows_with_wind(wind: float, more: float) -> None:
    assert whitecap_fraction(wind + more) >= whitecap_fraction(wind)


# ---- whitecaps -------------------------------------------------------------------------------------
@pytest.mark.parametrize("state", [3, 5])
def test_mean_white_fraction_is_the_sea_states_cover(state: int) -> None:
    caps = Whitecaps(WhitecapSpec(max_range_m=800.0), state, 200.0, 0.4, seed=1)
    mean = np.mean([caps.white_fraction(t) for t in np.arange(20.0, 80.0, 0.7)])
    assert mean == pytest.approx(whitecap_fraction(wind_mps(state)), rel=0.12)


def test_whitecap_pixels_grow_with_sea_state(sim_tools) -> None:
    bright = []
    for state in (2, 4, 6):
        sim = _sim(sim_tools, sea_state=state)
        sea = sim.views[0].background.sea_mask
        frac = [np.mean(sim.sea_overlay(0, t)[sea] > 10.0) for t in (5.0, 9.0, 13.0)]
        bright.append(float(np.mean(frac)))
    assert bright[0] < bright[1] < bright[2]
    assert bright[2] > 5 * bright[0]


def test_a_whitecaps_disparity_is_that_of_its_range(sim_tools) -> None:
    sim = _sim(sim_tools)
    f, baseline = sim.rig.focal_px(), sim.rig.baseline_m
    for x, z in ((-30.0, 300.0), (25.0, 900.0), (5.0, 2000.0)):
        centroids = []
        for camera in (0, 1):
            image = np.zeros((sim.rig.height, sim.rig.width), np.float32)
            one = np.array
            draw_patches(
                image,
                sim.views[camera].rays,
                sim.world,
                one([x]),
                one([z]),
                one([1.5]),
                one([0.6]),
                one([0.3]),
                one([1.0]),
                sim.foam_dn,
            )
            vv, uu = np.mgrid[0 : image.shape[0], 0 : image.shape[1]]
            centroids.append(np.array([(image * uu).sum(), (image * vv).sum()]) / image.sum())
        disparity = centroids[0][0] - centroids[1][0]
        assert disparity == pytest.approx(f * baseline / z, rel=0.01, abs=0.01)
        assert centroids[0][1] == pytest.approx(centroids[1][1], abs=0.01)  # no vertical parallax


def test_foam_contrast_falls_with_range_as_the_haze_transmission(sim_tools) -> None:
    visibility = 4000.0
    hazy = _sim(sim_tools, atmosphere={"visibility_m": visibility})
    clear = _sim(sim_tools, atmosphere={"visibility_m": 1e9})
    for z in (400.0, 1600.0, 3000.0):
        energy = []
        for sim in (hazy, clear):
            image = np.zeros((sim.rig.height, sim.rig.width), np.float32)
            one = np.array
            draw_patches(
                image,
                sim.views[0].rays,
                sim.world,
                one([0.0]),
                one([z]),
                one([1.0]),
                one([1.0]),
                one([0.0]),
                one([1.0]),
                foam_radiance_dn(sim.world, 0.75),
            )
            energy.append(float(image.sum()))
        path_m = math.hypot(z, hazy.world.height_m, hazy.rig.baseline_m / 2)
        assert energy[0] / energy[1] == pytest.approx(math.exp(-KOSCHMIEDER * path_m / visibility), rel=1e-3)


# ---- wakes -------------------------------------------------------------------------------------------
def test_the_wake_lies_behind_the_boat_and_only_when_it_moves(sim_tools) -> None:
    ships = [
        sim_tools.ship(1, "rib", 8.0, [(0.0, 300.0), (0.0, 900.0)], speed_kn=20.0, wake=1.0, motion=0.0),
        sim_tools.ship(2, "rib", 8.0, [(60.0, 400.0), (61.0, 401.0)], speed_kn=0.01, wake=1.0, motion=0.0),
    ]
    sim = _sim(sim_tools, ships=ships)
    t = 10.0
    x, z, _, _, _, cover = wake_patches(sim.ships[0], 1.0, t, sim.world.surface_y_m)
    bow_z = sim.ships[0].track.pose(t)[1] + 4.0
    behind = z < bow_z - 4.0
    assert (
        cover[behind].sum() > 10.0 * cover[~behind].sum()
    )  # the bow wave is the only foam ahead of amidships
    assert np.all(z <= bow_z + 1.0) and np.all(np.abs(x) < 0.4 * (bow_z - z) + 5.0)  # inside the Kelvin wedge
    assert wake_patches(sim.ships[1], 1.0, t, sim.world.surface_y_m)[5].sum() < 1e-3


# ---- glitter -----------------------------------------------------------------------------------------
def _sparkle_bearings(sim: Simulation) -> np.ndarray:
    assert sim.sparkles is not None
    out = [
        np.degrees(np.arctan2(ev["x"], ev["z"]))
        for ev in (sim.sparkles.alive(t) for t in np.arange(1, 4, 0.1))
    ]
    return np.concatenate(out)


def test_glitter_gathers_below_the_sun_and_vanishes_with_the_sun_behind(sim_tools) -> None:
    glitter = {"rate_per_m2_s": 0.02, "max_range_m": 1500.0}
    ahead = _sim(sim_tools, sea_state=3, glitter=glitter, sun={"azimuth_deg": 12.0, "elevation_deg": 15.0})
    bearings = _sparkle_bearings(ahead)
    assert len(bearings) > 200
    assert abs(np.median(bearings) - 12.0) < 3.0
    assert np.mean(np.abs(bearings - 12.0) < 8.0) > 0.6  # a column below the sun, not a uniform carpet
    behind = _sim(sim_tools, sea_state=3, glitter=glitter, sun={"azimuth_deg": 180.0, "elevation_deg": 15.0})
    assert len(_sparkle_bearings(behind)) < 0.01 * len(bearings)


def test_far_sparkles_are_seen_by_both_cameras_near_ones_by_one(sim_tools) -> None:
    sim = _sim(
        sim_tools,
        sea_state=4,
        glitter={"rate_per_m2_s": 0.05, "max_range_m": 4000.0},
        sun={"azimuth_deg": 0.0, "elevation_deg": 10.0},
    )
    assert sim.sparkles is not None
    ev = sim.sparkles.alive(2.0)
    r = np.hypot(ev["x"], ev["z"])
    beam = sim.sparkles.spec.cone_mrad * 1e-3 * r
    seen = [np.exp(-0.5 * ((x0 - ev["aim"]) / beam) ** 2) > 0.5 for x0 in (-4.07, 4.07)]
    both, either = seen[0] & seen[1], seen[0] | seen[1]
    far, near = either & (r > 2500.0), either & (r < 300.0)
    # the beam (6 mrad) is 15-24 m wide at 2.5-4 km, 2 m at 300 m: the 8.14 m baseline splits only near ones
    assert both[far].mean() > 0.6 and both[near].mean() < 0.05


# ---- land ------------------------------------------------------------------------------------------
def test_land_is_the_same_world_surface_from_both_cameras(sim_tools) -> None:
    sim = _sim(sim_tools)
    coast = LandSpec(shore_m=((-9000.0, 9000.0), (9000.0, 9500.0)), height_m=40.0, hills_m=20.0)
    pier = LandSpec(
        shore_m=((100.0, 200.0), (120.0, 200.0), (120.0, 600.0), (100.0, 600.0)), closed=True, height_m=3.0
    )
    land = Land((coast, pier), (), sim.world, 1.0 / sim.rig.focal_px())
    targets = [
        np.array([0.0, sim.world.surface_y_m(0.0, 9250.0) - 10.0, 9250.0]),  # on the coast's face
        np.array([100.0, sim.world.surface_y_m(100.0, 400.0) - 1.5, 400.0]),
    ]  # on the pier's side
    for target in targets:
        for origin in (np.array([-4.07, 0.0, 0.0]), np.array([4.07, 0.0, 0.0])):
            d = (target - origin) / (target - origin)[2]
            t, _ = land.hit(origin, d[None])
            assert t[0] == pytest.approx((target - origin)[2], rel=1e-6)
    # the pier is an island: a ray passing beside or over its far end sees the sea, not land
    over = np.array([110.0, sim.world.surface_y_m(110.0, 800.0), 800.0])
    t, _ = land.hit(np.zeros(3), (over / over[2])[None])
    assert t[0] > sim.world.sea_hit(np.zeros(3), (over / over[2])[None])[0]  # the sea comes first


def test_a_far_coast_has_near_zero_disparity_in_the_images(sim_tools) -> None:
    sim = _sim(
        sim_tools,
        land=[
            {"shore_m": [[-9000, 12000], [9000, 12000]], "height_m": 30, "hills_m": 120, "hill_scale_m": 1500}
        ],
        imaging={"read_noise_dn": 0.0, "shot_noise": False},
    )
    left, right = (sim.radiance(c, 0.0) for c in (0, 1))
    rows = slice(150, 235)  # above the horizon (row ~ 240 - f * dip): the skyline
    profile = [np.abs(np.diff(img[rows], axis=0)).sum(axis=0) for img in (left, right)]
    shifts = range(-6, 7)
    errors = [np.abs(profile[0][10:-10] - np.roll(profile[1], s)[10:-10]).sum() for s in shifts]
    best = list(shifts)[int(np.argmin(errors))]
    assert best == round(sim.rig.focal_px() * sim.rig.baseline_m / 12000.0)  # 0.6 px: 1 or 0


# ---- determinism and defaults ------------------------------------------------------------------------
def test_same_seed_same_bytes_other_seed_other_bytes(sim_tools) -> None:
    extra = {
        "sea_state": 4,
        "glitter": {"rate_per_m2_s": 0.03, "glow_dn": 30},
        "swell": {"height_m": 1.5},
        "land": [{"shore_m": [[-9000, 9000], [9000, 9000]], "height_m": 50}],
    }
    ships = [sim_tools.ship(1, "fishing", 10.0, [(0.0, 600.0), (50.0, 300.0)], speed_kn=12.0, wake=1.0)]
    a, b, c = (_sim(sim_tools, ships=ships, seed=s, **extra) for s in (5, 5, 6))
    frames = [sim.images(4) for sim in (b, a, c)]  # b first: order of construction and use does not matter
    assert (
        frames[0][0].tobytes() == frames[1][0].tobytes() and frames[0][1].tobytes() == frames[1][1].tobytes()
    )
    assert frames[0][0].tobytes() != frames[2][0].tobytes()


def test_existing_scenarios_leave_every_new_effect_off() -> None:
    for name in ("akashi-crossing", "glints", "approach-2048"):
        sim = Simulation(load_scenario(name), seed=0)
        assert sim.whitecaps is None and sim.sparkles is None and not sim.wakes
        assert sim.world.swell is None and sim.world.land is None and sim.world.glow_dn == 0.0
        assert sim.sea_overlay(0, 1.0) is None


@settings(max_examples=10, deadline=None)
@given(st.floats(0.05, 2.0), st.floats(0.0, 0.04))
def test_reversed_ranges_are_config_errors_naming_the_key(lo: float, gap: float) -> None:
    from tests.edge.conftest import calibration, scenario

    data = scenario(calibration("ideal-720"), glitter={"duration_s": [lo + gap + 0.01, lo]})
    with pytest.raises(ConfigError, match="glitter.duration_s"):
        scenario_from_dict(data, "/virtual/bad.yaml")


def test_new_scenarios_load() -> None:
    for name in ("sea-state-4", "sea-state-4-2048", "harbour-mouth", "harbour-mouth-2048", "sea-fog"):
        spec = load_scenario(name).spec
        assert spec.sea_state is not None
    ss4 = load_scenario("sea-state-4").spec
    boat = ss4.ships[0]
    assert boat.length_m == 10 and boat.track.waypoints_m[0][1] > 2000.0 and ss4.glitter.rate_per_m2_s > 0
