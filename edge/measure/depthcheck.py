"""Depth check of a track's stereo match: four sub-windows matched on their own, and the disparity
variance their persistent disagreement with the main match adds to the fix's sigma (issue 16).

Why: the 15-px window returns one disparity for everything it holds. Where the ship's depth varies
across it — a near ship seen end-on, whose bow, superstructure and masts lie 50-120 m apart in
range, at 720 px one window — that disparity is the texture-weighted mix of theirs, not the
disparity of the surface under the window's centre, and it stays off pair after pair while the
ship holds its aspect. The disparity filter averages it as if it were noise, and the alias check's
two concentric windows (edge.measure.aliascheck) weight those depths nearly alike, so neither sees
it: approach-720 at 1-2 km was at RMS(e / sigma) 1.96 (tools/evaluate).

What it adds: sub-windows of SUB_WINDOW px centred OFFSET_PX left of, right of, above and below the
point, each matched around the main match (search radius 2). `DepthCheck.sigma_px()` is GAIN x the
RMS over the four of their *persistent* disagreement with the main match (|mean| less two standard
errors, as the alias check's), at most MAX_SIGMA_PX. A fronto-parallel patch (a far ship, a ship
broadside) gives sub-windows that agree to the noise: the term stays 0. The point track drops it
while the alias check finds aliasing: 7-px windows alias worse than the product's 15-px one on
sharp optics, and their disagreement there sized their own bias (sharp-decks: sigma 4x, RMS 0.12).
GAIN 1.5 is fitted with eq. K.8's correlation time (edge.measure.filter_designs) on the eleven recordings of
docs/accuracy.md's sigma table; the sub-windows' disagreement is a few pixels' depth step, smaller than
the offset the window's texture may sit at. Four 7x7 matches over five disparities per track and
pair they run on, once per EVERY_S (0.5 s): every pair at 1 fps, every 5th at 10 fps. Run on every
pair they made a pair 2-4x the time with many tracks (tools/bench: 720x480, 29 tracks, 4.2 -> 14.5
ms), while the window's depth mix changes with the ship's aspect over seconds, and samples
0.5 s apart are nearly independent of the matcher's correlated noise (0.10 s, eq. K.8), as the
persistence test's standard error assumes.
"""

from __future__ import annotations

import math
from collections import deque

from edge.core.match import Match
from edge.measure.aliascheck import persistent_px

SUB_WINDOW = 7  # px side of each sub-window
OFFSET_PX = 4  # sub-window centres this far from the point: inside the 15-px window, half overlapping
OFFSETS = ((-OFFSET_PX, 0), (OFFSET_PX, 0), (0, -OFFSET_PX), (0, OFFSET_PX))  # (du, dv) px
GAIN = 1.5  # depth sigma = GAIN x the RMS persistent disagreement (module doc)
HISTORY = 20  # recent disagreements kept per sub-window (10 s at 10 fps, 20 s at 1 fps)
MAX_SIGMA_PX = 0.5  # the term's ceiling, px
EVERY_S = 0.5  # sub-windows matched on one pair per this many seconds (module doc)


def depth_every(fps: float) -> int:
    """Pairs between two depth checks: every pair at 2 fps and less, every 5th at 10 fps."""
    return max(1, int(round(fps * EVERY_S)))


class DepthCheck:
    """Recent disagreements between a track's match and each of its four sub-window matches."""

    def __init__(self) -> None:
        self.deltas: tuple[deque[float], ...] = tuple(deque(maxlen=HISTORY) for _ in OFFSETS)
        self._sigma: float | None = None  # sigma_px() of the deltas as they are (None: not computed)

    def clear(self) -> None:
        for d in self.deltas:
            d.clear()
        self._sigma = None

    def add(self, k: int, main: Match, sub: Match) -> None:
        """Sub-window k's match of this pair against the main one (ignored unless both are valid)."""
        if main.valid and sub.valid:
            self.deltas[k].append(sub.disparity_px - main.disparity_px)
            self._sigma = None

    def sigma_px(self) -> float:
        """The additive disparity sigma (px) for the depth the window spans: 0 while they agree.
        Computed once per new sample (the fixes ask for it every pair; it changes every 5th)."""
        if self._sigma is None:
            p = [persistent_px(d) or 0.0 for d in self.deltas]
            self._sigma = min(MAX_SIGMA_PX, GAIN * math.sqrt(sum(x * x for x in p) / len(p)))
        return self._sigma
