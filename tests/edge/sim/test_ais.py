"""Simulated AIS: ITU-R M.1371 intervals by speed and class, and the lines decoded by pyais (the
independent peer) land on the ship's antenna within the GNSS noise, on the true site heading."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pyais import decode

from edge.core.geodesy import geodetic_to_world
from edge.core.site import Site
from edge.sim.ais import ais_lines, antenna_world_xz, report_interval_s
from edge.sim.scenario import load_scenario, scenario_from_dict
from edge.sim.simulator import Simulation


@pytest.mark.parametrize(
    "cls, sog, interval",
    [
        ("A", 0.0, 180.0),
        ("A", 9.0, 10.0),
        ("A", 18.0, 6.0),
        ("A", 30.0, 2.0),
        ("B", 1.0, 180.0),
        ("B", 7.0, 30.0),
    ],
)
def test_report_interval(cls: str, sog: float, interval: float) -> None:
    assert report_interval_s(cls, sog) == interval


@pytest.mark.parametrize("heading_error_deg", [0.0, 0.5])
def test_positions_are_the_antenna_within_gnss_noise(heading_error_deg: float) -> None:
    base = load_scenario("harbour-mix")
    data = {
        "calibration": "../calibration/akashi-pinhole.yaml",
        "fps": 2,
        "duration_s": 200,
        "rig_error": {"heading_deg": heading_error_deg},
        "ships": [
            {
                "id": 1,
                "kind": "coaster",
                "length_m": 70,
                "track": {"waypoints_m": [[380, 1520], [-420, 1460]], "speed_kn": [9]},
                "ais": {"mmsi": 431000123, "name": "X", "accurate": True, "gnss_sigma_m": 0.001},
            }
        ],
    }
    scenario = scenario_from_dict(data, base.path)
    sim = Simulation(scenario)
    lines = ais_lines(scenario, sim.ships, 200.0)
    site = scenario.site
    true_site = Site(site.lat_deg, site.lon_deg, site.height_m, site.heading_deg + heading_error_deg)
    positions = [(t, decode(line)) for t, line in lines if line.startswith("!AIVDM,1,1")]
    assert 19 <= len(positions) <= 21  # 9 kn class A: every 10 s
    for t_ns, msg in positions:
        x, z, _ = antenna_world_xz(sim.ships[0], scenario.spec.ships[0].ais, t_ns / 1e9)
        w = geodetic_to_world(np.array(msg.lat), np.array(msg.lon), np.array(0.0), true_site)
        assert math.hypot(w[0] - x, w[2] - z) < 0.5  # 1/10000 minute of arc: 0.19 m, plus rounding
        assert msg.accuracy and abs(msg.speed - 9.0) <= 0.1
        ws = geodetic_to_world(np.array(msg.lat), np.array(msg.lon), np.array(0.0), site)  # stated heading
        turned = math.degrees(math.atan2(ws[0], ws[2]) - math.atan2(x, z))
        assert abs(turned - heading_error_deg) < 0.01  # turned by the error (0.19 m resolution at 1.5 km)
    statics = [decode(*[ln for t, ln in lines if t in (t0, t0)][:2]) for t0, line in lines if ",2,1," in line]
    assert statics and statics[0].shipname == "X" and statics[0].to_bow + statics[0].to_stern == 70
