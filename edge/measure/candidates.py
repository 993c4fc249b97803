"""Weak detections wait here until they persist: M of the last N detection passes, then a birth.

A detector tuned for small boats in glitter (issue 24) passes far more candidates than ships:
sun glints and whitecaps are bright, local and gone within a pass or two, a hull stays. A track
costs a stereo match every pair and a place in the table (`max_tracks`), so a candidate the
detector calls weak is not born at once: it is kept here, associated from pass to pass by the
overlap of its columns (`edge.measure.boxes.overlaps`, the table's own gate), and offered for
birth only once it was seen in `hits` of the last `passes` detection passes. Its birth then
still has to match in stereo at the sea range of its waterline (`TrackTable._birth`), and the
track has to be confirmed again before it turns T. A candidate that can no longer reach `hits`
is forgotten. Strong detections bypass this (born at once, as before).

Pure bookkeeping over rectified boxes [x0, y0, x1, y1]; no images.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from edge.measure.boxes import overlaps


@dataclass
class Candidate:
    box: np.ndarray
    seen: deque[bool]  # per detection pass since it appeared (the last `passes`): seen or not


class CandidatePool:
    """Weak detections by pass; `step` returns the boxes that persisted long enough to be born."""

    def __init__(self, hits: int = 3, passes: int = 5, min_overlap: float = 0.2) -> None:
        if not 1 <= hits <= passes:
            raise ValueError(f"need 1 <= hits <= passes, got {hits} of {passes}")
        self.hits, self.passes, self.min_overlap = hits, passes, min_overlap
        self.candidates: list[Candidate] = []

    def step(self, boxes: list[np.ndarray]) -> list[np.ndarray]:
        """One detection pass's weak boxes (not associated to a track); the boxes to give birth to."""
        matched: dict[int, int] = {}
        if self.candidates and boxes:
            share = overlaps(np.array([c.box for c in self.candidates]), np.array(boxes, float))
            rows, cols = linear_sum_assignment(-share)
            matched = {int(j): int(i) for i, j in zip(rows, cols, strict=True)
                       if share[i, j] >= self.min_overlap}
        seen = set(matched.values())
        for i, c in enumerate(self.candidates):
            c.seen.append(i in seen)
        for j, box in enumerate(boxes):
            if j in matched:
                self.candidates[matched[j]].box = np.asarray(box, float)
            else:
                self.candidates.append(Candidate(np.asarray(box, float), deque([True], maxlen=self.passes)))
        born = [c for c in self.candidates if sum(c.seen) >= self.hits]
        self.candidates = [c for c in self.candidates if sum(c.seen) < self.hits
                           and (len(c.seen) - sum(c.seen)) <= self.passes - self.hits]
        return [c.box for c in born]
