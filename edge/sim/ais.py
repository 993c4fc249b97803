"""Simulated AIS: the `!AIVDM` lines a receiver at the site would hear from the scenario's ships.

Each ship with an `ais:` block transmits:
- position reports (type 1 for class A, 18 for class B) at the ITU-R M.1371 interval for its
  speed (class A: 10 s up to 14 kn, 6 s up to 23 kn, 2 s above, 3 min when stopped; class B
  "CS": 30 s above 2 kn, 3 min below), at a random phase;
- static data (type 5, two fragments, for class A; type 24 parts A and B for class B) every
  `static_interval_s`.
The reported position is the antenna's (on the bridge unless A/B/C/D say otherwise) plus white
GNSS noise of the accuracy flag's sigma, on the *true* site heading (the scenario's stated one
plus `rig_error.heading_deg`), so a heading error appears between camera and AIS as it would
in the field. SOG/COG/heading come from the track (SOG 0.1 kn and COG 0.1 deg resolution, from
pyais's encoder). Lines are stamped with their transmit time on the recording's clock; the
receive latency (a slot, ~27 ms) is left out. Deterministic for a seed.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pyais import encode_dict

from edge.core.geo import world_to_latlon
from edge.core.site import Site
from edge.sim.routes import KNOT_MPS
from edge.sim.scenario import Scenario, ShipAisSpec
from edge.sim.ships import Ship

GNSS_SIGMA_ACCURATE_M = 1.5  # per axis: DGNSS, 95 % horizontal ~3.7 m (flag 1: < 10 m)
GNSS_SIGMA_COARSE_M = 6.0  # per axis: autonomous GNSS, 95 % ~15 m (flag 0)


def report_interval_s(ais_class: str, sog_kn: float) -> float:
    """ITU-R M.1371 Annex 1 table 1 (class A, not changing course) and class B CS (SOTDMA-less)."""
    if ais_class == "B":
        return 30.0 if sog_kn > 2.0 else 180.0
    if sog_kn < 0.2:
        return 180.0
    if sog_kn <= 14.0:
        return 10.0
    return 6.0 if sog_kn <= 23.0 else 2.0


def antenna_m(ship: Ship, spec: ShipAisSpec) -> tuple[float, float, float, float]:
    """A/B/C/D, m: the spec's, else the bridge point on the centreline."""
    if spec.antenna_m is not None:
        return spec.antenna_m
    half, a_t = ship.model.length_m / 2.0, float(ship.model.tracked_local[0])
    beam = ship.model.beam_m / 2.0
    return half - a_t, half + a_t, beam, beam


def antenna_world_xz(ship: Ship, spec: ShipAisSpec, t_s: float) -> tuple[float, float, float]:
    """(x, z) of the antenna in the world frame and the heading (rad from +Z) at t_s."""
    x, z, h = ship.track.pose(t_s)
    a, b, c, d = antenna_m(ship, spec)
    along = (a - b) / -2.0  # antenna from the hull centre: A from the bow means (B - A)/2 ahead
    across = (c - d) / 2.0  # ... and (C - D)/2 to starboard
    return (x + along * math.sin(h) + across * math.cos(h), z + along * math.cos(h) - across * math.sin(h), h)


def _velocity(ship: Ship, t_s: float) -> tuple[float, float]:
    x0, z0, _ = ship.track.pose(t_s - 0.5)
    x1, z1, _ = ship.track.pose(t_s + 0.5)
    return x1 - x0, z1 - z0


def ais_lines(scenario: Scenario, ships: list[Ship], duration_s: float,
              seed: int = 0) -> list[tuple[int, str]]:
    """(t_ns, sentence) of every AIS line in [0, duration_s), in time order."""
    spec = scenario.spec
    site = scenario.site
    true_site = Site(site.lat_deg, site.lon_deg, site.height_m, site.heading_deg + spec.rig_error.heading_deg)
    out: list[tuple[int, int, str]] = []
    seq = 0
    for k, (ship, ship_spec) in enumerate(zip(ships, spec.ships, strict=True)):
        ais = ship_spec.ais
        if ais is None:
            continue
        rng = np.random.default_rng([seed, ais.mmsi % 1_000_000_007, 0xA15])
        gnss = ais.gnss_sigma_m or (GNSS_SIGMA_ACCURATE_M if ais.accurate else GNSS_SIGMA_COARSE_M)
        t = float(rng.uniform(0.0, 10.0 if ais.ais_class == "A" else 30.0)) if ais.interval_s is None else \
            float(rng.uniform(0.0, ais.interval_s))
        channel = 0
        while t < duration_s:
            vx, vz = _velocity(ship, t)
            sog_kn = math.hypot(vx, vz) / KNOT_MPS
            x, z, h = antenna_world_xz(ship, ais, t)
            noise = rng.normal(0.0, gnss, 2)
            lat, lon, _ = world_to_latlon(np.array([x + noise[0], 0.0, z + noise[1]]), true_site)
            cog = (true_site.heading_deg + math.degrees(math.atan2(vx, vz))) % 360.0
            heading = round(true_site.heading_deg + math.degrees(h)) % 360
            msg: dict[str, Any] = {
                "type": 1 if ais.ais_class == "A" else 18, "mmsi": ais.mmsi, "speed": round(sog_kn, 1),
                "accuracy": int(ais.accurate), "lon": float(lon), "lat": float(lat),
                "course": round(cog, 1) % 360.0, "heading": heading, "second": int(t) % 60}
            if ais.ais_class == "B":
                msg["cs"] = 1
            for line in encode_dict(msg, talker_id="AI", sentence_type="VDM", radio_channel="AB"[channel]):
                out.append((round(t * 1e9), k, line))
            channel ^= 1
            t += ais.interval_s or report_interval_s(ais.ais_class, sog_kn)
        t = float(rng.uniform(0.0, min(ais.static_interval_s, duration_s)))
        while t < duration_s:
            a, b, c, d = (round(v) for v in antenna_m(ship, ais))
            dims = {"to_bow": a, "to_stern": b, "to_port": c, "to_starboard": d}
            msgs: list[dict[str, Any]]
            if ais.ais_class == "A":
                msgs = [{"type": 5, "mmsi": ais.mmsi, "shipname": ais.name, **dims}]
            else:
                msgs = [{"type": 24, "mmsi": ais.mmsi, "partno": 0, "shipname": ais.name},
                        {"type": 24, "mmsi": ais.mmsi, "partno": 1, **dims}]
            for i, msg in enumerate(msgs):
                seq = (seq + 1) % 10
                for line in encode_dict(msg, talker_id="AI", sentence_type="VDM", radio_channel="AB"[channel],
                                        seq_id=seq):
                    out.append((round(t * 1e9) + i, k, line))
            t += ais.static_interval_s
    out.sort(key=lambda r: (r[0], r[1]))
    return [(t_ns, line) for t_ns, _, line in out]
