"""shipmotion: the d'' bound holds for ships that keep to speed and acceleration limits; the ladder;
the world velocity from image rates equals the derivative of the triangulated track."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.shipmotion import (
    ACCEL_RUNGS,
    MAX_SHIP_ACCEL_MPS2,
    MAX_SHIP_SPEED_MPS,
    accel_rung,
    disparity_accel_bound,
)

FB = 2600.0 * 8.14  # the 2048 px rig's f L_B, px m


@settings(max_examples=60, deadline=None)
@given(st.floats(300.0, 6000.0), st.floats(-2000.0, 2000.0), st.floats(0.5, 1.0), st.floats(0.0, 2 * math.pi),
       st.floats(-1.0, 1.0))
def test_bound_holds_for_a_turning_ship(z0_m: float, x0_m: float, speed_share: float, heading: float,
                                        turn: float) -> None:
    """A ship on a circle (speed v, centripetal acceleration v^2 / R <= a): the numerical d'' never
    exceeds the bound at the ship's disparity."""
    v = speed_share * MAX_SHIP_SPEED_MPS
    a = turn * MAX_SHIP_ACCEL_MPS2  # signed: the turn's direction
    t = np.linspace(0.0, 20.0, 2001)
    dt = t[1] - t[0]
    omega = a / v  # heading rate of a turn with centripetal acceleration |a|
    psi = heading + omega * t
    x = x0_m + np.cumsum(v * np.sin(psi)) * dt
    z = z0_m + np.cumsum(v * np.cos(psi)) * dt
    ok = z > 200.0
    d = FB / z
    d2 = np.gradient(np.gradient(d, dt), dt)
    inner = ok[2:-2] & ok[1:-3] & ok[3:-1]
    bound = np.array([disparity_accel_bound(di, FB) for di in d[2:-2]])
    assert np.all(np.abs(d2[2:-2])[inner] <= bound[inner] * 1.01 + 1e-9)
    assert np.all(np.abs(x) < 1e6)


@settings(max_examples=60, deadline=None)
@given(st.floats(0.5, 200.0), st.floats(1e-3, 1.0))
def test_rung_is_the_tightest_ladder_step_above_the_bound(d_px: float, top: float) -> None:
    rung = accel_rung(d_px, FB, top)
    bound = disparity_accel_bound(d_px, FB)
    k = math.log2(top / rung)
    assert rung <= top and abs(k - round(k)) < 1e-9 and 0 <= round(k) <= ACCEL_RUNGS
    if rung < top:
        assert rung >= bound and (rung / 2 < bound or round(k) == ACCEL_RUNGS)
    else:
        assert top / 2 < bound  # the configured value, when the physics needs (about) that much


def test_rung_grows_with_disparity_and_without_a_rig_scale_is_the_configured_value() -> None:
    rungs = [accel_rung(d, FB, 0.05) for d in (2.0, 4.0, 8.0, 16.0, 32.0, 64.0)]
    assert rungs == sorted(rungs) and rungs[0] < rungs[-1] == 0.05
    assert accel_rung(4.0, 0.0, 0.05) == 0.05
