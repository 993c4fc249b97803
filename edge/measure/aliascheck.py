"""Aliasing check of a track's stereo match: the same point matched with a smaller window, and the
disparity variance their persistent disagreement adds to the fix's sigma (issue 16).

Why: on optics without blur (no anti-aliasing filter, a lens sharp at the pixel) regular detail
finer than two pixels — bridge windows, railings, container stacks at 3-5 km — aliases. The
sampled pattern then moves between the views by another shift than the ship does, the matcher
locks onto a disparity tenths of a pixel off, and every one of its passes agrees (they see the
same samples), so the predicted sigma and the track's scatter stay small while the fix is
hundreds of metres off. A single template cannot tell this apart: the alias folds detail near
1 px into low image frequencies, so energy near Nyquist (second differences, a row FFT's high
band) separates aliased from clean windows hardly better than chance (tools/bench-core,
"aliasing" section). Two windows centred on the same point weight the aliased detail and the
rest of the ship differently, so their disparities disagree where aliasing biases them and agree
(to the noise) where it does not: 55 % of the biased windows flagged at 5 % false alarms on
clean texture, 40 % at 1 %, against 32-39 % for the Nyquist-energy statistics.

What it adds: `AliasCheck.sigma_px()` = GAIN x the RMS of the recent disagreements d(window) -
d(CHECK window) once that RMS exceeds DEADZONE_PX (what clean texture shows), else 0. It is a
separate, additive disparity-variance term: the fix's disparity sigma is
hypot(filter sigma, this) (edge.pipeline `_fixes`), so other sigma terms compose with it.
A single pair's disagreement misses about a third of the biased windows (both windows biased
alike), so the term is the RMS over the track's recent pairs: a ship moving along its course
changes the pattern's phase from pair to pair, and the RMS sees the bias the windows show now
and then. Opt-in (`pipeline.alias_check`): one more match per track and pair.
"""

from __future__ import annotations

import math
from collections import deque

from edge.core.match import Match

CHECK_WINDOW_DELTA = 6  # the check window is this much smaller (15 -> 9)
MIN_CHECK_WINDOW = 7
DEADZONE_PX = 0.03  # RMS disagreement over a track's recent pairs that clean texture stays below
GAIN = 3.0  # alias sigma = GAIN x RMS disagreement (bench-core "aliasing": the checked column)
HISTORY = 20  # recent disagreements kept
MIN_SAMPLES = 3  # before the term counts


def check_window(window: int) -> int:
    """The smaller window of the cross-check (odd, at least MIN_CHECK_WINDOW)."""
    return max(MIN_CHECK_WINDOW, window - CHECK_WINDOW_DELTA) | 1


class AliasCheck:
    """Recent disagreements between a track's match and its small-window check."""

    def __init__(self) -> None:
        self.deltas: deque[float] = deque(maxlen=HISTORY)

    def clear(self) -> None:
        self.deltas.clear()

    def add(self, main: Match, check: Match) -> None:
        """One pair's two matches of the same point (ignored unless both are valid)."""
        if main.valid and check.valid:
            self.deltas.append(main.disparity_px - check.disparity_px)

    def rms_px(self) -> float | None:
        if len(self.deltas) < MIN_SAMPLES:
            return None
        return math.sqrt(sum(d * d for d in self.deltas) / len(self.deltas))

    def sigma_px(self) -> float:
        """The additive disparity sigma (px) for aliasing bias: 0 while the windows agree."""
        rms = self.rms_px()
        return GAIN * rms if rms is not None and rms > DEADZONE_PX else 0.0
