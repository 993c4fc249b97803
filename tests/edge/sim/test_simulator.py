"""Simulator behaviours: one-view glints, rig errors, per-camera exposure times, timing faults, live use."""

from __future__ import annotations

import math

import numpy as np
import pytest

from edge.sim.scenario import scenario_from_dict
from edge.sim.simulator import Simulation, live_source


def _sim(sim_tools, ships=None, **extra) -> Simulation:
    ships = ships or [sim_tools.ship(1, "coaster", 80.0, [(-60.0, 1000.0), (140.0, 1040.0)], motion=0.0)]
    data = sim_tools.scenario(sim_tools.calibration("ideal-720"), ships, **extra)
    return Simulation(scenario_from_dict(data, "/virtual/test.yaml"), seed=11)


def _marker(sim: Simulation, camera: int, t_s: float) -> np.ndarray:
    """Intensity centroid of the tracked-point marker (render with minus without)."""
    truth = sim.ships[0].tracked_point(t_s, sim.world.surface_y_m)
    sim.marker_m = 0.0
    plain = sim.radiance(camera, t_s)
    sim.marker_m = 1.4 * truth[2] / sim.rig.focal_px()
    diff = (sim.radiance(camera, t_s) - plain).astype(np.float64)
    vv, uu = np.mgrid[0 : diff.shape[0], 0 : diff.shape[1]]
    return np.array([(diff * uu).sum(), (diff * vv).sum()]) / diff.sum()


def test_right_camera_rotation_error_shifts_the_right_view_only(sim_tools) -> None:
    yaw, pitch = 0.01, 0.02  # degrees: relative yaw is a disparity bias, pitch a vertical misalignment
    base = _sim(sim_tools)
    bent = _sim(sim_tools, rig_error={"right_rotation_deg": [pitch, yaw, 0.0]})
    f = base.rig.focal_px()
    shift_right = _marker(bent, 1, 0.5) - _marker(base, 1, 0.5)
    assert shift_right[0] == pytest.approx(-f * math.radians(yaw), abs=0.02)  # 0.16 px at 720 px
    assert shift_right[1] == pytest.approx(f * math.radians(pitch), abs=0.02)  # axis up: the scene moves down
    assert np.allclose(_marker(bent, 0, 0.5), _marker(base, 0, 0.5), atol=1e-6)


def test_each_view_is_rendered_at_its_own_exposure_time(sim_tools) -> None:
    sim = _sim(sim_tools, trigger={"skew_ns": 100_000_000})  # right exposes 100 ms late
    trig = sim.triggers[2]
    assert trig.t_right_ns - trig.t_left_ns == 100_000_000
    ship = sim.ships[0]
    late = ship.tracked_point(trig.t_right_ns / 1e9, sim.world.surface_y_m)
    on_time = ship.tracked_point(trig.t_ns / 1e9, sim.world.surface_y_m)
    expected = sim.rig.project(late)[1]
    got = _marker(sim, 1, trig.t_right_ns / 1e9)
    assert np.abs(got - expected).max() < 0.05
    assert abs(sim.rig.project(on_time)[1][0] - expected[0]) > 0.2  # the skew is visible


def test_glints_appear_in_one_view_only(sim_tools) -> None:
    sim = _sim(sim_tools, glints={"rate_hz": 30.0, "duration_s": [0.3, 0.4], "max_range_m": 900.0})
    assert {e.camera for e in sim.glints} == {0, 1}
    t_s = 0.5
    live = [e for e in sim.glints if 0.3 < (t_s - e.t0_s) / e.duration_s < 0.7]
    assert len(live) >= 4
    with_glints = [sim.radiance(c, t_s) for c in (0, 1)]
    sim.glints = []
    diff = [with_glints[c] - sim.radiance(c, t_s) for c in (0, 1)]
    checked = {"seen": 0, "unseen": 0}
    for event in live:
        for camera in (0, 1):
            u, v = np.rint(sim.rig.project(np.array(event.point))[camera]).astype(int)
            if not (0 <= u < 720 and 0 <= v < 480):
                continue
            if camera == event.camera:
                assert diff[camera][v, u] > 100.0  # the glint is there in its own view ...
                checked["seen"] += 1
            elif all(
                e.camera != camera or np.abs(sim.rig.project(np.array(e.point))[camera] - (u, v)).max() > 6
                for e in live
            ):
                assert diff[camera][v, u] < 0.01  # ... and not where the same sea point is in the other
                checked["unseen"] += 1
    assert checked["seen"] >= 3 and checked["unseen"] >= 3


def test_jitter_and_drops_follow_the_scenario(sim_tools) -> None:
    sim = _sim(
        sim_tools, duration_s=200.0, trigger={"skew_ns": 1000, "jitter_ns": 250_000, "drop_rate": 0.05}
    )
    trig = [t for t in sim.triggers]
    left = np.array([t.t_left_ns - t.t_ns for t in trig])
    right = np.array([t.t_right_ns - t.t_ns - 1000 for t in trig])
    assert left.std() == pytest.approx(250_000, rel=0.05) and right.std() == pytest.approx(250_000, rel=0.05)
    assert abs(np.corrcoef(left, right)[0, 1]) < 0.05
    dropped = sum(t.index < 0 for t in trig)
    assert dropped / len(trig) == pytest.approx(1 - 0.95**2, abs=0.02)  # either camera may lose the frame
    assert [t.index for t in sim.pairs] == list(range(len(sim.pairs)))


def test_sea_texture_is_anchored_to_the_world(sim_tools) -> None:
    """Both cameras see the same wave pattern: patches around one sea point correlate."""
    sim = _sim(sim_tools, ships=[], sea={"components": 12, "wave_contrast": 0.3})
    world = sim.world
    z = 150.0
    point = np.array([5.0, world.surface_y_m(5.0, z), z])
    uv_l, uv_r = sim.rig.project(point)
    images = [sim.radiance(c, 1.0) for c in (0, 1)]

    def patch(image, uv, du=0):
        r, c = int(round(uv[1])), int(round(uv[0])) + du
        p = image[r - 10 : r + 11, c - 10 : c + 11].astype(float)
        return (p - p.mean()) / p.std()

    same = (patch(images[0], uv_l) * patch(images[1], uv_r)).mean()
    off = (patch(images[0], uv_l) * patch(images[1], uv_r, du=9)).mean()
    assert same > 0.9 and off < same - 0.3


def test_live_source_gives_the_rendered_pairs(sim_tools) -> None:
    sim = _sim(sim_tools, duration_s=0.3)
    source = live_source(sim.scenario, seed=11, pace=False, loop=False)
    pairs = list(source)
    assert len(pairs) == len(sim.pairs) == 3
    left, right = sim.images(1)
    assert np.array_equal(pairs[1].left, left) and np.array_equal(pairs[1].right, right)
