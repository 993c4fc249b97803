"""Coasting fixes: a live track whose point gives no usable range in a pair still gets a fix.

Why: the outputs key a track's life on the step's fixes. ASTERIX ends a track (I010/170 TRE) and
NMEA sends it L when its fix is missing, so a track the tracker still holds must be in every
step's list, and only its drop from the tracker may end it. A point that cannot be ranged on in
a pair (its disparity unknown, or scattering more than `pointfilter.MAX_USABLE_NOISE_PX`: a far
ship in haze) used to leave its track out of that pair's fixes; a VTS saw it end and start again.

The coasted fix is the track's last measured fix carried to this pair: moved by its
ground-plane velocity where the fix carried one (`ShipFix.en_state`, known once SOG is shown),
held where it did not. Its 1-sigma grows by what the ship may have done since, per horizontal
axis: the velocity's own 1-sigma times the time, or without a velocity the fastest ship
(`shipmotion.MAX_SHIP_SPEED_MPS`) times the time, a bound taken as the sigma. Status: L for a
confirmed track (the tracker has it L already when its scatter is the cause), Q for a tentative
one; `coasted` is set so ASTERIX can say so (I010/170 CST). Speed, course, length and identity
are the last fix's.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from edge.core.geo import enu_to_world, range_bearing, world_to_latlon
from edge.core.shipmotion import MAX_SHIP_SPEED_MPS
from edge.core.site import Site
from edge.fix import ShipFix, TrackStatus


def growth_m(last: ShipFix, dt_s: float) -> float:
    """The per-axis 1-sigma, m, a position carried `dt_s` from `last` gains."""
    if last.en_state is not None and last.en_cov is not None:
        var_ve, var_vn = last.en_cov[10], last.en_cov[15]  # the velocities' variances (4x4, row-major)
        return math.sqrt(max(0.0, 0.5 * (var_ve + var_vn))) * dt_s
    return MAX_SHIP_SPEED_MPS * dt_s


def coast(last: ShipFix, t_ns: int, status: TrackStatus, site: Site, *, age_s: float,
          confidence: float | None) -> ShipFix:
    """`last` (the track's last measured fix) carried to `t_ns` for a track whose status is now
    `status`; see the module docstring."""
    dt_s = max(0.0, (t_ns - last.t_ns) / 1e9)
    east_m = north_m = 0.0
    if last.en_state is not None:
        east_m, north_m = last.en_state[2] * dt_s, last.en_state[3] * dt_s
    world = np.array([last.x_m, last.y_m, last.z_m]) + enu_to_world(np.array([east_m, north_m, 0.0]),
                                                                     site.heading_deg)
    range_m, bearing_deg = range_bearing(world, site.heading_deg)
    lat, lon, _ = world_to_latlon(world, site)
    g = growth_m(last, dt_s)
    across = last.sigma_across_m
    return dataclasses.replace(
        last, t_ns=t_ns,
        status=TrackStatus.ACQUIRING if status is TrackStatus.ACQUIRING else TrackStatus.LOST,
        x_m=float(world[0]), y_m=float(world[1]), z_m=float(world[2]), range_m=float(range_m),
        bearing_deg=float(bearing_deg), lat_deg=float(lat), lon_deg=float(lon),
        sigma_m=math.sqrt(last.sigma_m * last.sigma_m + 2.0 * g * g),
        sigma_across_m=None if across is None else math.hypot(across, g),
        age_s=age_s, confidence=confidence, en_state=None, en_cov=None, coasted=True)
