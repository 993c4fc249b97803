"""Ray tables and ray casting: checked against the camera model and against the geometry itself."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.camera import PinholeCamera, Poly10Camera
from edge.sim.rays import EDGE_SAMPLES, CameraRays, PosedShip, cast, sphere_coverage
from edge.sim.routes import Route
from edge.sim.ships import KINDS, Ship, ShipModel


@pytest.mark.parametrize(
    "camera",
    [
        PinholeCamera(500.0, 501.0, 319.5, 239.5, (-0.3, 0.12, 0.001, -0.001, 0.0), (-2.0, 1.0, 0.5)),
        Poly10Camera(
            319.5, 239.5, (2e-3, 1e-6, 1e-9, 2e-9, 2e-9, 2e-3, 0.0, 1e-9, 2e-9, 2e-9), (1.0, -1.0, 0.3)
        ),
    ],
    ids=["strong-barrel-pinhole", "poly10"],
)
def test_ray_table_matches_the_camera_model(camera) -> None:
    rays = CameraRays(camera, 640, 480, -4.0)
    rng = np.random.default_rng(0)
    uv = rng.uniform([-0.5, -0.5], [639.5, 479.5], (5000, 2))
    direct = camera.pixel_to_normalised(uv)
    table = rays.normalised(uv[:, 0], uv[:, 1])
    err_px = np.abs(table - direct).max() * camera.focal_px()
    assert err_px < 1e-3
    back = rays.project(np.c_[table * 1000.0, np.full(len(uv), 1000.0)] + rays.origin)
    assert np.abs(back - uv).max() < 1e-3  # table ray -> camera model projection -> same pixel


def test_edge_samples_are_one_per_row_and_column_and_stratum() -> None:
    s = (EDGE_SAMPLES + 0.5) * 64
    assert sorted(np.floor(s[:, 0]).astype(int)) == list(range(64))
    assert sorted(np.floor(s[:, 1]).astype(int)) == list(range(64))
    cells = {(int(x // 8), int(y // 8)) for x, y in s}
    assert len(cells) == 64


def _posed(kind: str, heading_deg: float, roll: float) -> PosedShip:
    heading = np.radians(heading_deg)
    track = Route([(0.0, 0.0), (100.0 * np.sin(heading), 100.0 * np.cos(heading))], [1.0], 0.0)
    ship = Ship(1, ShipModel.build(kind, 60.0), track, motion=roll)
    origin, basis = ship.pose(3.3, lambda x, z: 20.0 + 0.0 * x)
    origin = origin + np.array([30.0, 0.0, 400.0])
    return PosedShip(0, ship.model, origin, basis)


@settings(max_examples=20, deadline=None)
@given(st.sampled_from(KINDS), st.floats(0.0, 360.0), st.floats(0.0, 3.0), st.integers(0, 2**31))
def test_cast_hits_the_surface_and_nothing_before_it(kind, heading, roll, seed) -> None:
    ship = _posed(kind, heading, roll)
    origin = np.array([-4.07, 0.0, 0.0])
    rng = np.random.default_rng(seed)
    lo, hi = ship.model.extent_local
    targets = ship.to_world(rng.uniform(lo, hi, (400, 3)))
    dirs = targets - origin
    dirs /= dirs[:, 2:3]
    hits = cast(origin, dirs, [ship])
    hit = np.isfinite(hits.t)
    assert hit.any()
    for part_index, part in enumerate(ship.model.parts):
        n, c = part.planes[:, :3], part.planes[:, 3]
        sel = hit & (hits.part == part_index)
        local = hits.local[sel]
        assert np.allclose(local, ship.to_local(origin + hits.t[sel, None] * dirs[sel]), atol=1e-6)
        assert np.all(np.abs((local @ n.T - c).max(axis=1)) < 1e-3)  # on the part's boundary
        on_plane = np.abs(local @ n.T - c)[np.arange(len(local)), hits.plane[sel] - _first(ship, part_index)]
        assert np.all(on_plane < 1e-3)  # on the reported face
    # just in front of each hit, and everywhere on a missing ray, the ray is outside every part
    for t_scale in np.linspace(0.05, 0.999, 12):
        ts = np.where(hit, hits.t * t_scale, np.linalg.norm(targets - origin, axis=1) * t_scale * 1.2)
        pts = ship.to_local(origin + ts[:, None] * dirs)
        for part in ship.model.parts:
            inside = ((pts @ part.planes[:, :3].T) - part.planes[:, 3] < -1e-6).all(axis=1)
            assert not inside.any()


def _first(ship: PosedShip, part_index: int) -> int:
    return int(ship.part_bounds[part_index])


def test_sphere_coverage() -> None:
    origin = np.zeros(3)
    dirs = np.array([[0.0, 0.0, 1.0], [0.001, 0.0, 1.0], [0.0011, 0.0, 1.0], [0.0, 0.0, -1.0]])
    assert list(sphere_coverage(origin, dirs, np.array([0.0, 0.0, 1000.0]), 1.05)) == [
        True,
        True,
        False,
        False,
    ]


def test_ship_models_have_the_sizes_they_claim() -> None:
    for kind in KINDS:
        for length in (10.0, 60.0, 200.0):
            model = ShipModel.build(kind, length)
            lo, hi = model.extent_local
            assert hi[0] - lo[0] == pytest.approx(length)
            assert hi[1] - lo[1] == pytest.approx(model.beam_m)
            assert model.tracked_local[1] == 0.0 and 0.0 < model.tracked_local[2] < hi[2]
    with pytest.raises(ValueError):
        ShipModel.build("submarine", 50.0)
