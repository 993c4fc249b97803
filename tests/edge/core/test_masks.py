"""edge.core.masks: polygon checks against constructed answers and OpenCV's point-in-polygon as an
independent peer, the image fill, and the pixel -> sea -> pixel round trip through the rig's projection."""

from __future__ import annotations

import math

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.camera import PinholeCamera, StereoRig
from edge.core.geo import horizon_dip_rad
from edge.core.masks import (
    crossing_edges,
    fill_image_polygon,
    horizon_rows,
    inside_polygon,
    normalised_grid,
    open_sea_share,
    polygon_problem,
    sea_pixel_grid,
    sea_points,
    search_mask,
)

W, H, F, B, HEIGHT = 720, 480, 914.0, 8.14, 25.0


def _star(n: int, seed: int, radius: float = 100.0, convex: bool = False) -> np.ndarray:
    """A simple polygon: one point in each of n equal sectors around a centre, at random radii
    (star-shaped about the centre, every edge within less than half a turn: no two edges meet)."""
    rng = np.random.default_rng(seed)
    angles = 2 * np.pi * (np.arange(n) + rng.uniform(0.0, 0.8, n)) / n
    r = np.full(n, radius) if convex else rng.uniform(0.3, 1.0, n) * radius
    return np.stack([360 + r * np.cos(angles), 240 + r * np.sin(angles)], axis=-1)


@settings(max_examples=60, deadline=None)
@given(st.integers(3, 12), st.integers(0, 10_000))
def test_star_shaped_polygons_are_accepted_and_swapping_two_vertices_makes_them_cross(
    n: int, seed: int
) -> None:
    poly = _star(n, seed)
    assert polygon_problem(poly) is None
    if n >= 4:  # two neighbouring vertices of a convex polygon swapped: it folds over itself
        folded = _star(n, seed, convex=True)
        folded[[1, 2]] = folded[[2, 1]]
        crossing = crossing_edges(folded)
        assert crossing is not None
        index, expected = polygon_problem(folded) or (None, "")
        assert index == crossing[1] and "simple polygon" in expected


def test_a_bowtie_crosses_at_its_diagonals() -> None:
    quad = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    assert crossing_edges(quad) is None
    assert crossing_edges(quad[[0, 2, 1, 3]]) == (0, 2)


def test_problems_name_the_vertex() -> None:
    assert polygon_problem(np.array([[0.0, 0.0], [1.0, 1.0]])) == (1, "at least 3 vertices")
    index, expected = polygon_problem(np.array([[0.0, 0.0], [5.0, 0.0], [5.0, 0.0], [0.0, 5.0]])) or (0, "")
    assert index == 2 and "coincide" in expected
    index, expected = polygon_problem(np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]])) or (0, "")
    assert "area" in expected or "simple" in expected  # collinear: edges 1-2 and 2-0 overlap
    # the fifth vertex's edge (4-0) crosses edge 1-2
    poly = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0], [12.0, 5.0]])
    index, expected = polygon_problem(poly) or (0, "")
    assert index == 3 and "edge 3-4 meets edge 1-2" in expected


@settings(max_examples=40, deadline=None)
@given(st.integers(3, 10), st.integers(0, 10_000))
def test_inside_agrees_with_opencv(n: int, seed: int) -> None:
    poly = _star(n, seed)
    rng = np.random.default_rng(seed + 1)
    pts = rng.uniform([200, 80], [520, 400], (300, 2))
    ours = inside_polygon(pts[:, 0], pts[:, 1], poly)
    contour = poly.astype(np.float32).reshape(-1, 1, 2)
    for (x, y), got in zip(pts, ours, strict=True):
        signed = cv2.pointPolygonTest(contour, (float(x), float(y)), True)
        if abs(signed) > 1e-6:  # on the edge either answer is fine
            assert got == (signed > 0)


@settings(max_examples=30, deadline=None)
@given(st.integers(3, 10), st.integers(0, 10_000))
def test_image_fill_covers_the_pixel_centres_inside_and_none_far_outside(n: int, seed: int) -> None:
    poly = _star(n, seed)
    mask = np.zeros((H, W), bool)
    fill_image_polygon(mask, poly)
    vv, uu = np.mgrid[0:H, 0:W]
    contour = poly.astype(np.float32).reshape(-1, 1, 2)
    inside = inside_polygon(uu.astype(float), vv.astype(float), poly)
    # pixel centres more than a pixel from the outline: the fill and the even-odd test agree
    far = np.array(
        [
            abs(cv2.pointPolygonTest(contour, (float(u), float(v)), True)) > 1.0
            for u, v in zip(uu[::7, ::7].ravel(), vv[::7, ::7].ravel(), strict=True)
        ]
    )
    assert np.array_equal(mask[::7, ::7].ravel()[far], inside[::7, ::7].ravel()[far])


def _rig(
    dist: tuple[float, ...] = (0.0,) * 5, rotation: tuple[float, float, float] = (0.0, 0.0, 0.0)
) -> StereoRig:
    cam = PinholeCamera(F, F, (W - 1) / 2, (H - 1) / 2, dist, rotation)  # type: ignore[arg-type]
    return StereoRig(B, W, H, cam, cam)


@settings(max_examples=30, deadline=None)
@given(st.floats(300.0, 6000.0), st.floats(-15.0, 15.0), st.floats(-0.5, 0.5), st.floats(-1.0, 1.0))
def test_pixel_to_sea_to_pixel_round_trip(
    range_m: float, bearing_deg: float, pitch_deg: float, roll_deg: float
) -> None:
    """A point on the sea (the curved, refracted sea of geo.sea_range_m) projects to a pixel whose ray
    comes back to the same point (within 1e-4 of the range: the sphere's and the parabola's sea
    differ by less) and reprojects to the same pixel within a thousandth of a pixel."""
    rig = _rig((-0.08, 0.02, 0.0005, -0.0003, 0.0), (pitch_deg, 0.0, roll_deg))
    r_e = 6_371_000.0 / (1.0 - 0.13)
    x, z = range_m * math.sin(math.radians(bearing_deg)), range_m * math.cos(math.radians(bearing_deg))
    y = HEIGHT + range_m * range_m / (2.0 * r_e)  # the sea below the tangent plane (Y down)
    uv, _ = rig.project(np.array([x, y, z]))
    if not (0 <= uv[0] < W and 0 <= uv[1] < H):
        return
    back = sea_points(rig.left, -0.5 * B, uv, HEIGHT)
    assert np.hypot(back[0] - x, back[1] - z) < 1e-4 * range_m
    d2 = back[0] ** 2 + back[1] ** 2
    again, _ = rig.project(np.array([back[0], HEIGHT + d2 / (2.0 * r_e), back[1]]))
    assert np.abs(again - uv).max() < 1e-3


def test_interpolated_rays_are_the_lens_model_to_a_thousandth_of_a_pixel() -> None:
    rig = _rig((-0.12, 0.05, 0.001, 0.0005, -0.01), (0.3, 0.1, 0.5))
    grid = normalised_grid(rig.left, W, H)
    uv = np.stack(np.meshgrid(np.arange(W, dtype=float), np.arange(0, H, 5, dtype=float)), axis=-1)
    exact = rig.left.pixel_to_normalised(uv)
    assert np.nanmax(np.abs(grid[::5] - exact)) * F < 1e-2


def test_sea_polygon_masks_the_sea_behind_it_and_never_the_sky() -> None:
    rig = _rig()
    sea = sea_pixel_grid(rig.left, -0.5 * B, W, H, HEIGHT)
    # horizon: the first sea row sits at the dip below the centre row
    dip_px = F * math.tan(horizon_dip_rad(HEIGHT))
    rows = horizon_rows(sea)
    assert np.nanmax(np.abs(rows[W // 2] - ((H - 1) / 2 + dip_px))) <= 1.0
    square = np.array([[-200.0, 1500.0], [200.0, 1500.0], [200.0, 2500.0], [-200.0, 2500.0]])  # X, Z metres
    mask = search_mask(W, H, [], [square], sea)
    uv_near, _ = rig.project(np.array([0.0, HEIGHT, 1600.0]))
    uv_far, _ = rig.project(np.array([0.0, HEIGHT, 3000.0]))
    uv_side, _ = rig.project(np.array([400.0, HEIGHT, 2000.0]))
    assert not mask[int(round(uv_near[1])), int(round(uv_near[0]))]
    assert mask[int(round(uv_far[1])), int(round(uv_far[0]))]
    assert mask[int(round(uv_side[1])), int(round(uv_side[0]))]
    assert mask[: int(rows[W // 2]) - 1].all()  # the sky is never in a sea polygon
    assert 0.0 < open_sea_share(mask, sea) < 1.0
    everything = search_mask(
        W, H, [np.array([[0.0, 0.0], [W - 1.0, 0.0], [W - 1.0, H - 1.0], [0.0, H - 1.0]])], [], None
    )
    assert open_sea_share(everything, sea) == 0.0
