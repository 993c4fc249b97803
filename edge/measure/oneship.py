"""One track per ship: which of two tracks sits on the other's ship, and which of them goes.

A track's point slides onto another ship when that ship passes in front of the one it followed
(akashi-crossing: the near freighter's bow crossed the far coaster's point, the coaster's track
followed the bow and became a second T track on the freighter, 30 false T fixes in 6 s). Two
tracks are one ship when one's point window reaches into the other's box and its disparity lies
where the other ship's hull can be: within the other's range plus or minus its length (its box
width at its range), widened by 3 sigma of the two filters. Ships in line merge into one blob
too, but they stand apart in range by far more than a hull.

Only settled filters are compared (the table passes tracks with enough measurements and a small
sigma): a newborn's disparity says little. Of two tracks on one ship the one its detections
confirmed more often over the last passes stays (it is on its own blob), the older on a tie; the
other is dropped, since its filter's history belongs to the ship it left.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class Held:
    """What the check needs of one track: its (rectified) box and point, its filtered disparity
    and sigma, the point's window, and its rank (higher stays: confirmations, then age)."""

    box: np.ndarray
    u: float
    v: float
    disparity_px: float
    sigma_px: float
    window: int
    rank: tuple[int, int, int]


def same_ship(a: Held, b: Held, f_px: float, fb: float) -> bool:
    """Whether b's point lies on a's ship: its window reaches into a's box and its disparity is
    within a's range -+ a's length, widened by 3 sigma of both filters."""
    half = 0.5 * b.window
    x0, y0, x1, y1 = a.box.tolist()
    if not (x0 - half <= b.u < x1 + half and y0 <= b.v < y1):
        return False
    z_m = fb / a.disparity_px
    length_m = (x1 - x0) * z_m / f_px
    d_far = fb / (z_m + length_m)
    d_near = fb / (z_m - length_m) if z_m > length_m else math.inf
    slack = 3.0 * math.hypot(a.sigma_px, b.sigma_px)
    return d_far - slack <= b.disparity_px <= d_near + slack


def duplicates(held: list[Held], f_px: float, fb: float) -> set[int]:
    """Indices into `held` of the tracks to drop: of every pair on one ship, the lower-ranked one
    (a dropped track is compared no further)."""
    gone: set[int] = set()
    for i, a in enumerate(held):
        for j, b in enumerate(held):
            if i == j or i in gone or j in gone or not same_ship(a, b, f_px, fb):
                continue
            gone.add(j if a.rank >= b.rank else i)
    return gone
