"""How much a ship's disparity can change: the bound that sets the disparity filter's process noise.

A ship at depth Z (disparity d = f L_B / Z) moving at speed <= v with acceleration <= a
(speed change or turn) has |Z'| <= v and |Z''| <= a, so differentiating d = f L_B / Z twice,

    d'' = f L_B (2 Z'^2 / Z^3 - Z'' / Z^2)
    |d''| <= a d^2 / (f L_B) + 2 v^2 d^3 / (f L_B)^2                        (px/s^2)

At 5 km with the 2048 px rig (f L_B = 21 165 px m) that is ~6e-4 px/s^2, eighty times less than
the filter's configured white acceleration (which is what a ship can do at a few hundred metres),
so a constant-velocity Kalman designed for the far ship may average over much longer. The design
is taken from a ladder of factors of 2 below the configured value, so that few tables are built
and shared, and the ladder stops at 1/16: the matcher's error on a ship is not white (it follows
the window's texture as the ship's pose changes, over seconds), and deeper designs averaged it
into a persistent offset instead (tools/evaluate: two-ships-crossing 2-3 km IMO 94 % on main,
90 % with 1/256, 96 % with 1/16; approach-2048 3-4 km 50 % on main, 99 % / 98 %).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

from edge.core.kalman import KalmanDesign, design_kalman

if TYPE_CHECKING:
    from edge.trackpoint import PointSettings

MAX_SHIP_SPEED_MPS = 25.0  # ~50 kn: no ship's range changes faster
MAX_SHIP_ACCEL_MPS2 = 0.5  # speed change or turn (12 kn on a 120 m radius is 0.32 m/s^2)
ACCEL_RUNGS = 4  # the ladder goes down to the configured acceleration / 2^4 (see the module doc)


def disparity_accel_bound(disparity_px: float, fb_px_m: float, *, speed_mps: float = MAX_SHIP_SPEED_MPS,
                          accel_mps2: float = MAX_SHIP_ACCEL_MPS2) -> float:
    """|d''| (px/s^2) a ship at this disparity can show (module doc); inf without a rig scale."""
    if fb_px_m <= 0:
        return float("inf")
    d = max(disparity_px, 0.0)
    return accel_mps2 * d * d / fb_px_m + 2.0 * speed_mps**2 * d**3 / fb_px_m**2


def accel_rung(disparity_px: float, fb_px_m: float, top_pxps2: float) -> float:
    """The white acceleration for the filter's design: the smallest top / 2^k (k <= ACCEL_RUNGS)
    that is at least the physical bound; `top` (the configured value) when the bound exceeds it."""
    bound = disparity_accel_bound(disparity_px, fb_px_m)
    rung = top_pxps2
    for _ in range(ACCEL_RUNGS):
        if rung / 2.0 < bound:
            break
        rung /= 2.0
    return rung


class Designs:
    """The Kalman tables of one setting, computed once (lazily per noise level) and shared by all tracks.

    The measurement noise of a track is not known in advance: a textured bridge at 1 km
    matches to a few hundredths of a pixel, a small hull in fog to half a pixel. Each track
    measures its own scatter and uses the design of the matching rung of NOISE_LADDER_PX
    (edge.pointfilter, factors of 2), so the gate and the reported sigma fit the data actually seen;
    and the acceleration rung of its disparity (`accel_rung`)."""

    def __init__(self, s: PointSettings) -> None:
        self.s, self._tables = s, {}

    def disparity(self, sigma_px: float, accel_pxps2: float | None = None) -> KalmanDesign:
        """The design for this noise level and white acceleration (default: the configured one).

        A design below the configured acceleration averages over longer than the matcher's
        errors stay independent (a window's texture-dependent error drifts with the ship's
        pose over seconds: tools/evaluate --diagnose), so its innovations spread more than its
        white-noise model says. It keeps the configured design's gate (its innovation covariance
        tables, eq. K.6 of edge.core.kalman: the same samples are refused; the accepted ones move
        the estimate less) and reports no less than the configured design's steady-state sigma
        (sigma_floor_px). Its own, tighter gate was measured worse: on akashi-crossing the far
        coaster's noisy track (raw 0.63 px RMS, unbiased) refused its own samples and coasted
        off by 1.7 px (1.3 km, 27 fixes beyond 3 sigma), though it spared two-ships-crossing's
        22 beyond 3 sigma while one ship passes in front of the other."""
        s, key = self.s, (sigma_px, accel_pxps2 or self.s.sigma_accel_pxps2)
        if key not in self._tables:
            design = design_kalman(s.fps, sigma_px, key[1], gate_sigma=s.gate_sigma,
                                   reacquire_s=s.reacquire_s)
            if key[1] < s.sigma_accel_pxps2:
                top = self.disparity(sigma_px)
                design = replace(design, sigma_floor_px=math.sqrt(top.post_var[-1] + top.sigma_floor_px**2),
                                 cov_q36=top.cov_q36, coast_q_q36=top.coast_q_q36)
            self._tables[key] = design
        return self._tables[key]
