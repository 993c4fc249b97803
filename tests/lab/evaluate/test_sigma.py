"""lab.evaluate.sigma: ruling 1's criterion on known answers, ruling 4's hull distance in 3-D."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import lab.evaluate.sigma as es
from edge.sim.ships import DRAFT_M, box
from lab.evaluate.metrics import Ship


def test_criterion_known_answers() -> None:
    sigma = np.full(100, 10.0)
    honest = np.concatenate([np.full(96, 10.0), np.full(4, 40.0)])  # 96 % within 3 sigma
    r = es.criterion(honest, sigma)
    assert r["share_within_3sigma"] == pytest.approx(0.96)
    assert r["rms_e_over_sigma"] == pytest.approx(math.sqrt((96 * 1 + 4 * 16) / 100))  # 1.265
    assert r["verdict"] == "PASS"
    assert es.criterion(np.concatenate([np.full(94, 10.0), np.full(6, 31.0)]), sigma)["verdict"] == "FAIL"
    too_big = es.criterion(np.full(100, 5.0), sigma)  # sigma twice the error: RMS 0.5
    assert too_big["rms_e_over_sigma"] == pytest.approx(0.5) and too_big["verdict"] == "FAIL"
    assert es.criterion(np.full(100, 6.0), sigma)["verdict"] == "PASS"  # 0.6: the edge, inside
    assert es.criterion(np.full(100, 16.0), sigma)["verdict"] == "FAIL"  # 1.6: too small a sigma
    assert es.criterion(np.array([]), np.array([]))["verdict"] == "-"


def test_box_distance_inside_and_outside() -> None:
    size = np.array([10.0, 4.0, 6.0])
    assert es.box_distance_m(np.array([5.0, 1.0, 3.0]), size) == pytest.approx(1.0)  # nearest face b = 0
    assert es.box_distance_m(np.array([13.0, 2.0, 3.0]), size) == pytest.approx(3.0)
    assert es.box_distance_m(np.array([13.0, 8.0, 3.0]), size) == pytest.approx(5.0)  # an edge: 3-4-5


@settings(max_examples=20, deadline=None)
@given(p=st.lists(st.floats(-20, 30), min_size=3, max_size=3))
def test_polyhedron_distance_of_a_box_matches_the_box_formula(p: list) -> None:
    planes = box(0.0, 10.0, 0.0, 4.0, 0.0, 6.0)
    point = np.array(p)
    got = es.polyhedron_distance_m(point[None], planes, iterations=120)[0]
    want = es.box_distance_m(point, np.array([10.0, 4.0, 6.0]))
    inside = bool(np.all((point >= 0) & (point <= (10, 4, 6))))
    assert got == pytest.approx(-want if inside else want, abs=1e-3)


def test_hull_error_of_a_bounding_box_ship() -> None:
    # a 100 m x 20 m ship heading +Z (north of the rig), bridge 10 m above the waterline, 20 m top
    t = np.arange(0, 10) * 10**9
    xyz = np.column_stack([np.zeros(10), -10.0 + np.zeros(10), 1000.0 + 5.0 * np.arange(10)])
    ship = Ship(1, 100.0, 20.0, 0.0, t, xyz, bridge_h_m=10.0, top_h_m=20.0)
    # 5 m in front of the bow at bridge height: 5 m; inside on the centreline: the side, 10 m
    assert es.hull_error_m(ship, 5, 0.0, -10.0, 1025.0 + 50.0 + 5.0) == pytest.approx(5.0)
    assert es.hull_error_m(ship, 5, 0.0, -10.0, 1025.0) == pytest.approx(10.0)
    # 3 m above the highest part
    assert es.hull_error_m(ship, 5, 9.0, -23.0, 1025.0) == pytest.approx(3.0)
    # below the keel at DRAFT_M under the waterline
    assert es.hull_error_m(ship, 5, 9.0, 0.0 + DRAFT_M + 2.0, 1025.0) == pytest.approx(2.0)


def test_a_ray_grazing_the_outline_meets_the_ship_at_it() -> None:
    # a 100 m ferry broadside at 2 km, waterline 25 m below the camera; f = 1000 px
    from edge.sim.rays import PosedShip, cast
    from edge.sim.ships import ShipModel

    f_px, camera = 1000.0, np.zeros(3)
    basis = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # a -> X, b -> Z, h -> up
    posed = [PosedShip(0, ShipModel.build("ferry", 100.0), np.array([0.0, 25.0, 2000.0]), basis)]
    # scan the image column through the ship's middle upwards to its outline, in 0.01 px steps
    rows_px = np.arange(0.0, -400.0, -0.01)
    dirs = np.column_stack([np.zeros_like(rows_px), 25.0 / 2000.0 + rows_px / f_px, np.ones_like(rows_px)])
    hits = cast(camera, dirs, posed)
    top = int(np.flatnonzero(hits.ship == 0).max())  # the last row that still meets the ship
    t_top = hits.t[top]
    on = es.graze_hit_t(camera, dirs[top], posed, 0, f_px)
    assert on is not None and on[0] == pytest.approx(t_top)
    above = es.graze_hit_t(camera, dirs[top] - [0.0, 0.55 / f_px, 0.0], posed, 0, f_px)
    assert above is not None and above[0] * np.linalg.norm(above[1]) == pytest.approx(
        t_top * np.linalg.norm(dirs[top]), rel=0.02)  # the outline's surface, not a far one
    # beyond half a window above the ship's highest point within a window's reach: no surface
    cols = np.arange(-es.GRAZE_PX - 1.0, es.GRAZE_PX + 1.01, 0.1)
    highest = min(rows_px[np.flatnonzero(cast(camera, np.column_stack(
        [np.full_like(rows_px, c / f_px), dirs[:, 1], dirs[:, 2]]), posed).ship == 0)].min() for c in cols)
    clear = np.array([0.0, 25.0 / 2000.0 + (highest - es.GRAZE_PX - 0.3) / f_px, 1.0])
    assert es.graze_hit_t(camera, clear, posed, 0, f_px) is None
    assert es.graze_hit_t(camera, clear + [0.0, 0.6 / f_px, 0.0], posed, 0, f_px) is not None
    assert es.graze_hit_t(camera, dirs[top], posed, 1, f_px) is None  # another ship's outline
