"""Aliasing check of a track's stereo match: the same point matched with a smaller window, and the
disparity variance their persistent disagreement adds to the fix's sigma (issue 16).

Why: on optics without blur (no anti-aliasing filter, a lens sharp at the pixel) regular detail
finer than two pixels — bridge windows, railings, container stacks at 3-5 km — aliases. The
sampled pattern then moves between the views by another shift than the ship does, the matcher
locks onto a disparity tenths of a pixel off, and every one of its passes agrees (they see the
same samples), so the predicted sigma and the track's scatter stay small while the fix is
hundreds of metres off. A single template cannot tell this apart: the alias folds detail near
1 px into low image frequencies, so energy near Nyquist (second differences, a row FFT's high
band) separates aliased from clean windows poorly (tools/bench-core,
"aliasing" section). Two windows centred on the same point weight the aliased detail and the
rest of the ship differently, so their disparities disagree where aliasing biases them and agree
(to the noise) where it does not: 55 % of the biased windows flagged at 5 % false alarms on
clean texture, 40 % at 1 %, against 32-39 % for the Nyquist-energy statistics.

What it adds: `AliasCheck.sigma_px()` = GAIN x the *persistent* disagreement, |mean of the recent
d(window) - d(check window)| less two of its standard errors, once that exceeds DEADZONE_PX, else
0, and at most MAX_SIGMA_PX. Persistent because aliasing bias at a ship's slowly changing
disparity persists from pair to pair, while the small window's own noise and phase-dependent
errors average out (its RMS, tried first, widened sigma 14x on tools/evaluate sharp-periodic).
The check window is 4 px smaller (15 -> 11), chosen by measurement in the pipeline (docs/accuracy.md,
"Sharp optics and periodic detail"): a 9-px window is itself aliased and far off (+0.4 px on
sharp-decks), so its disagreement sized the 9-px window's bias, not the product's, and widened
the sigma 2-10x; 23- and 27-px windows are biased alike with the 15-px one and never disagree;
the 11-px one disagrees by about the 15-px window's bias. The ceiling (0.1 px, a 15-px window's
bias seldom exceeds it in the pipeline's scenarios) keeps a check window that slipped to another
alias from making the fix useless. It is a separate, additive disparity-variance term: the fix's
disparity sigma is hypot(filter sigma, this) (edge.pipeline `Pipeline._fixes`), so other sigma
terms (calibration, row sigma) compose with it. On by default (`pipeline.alias_check`, one more
11x11 match per track and pair); on blurred optics it stays quiet (akashi-crossing: the same
figures).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence

from edge.core.match import Match

CHECK_WINDOW_DELTA = 4  # the check window is this much smaller (15 -> 11)
MIN_CHECK_WINDOW = 7
DEADZONE_PX = 0.03  # persistent disagreement that clean texture stays below (bench-core "aliasing")
GAIN = 1.0  # alias sigma = GAIN x persistent disagreement
HISTORY = 20  # recent disagreements kept
MAX_SIGMA_PX = 0.1  # the term's ceiling, px (module doc)
MIN_SAMPLES = 3  # before the term counts


def persistent_px(deltas: Sequence[float]) -> float | None:
    """|mean| of recent disagreements less two of its standard errors: the part that does not average
    out (None with fewer than MIN_SAMPLES)."""
    n = len(deltas)
    if n < MIN_SAMPLES:
        return None
    mean = sum(deltas) / n
    var = sum((d - mean) ** 2 for d in deltas) / (n - 1)
    return max(0.0, abs(mean) - 2.0 * math.sqrt(var / n))


def check_window(window: int) -> int:
    """The smaller window of the cross-check (odd, at least MIN_CHECK_WINDOW)."""
    return max(MIN_CHECK_WINDOW, window - CHECK_WINDOW_DELTA) | 1


class AliasCheck:
    """Recent disagreements between a track's match and its small-window check."""

    def __init__(self) -> None:
        self.deltas: deque[float] = deque(maxlen=HISTORY)
        self._sigma: float | None = None  # sigma_px() of the deltas as they are (None: not computed)

    def clear(self) -> None:
        self.deltas.clear()
        self._sigma = None

    def add(self, main: Match, check: Match) -> None:
        """One pair's two matches of the same point (ignored unless both are valid)."""
        if main.valid and check.valid:
            self.deltas.append(main.disparity_px - check.disparity_px)
            self._sigma = None

    def rms_px(self) -> float | None:
        if len(self.deltas) < MIN_SAMPLES:
            return None
        return math.sqrt(sum(d * d for d in self.deltas) / len(self.deltas))

    def persistent_px(self) -> float | None:
        """|mean disagreement| less two of its standard errors (the part that does not average out)."""
        return persistent_px(self.deltas)

    def sigma_px(self) -> float:
        """The additive disparity sigma (px) for aliasing bias: 0 while the windows agree. Computed
        once per new sample: the fixes and the depth check ask for it every pair."""
        if self._sigma is None:
            persistent = self.persistent_px()
            self._sigma = 0.0 if persistent is None or persistent <= DEADZONE_PX else \
                min(MAX_SIGMA_PX, GAIN * persistent)
        return self._sigma
