"""The AIS target table: the latest position and static data per MMSI, and where each target's
hull centre is at a given time in the site's east/north plane, with its uncertainty.

Positions come from types 1/2/3/18/19, static data (name, antenna offsets A/B/C/D) from 5, 19
and 24. A position report older than `max_age_s` at the time asked about is dropped (counted in
`too_old`): an extrapolation over minutes is worth less than no AIS at all.

`predict(t_ns)` extrapolates each report to the exposure time with its own SOG/COG (a straight
line: ships hold course for minutes) and moves the antenna's position to the hull centre:
the antenna is A m from the bow, B from the stern, C from port and D from starboard, so the
centre lies (A - B)/2 ahead of it and (D - C)/2 to starboard, along the heading (COG when the
heading is not available). The covariance of that centre is the GNSS error for the accuracy
flag (better than 10 m at 95 %: sigma 5 m; otherwise sigma 15 m), plus the extrapolation's error
(0.3 m/s per second along the course, 0.05 rad of the speed per second across it, the course's
and speed's resolution and a ship's change of either between reports).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from edge.ais.decode import AisCounters, PositionReport, Report, StaticReport
from edge.core.geo import KNOT_MPS, world_to_enu
from edge.core.geodesy import geodetic_to_world
from edge.core.site import Site

SIGMA_ACCURATE_M = 5.0  # accuracy flag 1: better than 10 m (95 %)
SIGMA_COARSE_M = 15.0  # accuracy flag 0: worse than 10 m (autonomous GNSS)
SPEED_DRIFT_MPS2 = 0.3  # along-course extrapolation error per second of age (m/s)
COURSE_DRIFT_RAD = 0.05  # across-course error per second of age, times the speed
DEFAULT_LENGTH_M = 30.0  # hull size when the static data has not come (yet)
DEFAULT_BEAM_M = 8.0


@dataclass
class Target:
    mmsi: int
    position: PositionReport | None = None
    static: StaticReport = field(default_factory=lambda: StaticReport(0, 0))

    @property
    def name(self) -> str | None:
        return self.static.name

    def dims_m(self) -> tuple[float, float, float, float] | None:
        s = self.static
        dims = (s.to_bow_m, s.to_stern_m, s.to_port_m, s.to_starboard_m)
        return None if any(d is None for d in dims) else dims  # type: ignore[return-value]


@dataclass(frozen=True)
class Predicted:
    """A target at one time: hull centre and antenna east/north (m), covariance, hull geometry."""

    mmsi: int
    centre_en_m: np.ndarray
    antenna_en_m: np.ndarray
    cov: np.ndarray  # 2x2 of the centre (GNSS + extrapolation)
    heading_rad: float  # true, from north toward east
    length_m: float
    beam_m: float
    report: PositionReport
    age_s: float
    dims_known: bool


class TargetTable:
    """Targets by MMSI; `add` reports as they arrive, `predict` at each exposure time."""

    def __init__(self, site: Site, max_age_s: float, counters: AisCounters | None = None) -> None:
        self.site, self.max_age_s = site, float(max_age_s)
        self.counters = counters or AisCounters()
        self.targets: dict[int, Target] = {}

    def add(self, report: Report) -> None:
        target = self.targets.setdefault(report.mmsi, Target(report.mmsi))
        if isinstance(report, PositionReport):
            target.position = report
            return
        old = target.static
        target.static = replace(report, **{k: getattr(old, k) for k in
                                           ("name", "to_bow_m", "to_stern_m", "to_port_m", "to_starboard_m")
                                           if getattr(report, k) is None})

    def expire(self, t_ns: int) -> None:
        """Drop position reports older than max_age_s (their static data stays)."""
        for target in self.targets.values():
            p = target.position
            if p is not None and (t_ns - p.t_ns) / 1e9 > self.max_age_s:
                target.position = None
                self.counters.too_old += 1

    def antenna_en_m(self, report: PositionReport) -> np.ndarray:
        lat, lon = np.array(report.lat_deg), np.array(report.lon_deg)
        world = geodetic_to_world(lat, lon, np.array(0.0), self.site)
        return world_to_enu(world, self.site.heading_deg)[:2]

    def predict(self, t_ns: int) -> list[Predicted]:
        """Every target with a recent position report, extrapolated to `t_ns`."""
        self.expire(t_ns)
        out = []
        for target in self.targets.values():
            p = target.position
            if p is None:
                continue
            age_s = max(0.0, (t_ns - p.t_ns) / 1e9)
            speed = (p.sog_kn or 0.0) * KNOT_MPS
            course = math.radians(p.cog_deg) if p.cog_deg is not None else 0.0
            if p.cog_deg is None:
                speed = 0.0
            fwd_c = np.array([math.sin(course), math.cos(course)])
            antenna = self.antenna_en_m(p) + fwd_c * speed * age_s
            heading = math.radians(p.heading_deg) if p.heading_deg is not None else course
            fwd = np.array([math.sin(heading), math.cos(heading)])
            stbd = np.array([fwd[1], -fwd[0]])
            dims = target.dims_m()
            if dims is None:
                centre, length, beam = antenna, DEFAULT_LENGTH_M, DEFAULT_BEAM_M
            else:
                a, b, c, d = dims
                centre = antenna + fwd * (a - b) / 2.0 + stbd * (d - c) / 2.0
                length, beam = max(a + b, 1.0), max(c + d, 1.0)
            gnss = SIGMA_ACCURATE_M if p.accurate else SIGMA_COARSE_M
            along = math.hypot(gnss, SPEED_DRIFT_MPS2 * age_s)
            across = math.hypot(gnss, (COURSE_DRIFT_RAD * speed + 0.05) * age_s)
            cov = along**2 * np.outer(fwd_c, fwd_c) + across**2 * np.outer(
                [fwd_c[1], -fwd_c[0]], [fwd_c[1], -fwd_c[0]])
            out.append(Predicted(target.mmsi, centre, antenna, cov, heading, length, beam, p, age_s,
                                 dims is not None))
        return out
