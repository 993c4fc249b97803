"""Many tracks' points stepped together, their image searches batched (edge.core.batchmatch).

A `TrackPoint` does its per-pair work as a generator (`TrackPoint.steps`): where it needs the
core it yields a request, a `Follow` (the left-image point tracker, `follow_point`) or a
`StereoMatch` (the right-image matcher, `match_point`), and is sent the result. `step_points`
runs the generators of all tracks in rounds: each round collects every track's pending
request, answers the follows with one `track_points` call and the matches with one
`match_points` call (per group of equal settings), and sends each track its own answer. A
track's logic and the order of its own requests are those of `TrackPoint.step`, which runs
the same generator alone with the per-point core functions, and the batched core functions
are bit-identical to those, so the batched pipeline gives the same fixes bit for bit (tests
compare the two; replay stays deterministic). Tracks do not share state within a step, so
interleaving them in rounds changes nothing.

Why: per-call numpy overhead dominated a track's cost (~0.4 ms per track per pair, tools/bench);
batching the integer searches across tracks removes most of it.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Generator, Sequence
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from edge.core import native
from edge.core.batchmatch import match_points, track_points
from edge.core.match import Match, match_point
from edge.core.prefilter import NOISE_GAIN
from edge.core.rectify import Rectifier
from edge.core.refpoint import FollowResult, follow_point
from edge.measure.settings import PointSettings

# fewer requests of a kind and settings are answered one by one (same results): the batched follow
# is cheaper than `follow_point` even for one point (its parabola curves come off the cost square),
# the batched match only from about three points on (its fixed cost: the batched products and the
# vectorised Gaussian fits cost more than one point's own). Tracks with a window of their own
# (edge.measure.anchor.ship_window) form small groups: tools/bench's 8-ship scene has groups of 1, 3 and 4
BATCH_MIN = {"Follow": 1, "StereoMatch": 3}  # NumPy only: the compiled kernels (edge.core.native) take any


@dataclass(frozen=True, slots=True)
class FollowSettings:
    """The point tracker's knobs shared by a batch (hashable: requests are grouped by them)."""

    window: int
    search_radius: int
    subpixel: str
    noise_dn: float
    max_sigma_px: float


@dataclass(frozen=True, slots=True)
class MatchSettings:
    """The stereo matcher's knobs shared by a batch."""

    window: int
    search_radius: int
    cost: str
    subpixel: str
    noise_dn: float
    max_sigma_px: float


@dataclass(frozen=True, slots=True)
class Follow:
    """`follow_point(prev, cur, x, y, predicted_dx=...)`: where did the template's point go?"""

    prev: np.ndarray
    cur: np.ndarray
    x: float
    y: float
    predicted_dx: float
    settings: FollowSettings

    def run(self) -> FollowResult:
        s = self.settings
        return follow_point(self.prev, self.cur, self.x, self.y, window=s.window,
                           search_radius=s.search_radius, predicted_dx=self.predicted_dx, subpixel=s.subpixel,
                           noise_dn=s.noise_dn, max_sigma_px=s.max_sigma_px)


@dataclass(frozen=True, slots=True)
class StereoMatch:
    """`match_point(left, right, x, y, ...)` on two rectified patches of the same rows and columns."""

    left: np.ndarray
    right: np.ndarray
    x: float
    y: float
    max_disparity: int
    predicted: float | None
    settings: MatchSettings
    x0: int = 0  # the patches' origin in the rectified image (`stereo_request`; reused by `near`)
    y0: int = 0

    def run(self) -> Match:
        s, pred = self.settings, self.predicted
        return match_point(self.left, self.right, self.x, self.y, window=s.window,
                           max_disparity=self.max_disparity, predicted_disparity=pred, cost=s.cost,
                           subpixel=s.subpixel,
                           search_radius=s.search_radius if pred is not None else None,
                           noise_dn=s.noise_dn, max_sigma_px=s.max_sigma_px)


@dataclass(frozen=True, slots=True)
class Checks:
    """Several matches that depend on none of each other's answers (a track's cross-checks of its
    main match), asked in one round and answered with a list of Match in their order."""

    requests: tuple[StereoMatch, ...]

    def run(self) -> list[Match]:
        return [r.run() for r in self.requests]


Request = Follow | StereoMatch | Checks
Steps = Generator[Request, FollowResult | Match | list[Match], bool]


def follow_settings(s: PointSettings, max_sigma_px: float) -> FollowSettings:
    """A track's follow knobs (constant per track: kept, and the key its follows are grouped by)."""
    return FollowSettings(s.window, s.follow_radius_px, s.follow_subpixel, s.noise_dn, max_sigma_px)


def match_settings(s: PointSettings) -> MatchSettings:
    """A track's stereo-match knobs (constant per track: kept, and the key its matches are grouped by)."""
    gain = NOISE_GAIN if s.prefilter == "xsobel" else 1.0
    return MatchSettings(s.window, s.search_radius_px, s.cost, s.subpixel, s.noise_dn * gain, s.max_sigma_px)


def stereo_request(s: PointSettings, left: np.ndarray, right: np.ndarray, rect: Rectifier, u: float,
                   v: float, pred: float | None, settings: MatchSettings,
                   within: StereoMatch | None = None) -> StereoMatch:
    """The match of rectified left point (u, v): patches of the rows the window covers and the columns
    the search needs (narrowed to the prediction when there is one); `settings` is `match_settings(s)`,
    which a track keeps. `within`: a request of this pair whose patches may hold these (no
    prefilter); then they are cut from them (a patch is the same pixels however it was fetched), not
    rectified again (the alias and depth checks' windows lie inside the main match's)."""
    h = s.window // 2
    ui, vi = int(round(u)), int(round(v))
    d_hi = s.max_disparity
    if pred is not None:
        d_hi = max(4, min(d_hi, int(math.ceil(pred)) + s.search_radius_px + 1))
    x0, width = ui - h - d_hi - 4, 2 * h + d_hi + 9
    y0 = vi - h
    if within is not None and s.prefilter == "none" and within.x0 <= x0 \
            and x0 + width <= within.x0 + within.left.shape[1] \
            and within.y0 <= y0 and y0 + 2 * h + 1 <= within.y0 + within.left.shape[0]:
        # inside the patches of `within` (the same images): the same pixels, no remap
        cols = slice(x0 - within.x0, x0 - within.x0 + width)
        rows = slice(y0 - within.y0, y0 - within.y0 + 2 * h + 1)
        return StereoMatch(within.left[rows, cols], within.right[rows, cols], u - x0, v - y0, d_hi, pred,
                           settings, x0, y0)
    get = rect.xsobel_patch if s.prefilter == "xsobel" else rect.patch
    lp, rp = get(left, 0, x0, y0, width, 2 * h + 1), get(right, 1, x0, y0, width, 2 * h + 1)
    return StereoMatch(lp, rp, u - x0, v - y0, d_hi, pred, settings, x0, y0)


def run_one(steps: Steps) -> bool:
    """Drive one point's generator with the per-point core functions (the reference)."""
    try:
        request = next(steps)
        while True:
            request = steps.send(request.run())
    except StopIteration as done:
        return bool(done.value)


def answer_all(requests: Sequence[Follow | StereoMatch]) -> list[FollowResult | Match]:
    """The answers to many requests, the core's searches batched per kind and settings."""
    out: list[FollowResult | Match | None] = [None] * len(requests)
    groups: dict[tuple, list[int]] = defaultdict(list)
    for i, r in enumerate(requests):
        groups[(type(r), r.settings)].append(i)
    for (kind, s), idx in groups.items():
        rs: list[Any] = [requests[i] for i in idx]  # all Follow or all StereoMatch, as `kind` says
        if len(rs) < BATCH_MIN[kind.__name__] and native.kernels is None:  # too few to repay the batch
            answers = [r.run() for r in rs]
        elif kind is Follow:
            answers = track_points([r.prev for r in rs], [r.cur for r in rs], [r.x for r in rs],
                                   [r.y for r in rs], [r.predicted_dx for r in rs], [0.0] * len(rs),
                                   window=s.window, search_radius=s.search_radius, subpixel=s.subpixel,
                                   noise_dn=s.noise_dn, max_sigma_px=s.max_sigma_px)
        else:
            answers = match_points([r.left for r in rs], [r.right for r in rs], [r.x for r in rs],
                                   [r.y for r in rs], [r.max_disparity for r in rs],
                                   [r.predicted for r in rs], window=s.window, search_radius=s.search_radius,
                                   cost=s.cost, subpixel=s.subpixel, noise_dn=s.noise_dn,
                                   max_sigma_px=s.max_sigma_px)
        for i, a in zip(idx, answers, strict=True):
            out[i] = a
    return out  # type: ignore[return-value]


def step_points(all_steps: Sequence[Steps]) -> list[bool]:
    """Run many points' generators to the end in rounds, each round's requests answered together;
    the value each returned (TrackPoint.step's)."""
    results: list[bool] = [False] * len(all_steps)
    pending: dict[int, Request] = {}

    def advance(i: int, answer: FollowResult | Match | list[Match] | None) -> None:
        try:
            pending[i] = next(all_steps[i]) if answer is None else all_steps[i].send(answer)
        except StopIteration as done:
            results[i] = bool(done.value)

    for i in range(len(all_steps)):
        advance(i, None)
    while pending:
        order = sorted(pending)
        asked = [pending.pop(i) for i in order]
        flat: list[Follow | StereoMatch] = []
        for r in asked:  # a Checks' matches join the round's others
            if isinstance(r, Checks):
                flat.extend(r.requests)
            else:
                flat.append(r)
        answers = iter(answer_all(flat))
        for i, r in zip(order, asked, strict=True):
            if isinstance(r, Checks):
                advance(i, [cast(Match, next(answers)) for _ in r.requests])
            else:
                advance(i, next(answers))
    return results


__all__ = ["Checks", "Follow", "StereoMatch", "answer_all", "follow_settings", "match_settings", "run_one",
           "step_points", "stereo_request"]
