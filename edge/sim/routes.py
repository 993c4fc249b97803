"""Scripted ship tracks: waypoints joined by straight legs and constant-radius turns.

A track is a polyline of world (x, z) waypoints (metres; X right along the
baseline, Z forward) with one speed per leg. Each interior waypoint is rounded
by a circular arc of `turn_radius_m` tangent to both legs (shrunk if a leg is
too short), unless the ship holds there: then it stops at the waypoint, turns
on the spot at a constant rate during the hold, and sails on. Before the start
time the ship is on the extension of the first leg; after the last waypoint
it carries on along the last leg, so any time has a pose.

Heading is the world azimuth of the bow in the XZ plane, from +Z toward +X
(radians); the direction of travel is (sin h, cos h) in (x, z).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

KNOT_MPS = 1852.0 / 3600.0
MAX_FILLET_RAD = math.radians(170.0)  # sharper reversals turn on the spot (give a hold to make it take time)


@dataclass(frozen=True)
class _Segment:
    t0_s: float  # time the segment starts
    duration_s: float
    start: tuple[float, float]  # (x, z)
    heading0: float
    speed_mps: float
    turn: float  # signed curvature 1/r (0 for a straight leg); heading rate = speed * turn
    spin_rate: float = 0.0  # heading change per second while holding (speed 0)


def _heading(vec: np.ndarray) -> float:
    return math.atan2(vec[0], vec[1])


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


class Route:
    """Pose (x_m, z_m, heading_rad) of a ship as a function of time."""

    def __init__(
        self,
        waypoints_m: Sequence[tuple[float, float]] | np.ndarray,
        speeds_mps: list[float] | np.ndarray,
        turn_radius_m: float,
        start_s: float = 0.0,
        holds_s: list[float] | np.ndarray | None = None,
    ) -> None:
        pts = np.asarray(waypoints_m, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 2:
            raise ValueError("a track needs at least two (x, z) waypoints")
        legs = np.diff(pts, axis=0)
        lengths = np.hypot(legs[:, 0], legs[:, 1])
        if np.any(lengths <= 0.0):
            raise ValueError("consecutive waypoints must differ")
        speeds = np.broadcast_to(np.asarray(speeds_mps, dtype=np.float64), (len(legs),))
        if np.any(speeds <= 0.0):
            raise ValueError("leg speeds must be positive")
        holds = np.zeros(len(pts)) if holds_s is None or len(holds_s) == 0 else np.asarray(holds_s, float)
        if holds.shape != (len(pts),) or np.any(holds < 0.0):
            raise ValueError("holds_s needs one non-negative time per waypoint")
        self.segments: list[_Segment] = []
        radius = turn_radius_m if turn_radius_m >= 0.01 else 0.0  # below a centimetre: sharp corners
        self._build(pts, legs / lengths[:, None], lengths, speeds, holds, radius, start_s)

    def _build(self, pts, dirs, lengths, speeds, holds, radius, t) -> None:
        n_legs = len(dirs)
        # tangent length cut from each end of each leg by the fillets
        cut = np.zeros((n_legs, 2))
        turns = np.zeros(len(pts))
        for i in range(1, n_legs):
            cross = dirs[i - 1, 0] * dirs[i, 1] - dirs[i - 1, 1] * dirs[i, 0]
            turns[i] = -math.atan2(cross, float(dirs[i - 1] @ dirs[i]))  # heading change at waypoint i
            if holds[i] == 0.0 and radius > 0.0 and 1e-9 < abs(turns[i]) < MAX_FILLET_RAD:
                cut[i - 1, 1] = cut[i, 0] = radius * math.tan(abs(turns[i]) / 2.0)
        scale = np.minimum(1.0, 0.5 * lengths / np.maximum(cut.max(axis=1), 1e-12))  # legs too short
        for i in range(1, n_legs):
            cut[i - 1, 1] = cut[i, 0] = min(cut[i - 1, 1] * scale[i - 1], cut[i, 0] * scale[i])
        for i in range(n_legs):
            if holds[i] > 0.0:
                spin = turns[i] / holds[i] if i > 0 else 0.0
                heading = _heading(dirs[i]) - turns[i]
                self._add(t, holds[i], tuple(pts[i]), heading, 0.0, 0.0, spin)
                t += holds[i]
            start = pts[i] + dirs[i] * cut[i, 0]
            straight = lengths[i] - cut[i].sum()
            self._add(t, straight / speeds[i], tuple(start), _heading(dirs[i]), speeds[i], 0.0)
            t += straight / speeds[i]
            if i + 1 < n_legs and cut[i, 1] > 0.0:
                r = cut[i, 1] / math.tan(abs(turns[i + 1]) / 2.0)
                arc = r * abs(turns[i + 1])
                curvature = math.copysign(1.0 / r, turns[i + 1])
                end = pts[i + 1] - dirs[i] * cut[i, 1]
                self._add(t, arc / speeds[i], tuple(end), _heading(dirs[i]), speeds[i], curvature)
                t += arc / speeds[i]
        if holds[-1] > 0.0:
            self._add(t, holds[-1], tuple(pts[-1]), _heading(dirs[-1]), 0.0, 0.0)
            t += holds[-1]
        self.end_s = t
        self._end = (tuple(pts[-1]), _heading(dirs[-1]), float(speeds[-1]))

    def _add(self, t0, duration, start, heading, speed, turn, spin=0.0) -> None:
        if duration > 0.0:
            self.segments.append(_Segment(float(t0), float(duration), start, heading, speed, turn, spin))

    @property
    def start_s(self) -> float:
        return self.segments[0].t0_s

    def pose(self, t_s: float) -> tuple[float, float, float]:
        """(x_m, z_m, heading_rad) at time t_s."""
        first = self.segments[0]
        if t_s < first.t0_s:  # approaching along the first leg's extension
            seg = next(s for s in self.segments if s.speed_mps > 0.0)
            back = (first.t0_s - t_s) * seg.speed_mps
            x0, z0 = first.start
            return x0 - back * math.sin(seg.heading0), z0 - back * math.cos(seg.heading0), seg.heading0
        if t_s >= self.end_s:
            (x, z), heading, speed = self._end
            ahead = (t_s - self.end_s) * speed
            return x + ahead * math.sin(heading), z + ahead * math.cos(heading), heading
        seg = self.segments[-1]
        for candidate in self.segments:
            if t_s < candidate.t0_s + candidate.duration_s:
                seg = candidate
                break
        return _advance(seg, t_s - seg.t0_s)


def _advance(seg: _Segment, dt: float) -> tuple[float, float, float]:
    x0, z0 = seg.start
    h0 = seg.heading0
    if seg.speed_mps == 0.0:
        return x0, z0, _wrap(h0 + seg.spin_rate * dt)
    s = seg.speed_mps * dt
    if seg.turn == 0.0:
        return x0 + s * math.sin(h0), z0 + s * math.cos(h0), _wrap(h0)
    # on the arc: the centre lies 1/turn to starboard (cos h, -sin h) of the start point
    r = 1.0 / seg.turn  # signed: positive turns toward +heading (starboard)
    h1 = h0 + s * seg.turn
    cx, cz = x0 + r * math.cos(h0), z0 - r * math.sin(h0)
    return cx - r * math.cos(h1), cz + r * math.sin(h1), _wrap(h1)
