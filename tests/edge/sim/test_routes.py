"""Scripted tracks: continuous, at the leg speeds, heading along the motion, turns of the given radius."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.sim.routes import Route

coord = st.floats(-3000.0, 3000.0)
waypoints = st.lists(st.tuples(coord, coord), min_size=2, max_size=5).filter(
    lambda pts: all(math.dist(a, b) > 50.0 for a, b in zip(pts, pts[1:], strict=False))
)


def _samples(track: Route, n: int = 3000):
    t = np.linspace(track.start_s - 5.0, track.end_s + 5.0, n)
    return t, np.array([track.pose(x) for x in t])


@settings(max_examples=30, deadline=None)
@given(waypoints, st.floats(1.0, 15.0), st.floats(0.0, 400.0))
def test_speed_continuity_and_heading(pts, speed_mps, radius) -> None:
    track = Route(pts, [speed_mps], radius)
    t, pose = _samples(track)
    dt = t[1] - t[0]
    step = np.hypot(np.diff(pose[:, 0]), np.diff(pose[:, 1]))
    assert np.all(step <= speed_mps * dt * (1 + 1e-6) + 1e-6)  # never faster than the leg speed
    assert np.median(step) == pytest.approx(speed_mps * dt, rel=1e-3)
    # heading points along the motion: each chord lies between the headings at its ends
    # (except the step that crosses a sharp reversal, where the heading flips)
    turn = np.diff(np.unwrap(pose[:, 2]))
    moving = (step > 0.99 * speed_mps * dt) & (np.abs(turn) < 0.5)
    direction = np.arctan2(np.diff(pose[:, 0]), np.diff(pose[:, 1]))
    mid = pose[:-1, 2] + turn / 2
    error = np.abs(np.angle(np.exp(1j * (direction - mid))))
    assert np.all(error[moving] <= np.abs(turn[moving]) / 2 + 1e-6)
    # the path length equals the legs minus what the fillets cut off (never longer)
    legs = sum(math.dist(a, b) for a, b in zip(pts, pts[1:], strict=False))
    travelled = step[(t[:-1] >= track.start_s) & (t[1:] <= track.end_s)].sum()
    assert travelled <= legs + 1e-6
    assert track.pose(track.start_s)[:2] == pytest.approx(pts[0], abs=1e-6)


def test_turn_has_the_requested_radius_and_ends_on_the_next_leg() -> None:
    track = Route([(0.0, 0.0), (0.0, 1000.0), (1000.0, 1000.0)], [5.0], 200.0)
    arc = next(s for s in track.segments if s.turn != 0.0)
    assert 1.0 / arc.turn == pytest.approx(200.0)  # a right turn (heading increases toward +X)
    mid = track.pose(arc.t0_s + arc.duration_s / 2)
    centre = (200.0, 800.0)
    assert math.dist(mid[:2], centre) == pytest.approx(200.0, abs=1e-6)
    end = track.pose(arc.t0_s + arc.duration_s)
    assert end == pytest.approx((200.0, 1000.0, math.pi / 2), abs=1e-6)
    left_turn = Route([(0.0, 0.0), (0.0, 1000.0), (-1000.0, 1000.0)], [5.0], 200.0)
    assert next(s for s in left_turn.segments if s.turn != 0.0).turn == pytest.approx(-1 / 200.0)


def test_hold_stops_and_turns_on_the_spot() -> None:
    track = Route(
        [(0.0, 0.0), (0.0, 100.0), (100.0, 100.0)], [10.0, 5.0], 50.0, start_s=2.0, holds_s=[0, 8, 0]
    )
    assert track.pose(12.0)[:2] == pytest.approx((0.0, 100.0))  # arrived at t = 2 + 10
    assert track.pose(16.0) == pytest.approx((0.0, 100.0, math.pi / 4))  # half way through the turn
    assert track.pose(20.0 + 10.0) == pytest.approx((50.0, 100.0, math.pi / 2))  # 10 s at 5 m/s
    assert track.pose(0.0) == pytest.approx((0.0, -20.0, 0.0))  # before the start: on the first leg


@pytest.mark.parametrize(
    "args",
    [([(0, 0)], [1.0]), ([(0, 0), (0, 0)], [1.0]), ([(0, 0), (1, 1)], [0.0]), ([(0, 0), (5, 5)], [1.0, 2.0])],
)
def test_bad_tracks(args) -> None:
    with pytest.raises(ValueError):
        Route(*args, 10.0)
