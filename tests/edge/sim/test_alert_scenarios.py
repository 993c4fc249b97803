"""The issue-18 scenarios have the geometry they claim: close-quarters closes to a 150 m CPA,
near-pass to 1 km, both at t = 300 s, both ships inside the 43 deg field of view throughout."""

from __future__ import annotations

import math

import numpy as np
import pytest

from edge.core.cpa import relative_cpa
from edge.sim.scenario import build_ships, load_scenario


@pytest.mark.parametrize(("name", "cpa_m"), [("close-quarters", 150.0), ("near-pass", 1000.0)])
def test_true_cpa_and_field_of_view(name: str, cpa_m: float) -> None:
    scenario = load_scenario(name)
    a, b = build_ships(scenario.spec, scenario.path)
    t = np.arange(0.0, scenario.spec.duration_s + 1.0)
    pa = np.array([a.track.pose(s)[:2] for s in t])
    pb = np.array([b.track.pose(s)[:2] for s in t])
    d = np.hypot(*(pb - pa).T)
    k = int(np.argmin(d))
    assert math.isclose(d[k], cpa_m, abs_tol=1.0) and t[k] == 300.0
    # the constant-velocity CPA of edge.core.cpa from the first second agrees (straight tracks)
    m, tcpa, _, _ = relative_cpa(pb[0] - pa[0], (pb[1] - pa[1]) - (pb[0] - pa[0]))
    assert math.isclose(abs(float(m)), cpa_m, abs_tol=1.0) and math.isclose(float(tcpa), 300.0, abs_tol=1.0)
    for p in (pa, pb):  # x right, z forward: the centre inside the 21.5 deg half field
        assert np.all(np.abs(np.degrees(np.arctan2(p[:, 0], p[:, 1]))) < 21.0)
        assert np.all(np.hypot(*p.T) < 2800.0)
