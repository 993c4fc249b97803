"""lab.evaluate.motion: the truth's own speed, course and manoeuvres from the scripted track, and
the table-3 windows' errors and pass/fail."""

from __future__ import annotations

import math

import numpy as np
import pytest

import lab.evaluate.motion as mo
from edge.core.site import Site
from edge.fix import ShipFix, TrackStatus
from edge.sim.routes import KNOT_MPS, Route
from lab.evaluate.metrics import Matched

SITE = Site(34.63, 135.02, 25.0, 0.0)  # heading north: world +Z is north, +X east


def test_truth_motion_of_a_turning_track() -> None:
    """10 kn east, a 90 deg turn to the north on a 100 m radius (at 3 deg/s), then north."""
    v = 10 * KNOT_MPS
    track = Route([(-1000.0, 2000.0), (0.0, 2000.0), (0.0, 3000.0)], [v, v], 100.0)
    straight = mo.truth_motion(track, 30.0, SITE)
    assert straight.speed_kn == pytest.approx(10.0, abs=1e-6)
    assert straight.course_deg == pytest.approx(90.0, abs=0.05)  # east (meridian convergence ~0.01 deg)
    assert not straight.manoeuvring
    turn_start = (1000.0 - 100.0) / v
    assert mo.truth_motion(track, turn_start + 10.0, SITE).manoeuvring
    after = mo.truth_motion(track, turn_start + 60.0, SITE)
    assert abs((after.course_deg + 180.0) % 360.0 - 180.0) < 0.05
    since = mo.steady_since_s(track, np.arange(0.0, 300.0, 1.0), SITE)
    assert since[0] == -math.inf
    assert turn_start + 25.0 < since[-1] < turn_start + 35.0  # the turn ends ~30 s in


def test_windows_pass_and_fail_by_error_and_share(monkeypatch: pytest.MonkeyPatch) -> None:
    """A straight 3.4 kn ship: fixes with 0.2 kn and 2 deg errors pass both windows; withholding the
    course on a tenth of them fails them (share below 95 %)."""
    v = 3.4 * KNOT_MPS
    track = Route([(0.0, 3000.0), (0.0, 5000.0)], [v], 100.0)
    monkeypatch.setattr(mo, "truth_tracks", lambda meta: {1: track})

    def run(withhold_every: int) -> list[dict]:
        fixes, matched = {}, []
        for k in range(300):
            t_ns = k * 10**9
            cog = None if withhold_every and k % withhold_every == 0 else 2.0
            fixes[t_ns] = [ShipFix(t_ns, 1, TrackStatus.TRACKING, 0.0, 0.0, 3000.0, 3000.0, 0.0, 0.0, 0.0,
                                   3.6, cog, 10.0, 5.0, age_s=float(k), sog_sigma_kn=0.2, cog_sigma_deg=2.0)]
            matched.append(Matched(t_ns, 1, 1, 3000.0, 0.0, 0.0, 0.0, 10.0, 0.0, 3000.0))
        return mo.motion_rows(fixes, matched, {}, SITE)

    rows = run(0)
    assert [(r["window"], r["fixes"]) for r in rows] == [("1 min", 240), ("3 min", 120)]
    assert all(r["pass"] for r in rows)
    assert rows[0]["sog_p95_kn"] == pytest.approx(0.2, abs=1e-4)
    assert rows[0]["cog_p95_deg"] == pytest.approx(2.0)
    assert rows[0]["sog_rms_z"] == pytest.approx(1.0, abs=1e-4)
    assert not any(r["pass"] for r in run(10))
