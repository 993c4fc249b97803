"""The world (sphere sea, Koschmieder fog, sky, Fresnel sea) and the sensor model, on known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from edge.sim.imaging import ImagingSpec, expose
from edge.sim.scene import (
    Atmosphere,
    Sea,
    Sky,
    Sun,
    World,
    effective_radius_m,
    horizon_dip_rad,
    transmission,
)


def _world(**atm) -> World:
    return World(25.0, Atmosphere(**atm), Sky(), Sea(), Sun())


def _dirs(depression_rad: np.ndarray, azimuth_rad: float = 0.3) -> np.ndarray:
    d = np.stack(
        [
            np.full_like(depression_rad, math.sin(azimuth_rad)),
            np.tan(depression_rad) * np.ones_like(depression_rad),
            np.full_like(depression_rad, math.cos(azimuth_rad)),
        ],
        -1,
    )
    return d / d[:, 2:3]


def test_sea_hits_lie_on_the_sphere_and_the_horizon_is_the_tangent() -> None:
    world = _world()
    origin = np.array([-4.07, 0.0, 0.0])
    dip = horizon_dip_rad(25.0)
    dep = np.array([dip * 1.0001, dip * 1.5, 0.01, 0.2, 0.7])
    dirs = _dirs(dep)
    t = world.sea_hit(origin, dirs)
    pts = origin + t[:, None] * dirs
    assert np.allclose(np.linalg.norm(pts - world.centre, axis=1), world.radius_m, rtol=0, atol=1e-4)
    assert np.all(np.isinf(world.sea_hit(origin, _dirs(np.array([dip * 0.9999, 0.0, -0.1])))))
    # near range: the flat-sea answer h / tan(depression)
    assert t[-1] * np.linalg.norm(dirs[-1, [0, 2]]) == pytest.approx(25.0 / math.tan(0.7), rel=1e-4)
    # the waterline far out drops by d^2 / (2 R_e)
    assert world.surface_y_m(0.0, 5000.0) - 25.0 == pytest.approx(
        5000.0**2 / (2 * effective_radius_m(0.13)), rel=1e-5
    )


def test_koschmieder_visibility_is_the_two_percent_contrast_range() -> None:
    assert float(transmission(3000.0, 3000.0)) == pytest.approx(0.02, rel=0.01)
    world = _world(visibility_m=2000.0)
    origin = np.zeros(3)
    dirs = _dirs(np.array([0.02]))
    t = world.sea_hit(origin, dirs)
    rad, scale, _ = world.sea_static_dn(origin, dirs, t)
    clear = World(25.0, Atmosphere(visibility_m=1e12), Sky(), Sea(), Sun())
    rad_clear, _, _ = clear.sea_static_dn(origin, dirs, t)
    d = t[0] * np.linalg.norm(dirs[0])
    tr = math.exp(-3.912 * d / 2000.0)
    assert rad[0] == pytest.approx(tr * rad_clear[0] + (1 - tr) * 190.0)  # I = t J + (1 - t) A
    assert scale[0] == pytest.approx(tr * rad_clear[0])


def test_sea_brightens_toward_the_horizon_and_fog_washes_out_the_sky() -> None:
    world = _world(visibility_m=1e12)
    origin = np.zeros(3)
    dirs = _dirs(np.geomspace(horizon_dip_rad(25.0) * 1.01, 0.4, 30)[::-1])  # from near to far
    rad, _, _ = world.sea_static_dn(origin, dirs, world.sea_hit(origin, dirs))
    assert np.all(np.diff(rad) > 0.0)
    foggy = _world(visibility_m=500.0)
    up = _dirs(-np.radians([0.5, 5.0, 30.0]))
    assert foggy.sky_dn(up)[0] == pytest.approx(190.0, abs=0.5)  # a low sky ray crosses km of fog
    assert world.sky_dn(up)[2] < world.sky_dn(up)[0]  # clear sky darkens toward the zenith


def test_noise_has_the_stated_variance_and_is_independent() -> None:
    spec = ImagingSpec(psf_sigma_px=0.0, read_noise_dn=2.0, electrons_per_dn=4.0)
    radiance = np.full((400, 400), 100.0, np.float32)
    a = expose(radiance, spec, False, np.random.default_rng(1)).astype(float)
    b = expose(radiance, spec, False, np.random.default_rng(2)).astype(float)
    expected = math.sqrt(2.0**2 + 100.0 / 4.0 + 1 / 12)  # read + shot + rounding
    assert a.std() == pytest.approx(expected, rel=0.03)
    assert a.mean() == pytest.approx(100.0, abs=0.05)
    assert abs(np.corrcoef(a.ravel(), b.ravel())[0, 1]) < 0.02


def test_gain_offset_psf_and_clipping() -> None:
    spec = ImagingSpec(
        psf_sigma_px=1.0, read_noise_dn=0.0, shot_noise=False, right_gain=1.1, right_offset_dn=-5
    )
    radiance = np.zeros((64, 64), np.float32)
    radiance[20:44, 20:44] = 100.0
    radiance[2, 2] = 5000.0  # a glint saturates
    left, right = expose(radiance, spec, False, None), expose(radiance, spec, True, None)
    assert left[32, 32] == 100 and right[32, 32] == 105  # 1.1 * 100 - 5
    assert left[2, 2] == 255 and left.dtype == np.uint8
    # the blurred step: pixel 20 lies 0.5 px inside the edge at 19.5, Phi(0.5) = 0.69 of the way up
    assert left[32, 20] == pytest.approx(69.1, abs=1.0) and left[32, 19] == pytest.approx(30.9, abs=1.0)
    assert left[10:54, 10:54].astype(float).sum() == pytest.approx(57600.0, rel=0.002)  # the PSF keeps energy


def test_sharp_optics_keep_a_one_pixel_feature_one_pixel() -> None:
    """psf_sigma_px 0 (issue 16's sharp optics, no anti-aliasing filter): no blur at all, so a
    one-pixel feature stays one pixel and its value is exposed exactly."""
    from edge.sim.imaging import ImagingSpec, expose

    radiance = np.full((9, 9), 40.0, np.float32)
    radiance[4, 4] = 200.0
    spec = ImagingSpec(psf_sigma_px=0.0, read_noise_dn=0.0, shot_noise=False)
    image = expose(radiance, spec, right=False, rng=np.random.default_rng(0))
    assert image[4, 4] == 200 and np.count_nonzero(image != 40) == 1
    blurred = expose(radiance, ImagingSpec(read_noise_dn=0.0, shot_noise=False), right=False, rng=None)
    assert np.count_nonzero(blurred != 40) > 1  # the default PSF spreads it


def test_periodic_detail_repaints_on_one_pitch_and_keeps_the_geometry() -> None:
    from edge.sim.shipdetail import periodic_detail
    from edge.sim.ships import ShipModel, paint

    model = ShipModel.build("ferry", 120.0)
    sharp = periodic_detail(model, 2.0)
    assert np.array_equal(sharp.tracked_local, model.tracked_local)
    assert [p.name for p in sharp.parts] == [p.name for p in model.parts] + ["railing"]
    decks = [p.name for p in sharp.parts].index("decks")
    h = 1.4 + 2.8 * 4  # the middle of a row of windows (cells 2.8 m high)
    a = np.linspace(-20.0, 0.0, 4001)
    pts = np.stack([a, np.zeros_like(a), np.full_like(a, h)], -1)
    albedo, _ = paint(sharp, decks, pts, footprint_m=0.01)
    shifted, _ = paint(sharp, decks, pts + [2.0, 0.0, 0.0], footprint_m=0.01)
    assert albedo.max() - albedo.min() > 0.5  # dark glass against white
    assert np.mean(np.abs(albedo - shifted)) < 0.02  # the same every 2 m (only the faint noise differs)
