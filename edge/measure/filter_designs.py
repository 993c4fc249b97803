"""The disparity filter's designs: Kalman tables per noise level and acceleration rung, shared by all tracks.

The white acceleration of a track's design comes from the ship-motion bound of its disparity
(`edge.core.shipmotion.accel_rung`): far ships change disparity so slowly that a design built for
them may average over much longer than one built for a ship a few hundred metres away.
"""

from __future__ import annotations

import math
from dataclasses import replace

from edge.core.kalman import KalmanDesign, design_kalman
from edge.measure.settings import PointSettings

# Correlation time of the matcher's disparity error (s), for the reported sigma (eq. K.8 of
# edge.core.kalman_design): fitted with edge.measure.depthcheck's GAIN on the eleven recordings of the
# sigma-criterion table of docs/accuracy.md (docs/decisions.md); 0.10 s puts RMS(e / sigma) in
# 0.6-1.5 on all of them
# (0.12 s before the depth check; with it, 0.09 s put akashi-crossing at 1.51).
MATCH_ERROR_CORR_S = 0.10


class Designs:
    """The Kalman tables of one setting, computed once (lazily per noise level) and shared by all tracks.

    The measurement noise of a track is not known in advance: a textured bridge at 1 km
    matches to a few hundredths of a pixel, a small hull in fog to half a pixel. Each track
    measures its own scatter and uses the design of the matching rung of NOISE_LADDER_PX
    (edge.measure.pointfilter, factors of 2), so the gate and the reported sigma fit the data actually seen;
    and the acceleration rung of its disparity (`accel_rung`)."""

    _tables: dict[tuple[float, float], KalmanDesign]  # (sigma_px, accel_pxps2) -> design

    def __init__(self, s: PointSettings) -> None:
        self.s, self._tables = s, {}

    def disparity(self, sigma_px: float, accel_pxps2: float | None = None) -> KalmanDesign:
        """The design for this noise level and white acceleration (default: the configured one).

        A design below the configured acceleration averages over longer than the matcher's
        errors stay independent (a window's texture-dependent error drifts with the ship's
        pose over seconds: tools/evaluate --diagnose), so its innovations spread more than its
        white-noise model says. It keeps the configured design's gate (its innovation covariance
        tables, eq. K.6 of edge.core.kalman: the same samples are refused; the accepted ones move
        the estimate less). Its own, tighter gate refuses a noisy far track's own samples and lets it
        coast off (docs/decisions.md). Its reported sigma is its own covariance times the
        correlated-noise gain of eq. K.8 (MATCH_ERROR_CORR_S), with the lag-1 correlated share rho of
        the configured design's steady-state variance as its floor (the whole of it made the sigma
        2-3x the error at 2-5 km at 1 fps, where rho ~ 0, and too small at 1-2 km at 10 fps)."""
        s, key = self.s, (sigma_px, accel_pxps2 or self.s.sigma_accel_pxps2)
        if key not in self._tables:
            design = design_kalman(s.fps, sigma_px, key[1], gate_sigma=s.gate_sigma,
                                   reacquire_s=s.reacquire_s, corr_s=MATCH_ERROR_CORR_S)
            if key[1] < s.sigma_accel_pxps2:
                top = self.disparity(sigma_px)
                # the share rho of the configured design's steady-state variance is correlated from
                # pair to pair and stays as a floor that longer averaging cannot remove (eq. K.8)
                floor = math.sqrt(design.corr_rho * top.post_var[-1] + top.sigma_floor_px**2)
                design = replace(design, sigma_floor_px=floor, cov_q36=top.cov_q36,
                                 coast_q_q36=top.coast_q_q36)
            self._tables[key] = design
        return self._tables[key]

