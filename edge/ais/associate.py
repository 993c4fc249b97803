"""Association of T tracks with AIS targets: a chi-square gate, a global nearest neighbour, and
hysteresis so that an identity neither flickers between two close ships nor hops at one bad fix.

Gate (per track i, target j): the innovation y = p_i - c_j between the track's ground-plane
position p_i (the IMM's east/north, `edge.measure.groundtrack`) and the target's hull centre c_j
extrapolated to the exposure time (`edge.ais.targets`), with S = P_i + C_j + D_j:
  P_i  the track's covariance: along the line of sight the range sigma (r^2 sigma_d / (f L_B),
       growing as Z^2), across it the small bearing sigma;
  C_j  the AIS position's covariance: GNSS error by accuracy flag plus extrapolation error;
  D_j  the camera's point is somewhere on the hull, not its centre: a uniform spread over the
       length along the heading and the beam across it, variances (L/2)^2/3 and (W/2)^2/3.
NIS = y^T S^-1 y; a pair with NIS > gate_nis (chi-square 2 dof) is not allowed.

Assignment: scipy's `linear_sum_assignment` over all tracks and targets, cost = NIS + ln det S
(the negative log-likelihood up to a constant, so a wide gate is not a free pass), minus
`hold_bonus` for the track's current target. Hysteresis: the assigned MMSI becomes the track's
reported one only after it has been the assignment for `confirm_s` unchanged; losing an
association takes the same. A T track without a reported association for `dark_after_s`, counted
from its first T fix, its last association or the AIS input's warm-up (whichever is latest),
is dark. A fix carries its track's MMSI only when this pair's assignment agrees: a fix outside
its target's gate (an occlusion mixing two ships' points, a jump to the neighbour) is not
labelled with an identity its own position contradicts, while the track keeps it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from edge.ais.targets import Predicted

BIG = 1e9


@dataclass(frozen=True)
class TrackGeometry:
    """A T track's ground-plane position and covariance at the exposure time."""

    track_id: int
    en_m: np.ndarray
    cov: np.ndarray


@dataclass
class _State:
    first_t_ns: int
    reported: int | None = None
    candidate: int | None = None
    candidate_since_ns: int = 0
    last_assoc_ns: int | None = None
    dark: bool = False


@dataclass(frozen=True)
class Association:
    mmsi: int | None  # the track's reported MMSI
    dark: bool
    this_pair: bool = True  # this pair's assignment agrees with `mmsi` (else the fix does not carry it)


def hull_cov(heading_rad: float, length_m: float, beam_m: float) -> np.ndarray:
    """Covariance of a point spread uniformly over a hull of length x beam along `heading_rad`."""
    fwd = np.array([math.sin(heading_rad), math.cos(heading_rad)])
    stbd = np.array([fwd[1], -fwd[0]])
    return (length_m / 2.0) ** 2 / 3.0 * np.outer(fwd, fwd) + (beam_m / 2.0) ** 2 / 3.0 * np.outer(stbd, stbd)


def gate_cost(track: TrackGeometry, target: Predicted) -> tuple[float, float]:
    """(NIS, NIS + ln det S) of a track against a target."""
    s = track.cov + target.cov + hull_cov(target.heading_rad, target.length_m, target.beam_m)
    y = track.en_m - target.centre_en_m
    det = float(np.linalg.det(s))
    if not det > 0.0:
        return math.inf, math.inf
    nis = float(y @ np.linalg.solve(s, y))
    return nis, nis + math.log(det)


class Associator:
    """Per-track association state; `step` once per pair with the T tracks and the targets."""

    def __init__(self, gate_nis: float, hold_bonus: float, confirm_s: float, dark_after_s: float,
                 warmup_s: float) -> None:
        self.gate_nis, self.hold_bonus = gate_nis, hold_bonus
        self.confirm_ns, self.dark_after_ns = round(confirm_s * 1e9), round(dark_after_s * 1e9)
        self.warmup_ns = round(warmup_s * 1e9)
        self.state: dict[int, _State] = {}
        self.switches = 0  # a track's reported MMSI changed from one to another

    def step(self, t_ns: int, tracks: list[TrackGeometry], targets: list[Predicted],
             input_start_ns: int | None, live_ids: set[int]) -> dict[int, Association]:
        """The association of every T track in `tracks`; tracks not in `live_ids` are forgotten."""
        self.state = {k: v for k, v in self.state.items() if k in live_ids}
        assigned: dict[int, int] = {}
        if tracks and targets:
            cost = np.full((len(tracks), len(targets)), BIG)
            for i, tr in enumerate(tracks):
                held = self.state[tr.track_id].reported if tr.track_id in self.state else None
                for j, tg in enumerate(targets):
                    nis, c = gate_cost(tr, tg)
                    if nis <= self.gate_nis:
                        cost[i, j] = c - (self.hold_bonus if held == tg.mmsi else 0.0)
            rows, cols = linear_sum_assignment(cost)
            for i, j in zip(rows.tolist(), cols.tolist(), strict=True):
                if cost[i, j] < BIG / 2:
                    assigned[tracks[i].track_id] = targets[j].mmsi
        out = {}
        ready_ns = None if input_start_ns is None else input_start_ns + self.warmup_ns
        for tr in tracks:
            st = self.state.setdefault(tr.track_id, _State(t_ns, candidate_since_ns=t_ns))
            got = assigned.get(tr.track_id)
            if got != st.candidate:
                st.candidate, st.candidate_since_ns = got, t_ns
            if st.candidate != st.reported and t_ns - st.candidate_since_ns >= self.confirm_ns:
                if st.reported is not None and st.candidate is not None:
                    self.switches += 1
                st.reported = st.candidate
            if st.reported is not None:
                st.last_assoc_ns = t_ns
                st.dark = False
            else:
                since = max(st.first_t_ns, st.last_assoc_ns or st.first_t_ns,
                            ready_ns if ready_ns is not None else t_ns)
                st.dark = ready_ns is not None and t_ns - since >= self.dark_after_ns
            out[tr.track_id] = Association(st.reported, st.dark, got == st.reported)
        return out
