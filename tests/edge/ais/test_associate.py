"""Association: the gate's geometry, the global nearest neighbour against a greedy one, the
hysteresis that keeps an identity through a close pass, and the dark flag's timing."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.ais.associate import Associator, TrackGeometry, gate_cost, hull_cov
from edge.ais.decode import PositionReport
from edge.ais.targets import Predicted
from edge.measure.groundtrack import measurement_cov

S = 1_000_000_000


def target(
    mmsi: int,
    e: float,
    n: float,
    sigma_m: float = 5.0,
    length_m: float = 30.0,
    beam_m: float = 8.0,
    heading_rad: float = math.pi / 2,
) -> Predicted:
    rep = PositionReport(0, mmsi, "A", 0.0, 0.0, 0.0, 0.0, 0.0, True)
    c = np.array([e, n])
    return Predicted(mmsi, c, c, np.eye(2) * sigma_m**2, heading_rad, length_m, beam_m, rep, 0.0, True)


def track(tid: int, e: float, n: float, sigma_r: float = 5.0, sigma_b: float = 1.0) -> TrackGeometry:
    return TrackGeometry(tid, np.array([e, n]), measurement_cov(math.atan2(e, n), sigma_r, sigma_b))


@given(length=st.floats(5.0, 300.0), beam=st.floats(2.0, 50.0), heading=st.floats(0.0, 2 * math.pi))
@settings(max_examples=40, deadline=None)
def test_hull_cov_is_uniform_spread_along_and_across(length: float, beam: float, heading: float) -> None:
    c = hull_cov(heading, length, beam)
    fwd = np.array([math.sin(heading), math.cos(heading)])
    assert math.isclose(fwd @ c @ fwd, length**2 / 12.0, rel_tol=1e-9)  # var of U(-L/2, L/2)
    assert math.isclose(np.trace(c), (length**2 + beam**2) / 12.0, rel_tol=1e-9)


def test_gate_allows_the_range_sigma_and_half_a_ship_but_not_the_neighbour() -> None:
    # 2 km north: range sigma 60 m (Z^2 growth), bearing sigma 2 m
    far = track(1, 0.0, 2000.0, sigma_r=60.0, sigma_b=2.0)
    nis, _ = gate_cost(far, target(9, 0.0, 2100.0))  # 100 m further in range: 1.7 sigma
    assert nis < 13.8
    nis, _ = gate_cost(far, target(9, 60.0, 2000.0))  # 60 m across the line of sight: no
    assert nis > 13.8
    near = track(1, 0.0, 500.0, sigma_r=4.0, sigma_b=0.5)  # the point 50 m along a 120 m ship
    assert gate_cost(near, target(9, 50.0, 500.0, length_m=120.0, heading_rad=math.pi / 2))[0] < 13.8
    assert gate_cost(near, target(9, 50.0, 500.0, length_m=20.0, heading_rad=math.pi / 2))[0] > 13.8


def test_global_nearest_neighbour_beats_greedy() -> None:
    # track 1 is nearest to A, but A is the only target track 2 can have: GNN gives 1-B, 2-A
    a = Associator(13.8, 0.0, 0.0, 20.0, 0.0)
    tracks = [track(1, 0.0, 500.0, 5.0, 5.0), track(2, 14.0, 500.0, 5.0, 5.0)]
    targets = [target(100, 7.0, 500.0, 3.0, 1.0, 1.0), target(200, -6.0, 500.0, 3.0, 1.0, 1.0)]
    got = a.step(0, tracks, targets, 0, {1, 2})
    assert got[1].mmsi == 200 and got[2].mmsi == 100


def test_hysteresis_keeps_identities_through_a_close_pass() -> None:
    a = Associator(13.8, 6.0, 5.0, 20.0, 0.0)
    ids = set()
    for k in range(120):
        t_ns = k * S
        gap = abs(60.0 - k)  # two ships 1 m/s apart in east, passing each other at k = 60
        e1, e2 = -gap / 2.0, gap / 2.0
        noise = 3.0 * math.sin(k * 1.7)
        tracks = [track(1, e1 + noise, 800.0), track(2, e2 - noise, 800.0)]
        targets = [target(100, e1, 800.0), target(200, e2, 800.0)]
        got = a.step(t_ns, tracks, targets, 0, {1, 2})
        if k > 10:
            ids.add((got[1].mmsi, got[2].mmsi))
    assert ids <= {(100, 200)}  # never swapped (the tracks cross too: e1 < e2 before, e1 > e2 after)
    assert a.switches == 0


def test_dark_after_the_configured_time_and_not_before_the_warm_up() -> None:
    a = Associator(13.8, 6.0, 2.0, 20.0, 30.0)
    flagged = None
    for k in range(60):
        got = a.step(k * S, [track(1, 0.0, 400.0)], [], 0, {1})
        if got[1].dark and flagged is None:
            flagged = k
    assert flagged == 50  # unassociated time counts from the warm-up's end (30 s), the later start
    a = Associator(13.8, 6.0, 2.0, 20.0, 30.0)
    flagged = None
    for k in range(40, 100):
        got = a.step(k * S, [track(1, 0.0, 400.0)], [], 0, {1})
        if got[1].dark and flagged is None:
            flagged = k
    assert flagged == 60  # first T at 40 s + 20 s
    # an associated track is never dark, and the flag waits dark_after_s after the association ends
    a = Associator(13.8, 6.0, 2.0, 20.0, 0.0)
    for k in range(10):
        assert not a.step(k * S, [track(1, 0.0, 400.0)], [target(5, 0.0, 400.0)], 0, {1})[1].dark
    darks = [a.step(k * S, [track(1, 0.0, 400.0)], [], 0, {1})[1].dark for k in range(10, 40)]
    assert darks.index(True) == 21  # last associated at 11 s (2 s to drop it), then 20 s: 31 s
