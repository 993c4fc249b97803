"""Fixes against ground truth: matching, per-range-bin statistics, id switches, first-T times.

Used by tools/evaluate. Pure computation over lists of `ShipFix` and the truth of a
recording (no I/O here).

Matching, pair by pair: every T fix is matched to at most one ship by the Hungarian
method on cost = (degrees of the fix's bearing outside the ship's angular extent) / 1 deg
+ |ln(range_fix / range_ship)| / ln 1.5, gated at 2. So a fix is credited to the ship it
points at, however bad its range, and fixes that point at no ship are false fixes.

Errors are against truth.csv, the bridge on the centreline. A fix measures *some*
visible point of the ship, so besides the range and bearing errors the tables give the
fix's distance outside the ship's hull outline (length x beam at the truth heading,
placed with the scenario model's bridge offset): the "3 reported sigma" check uses it.
IMO MSC.192(79) target accuracy: range within max(50 m, 1 % of range) and bearing
within 2 deg of the bridge (`imo_ok`, the acceptance figure); beside it the same tolerances
against the hull outline (`imo_hull_ok`).
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from edge.core.geo import KNOT_MPS
from edge.fix import ShipFix, TrackStatus

BINS_M = ((0, 1000), (1000, 2000), (2000, 3000), (3000, 4000), (4000, 5000))
MIN_SHIP_PX = 20  # a ship counts for detection once it covers this many pixels (eq. 3.12)
FIRST_T_LIMIT_S = 3.0
HEADING_SPAN_S = 4.0  # a ship's course from its truth track over this long (longer than wave motion)


@dataclass
class Ship:
    """One truth ship: id, size, the bridge's offset along the hull, and its track."""

    ship_id: int
    length_m: float
    beam_m: float
    bridge_a_m: float  # bridge position along the hull from its centre (bow +)
    t_ns: np.ndarray  # (n,)
    xyz_m: np.ndarray  # (n, 3) truth (bridge) positions
    bridge_h_m: float = 0.0  # the bridge's height above the waterline (lab.evaluate.sigma's 3-D hull)
    top_h_m: float = math.nan  # the model's highest part above the waterline (NaN: not known)

    def _motion(self, i: int) -> tuple[float, float, float]:
        """(dx, dz, dt) of the truth track over HEADING_SPAN_S around sample i. (The truth point
        sways and rolls with the waves: over a few samples a ship at anchor seems to move at random
        headings, which would spin its outline.)"""
        half_ns = int(HEADING_SPAN_S * 5e8)
        j0 = int(np.searchsorted(self.t_ns, self.t_ns[i] - half_ns))
        j1 = max(j0, int(np.searchsorted(self.t_ns, self.t_ns[i] + half_ns, side="right")) - 1)
        dx, dz = self.xyz_m[j1, 0] - self.xyz_m[j0, 0], self.xyz_m[j1, 2] - self.xyz_m[j0, 2]
        return float(dx), float(dz), (self.t_ns[j1] - self.t_ns[j0]) / 1e9

    def heading_at(self, i: int) -> float | None:
        """Course (rad, from +Z toward +X) from the truth track around sample i; None if still."""
        dx, dz, dt = self._motion(i)
        if dt <= 0 or math.hypot(dx, dz) / dt < 0.2:
            return None
        return math.atan2(dx, dz)

    def speed_kn_at(self, i: int) -> float:
        """Speed over ground (kn) from the truth track around sample i (NaN with a single sample)."""
        dx, dz, dt = self._motion(i)
        return math.hypot(dx, dz) / dt / KNOT_MPS if dt > 0 else math.nan

    def corners(self, i: int) -> np.ndarray:
        """(4, 2) hull outline corners (x, z) at sample i (a square of side L if the ship is still)."""
        h = self.heading_at(i)
        x, z = self.xyz_m[i, 0], self.xyz_m[i, 2]
        if h is None:
            half = self.length_m / 2
            return np.array([[x - half, z - half], [x + half, z - half], [x + half, z + half],
                             [x - half, z + half]])
        fwd, stbd = np.array([math.sin(h), math.cos(h)]), np.array([math.cos(h), -math.sin(h)])
        centre = np.array([x, z]) - self.bridge_a_m * fwd
        a, b = self.length_m / 2, self.beam_m / 2
        signs = ((1, 1), (1, -1), (-1, -1), (-1, 1))
        return np.array([centre + sa * a * fwd + sb * b * stbd for sa, sb in signs])

    def outside_hull_m(self, i: int, x: float, z: float) -> float:
        """Horizontal distance of (x, z) outside the hull outline (0 inside)."""
        c = self.corners(i)
        origin, ea, eb = c[2], c[1] - c[2], c[3] - c[2]
        p = np.array([x, z]) - origin
        sa = np.clip(p @ ea / (ea @ ea), 0, 1)
        sb = np.clip(p @ eb / (eb @ eb), 0, 1)
        return float(np.linalg.norm(p - sa * ea - sb * eb))


@dataclass
class Matched:
    t_ns: int
    ship_id: int
    track_id: int
    range_m: float  # truth range (bridge)
    range_error_m: float  # fix - truth
    bearing_error_deg: float
    outside_hull_m: float
    sigma_m: float
    x_m: float
    z_m: float
    bearing_outside_deg: float = 0.0  # degrees the fix's bearing lies outside the hull's angular extent
    sog_kn: float | None = None  # the fix's speed (None: withheld)
    truth_sog_kn: float = math.nan
    y_m: float = math.nan  # the fix's world Y (down), for the 3-D hull error


@dataclass
class Evaluation:
    matched: list[Matched] = field(default_factory=list)
    false_fixes: list[ShipFix] = field(default_factory=list)
    visible: dict[tuple[int, int], float] = field(default_factory=dict)  # (t_ns, ship) -> truth range
    first_visible_ns: dict[int, int] = field(default_factory=dict)
    first_t_ns: dict[int, int] = field(default_factory=dict)
    id_switches: dict[int, int] = field(default_factory=dict)


def _bearing_deg(x: float, z: float) -> float:
    return math.degrees(math.atan2(x, z))


def _wrap(a: float) -> float:
    return (a + 180.0) % 360.0 - 180.0


def evaluate(fixes_by_t: dict[int, list[ShipFix]], ships: list[Ship], focal_px: float,
             width_px: int) -> Evaluation:
    """Match every pair's T fixes to the truth ships and collect the per-fix errors."""
    ev = Evaluation()
    index = {s.ship_id: {int(t): i for i, t in enumerate(s.t_ns)} for s in ships}
    half_fov = math.degrees(math.atan(width_px / 2 / focal_px))
    tracks_of: dict[int, list[int]] = defaultdict(list)
    for t_ns in sorted(set().union(*[set(map(int, s.t_ns)) for s in ships]) | set(fixes_by_t)):
        present = []  # (ship, sample, bearing interval, truth range)
        for s in ships:
            i = index[s.ship_id].get(t_ns)
            if i is None:
                continue
            angles = [_bearing_deg(cx, cz) for cx, cz in s.corners(i)]
            lo, hi = min(angles), max(angles)
            rng = math.hypot(s.xyz_m[i, 0], s.xyz_m[i, 2])
            present.append((s, i, lo, hi, rng))
            if -half_fov <= _bearing_deg(s.xyz_m[i, 0], s.xyz_m[i, 2]) <= half_fov and \
                    math.radians(hi - lo) * focal_px >= MIN_SHIP_PX:
                ev.visible[(t_ns, s.ship_id)] = rng
                ev.first_visible_ns.setdefault(s.ship_id, t_ns)
        fixes = [f for f in fixes_by_t.get(t_ns, []) if f.status is TrackStatus.TRACKING]
        if not fixes:
            continue
        cost = np.full((len(fixes), max(1, len(present))), 1e6)
        for a, f in enumerate(fixes):
            b_fix = _bearing_deg(f.x_m, f.z_m)
            r_fix = math.hypot(f.x_m, f.z_m)
            for b, (_s, _i, lo, hi, rng) in enumerate(present):
                outside = max(0.0, lo - b_fix, b_fix - hi)
                c = outside / 1.0 + abs(math.log(max(r_fix, 1.0) / rng)) / math.log(1.5)
                if c < 2.0:
                    cost[a, b] = c
        rows, cols = linear_sum_assignment(cost)
        used = set()
        for a, b in zip(rows, cols, strict=True):
            if cost[a, b] >= 1e6:
                continue
            used.add(a)
            f, (s, i, lo, hi, rng) = fixes[a], present[b]
            x, z = s.xyz_m[i, 0], s.xyz_m[i, 2]
            b_fix = _bearing_deg(f.x_m, f.z_m)
            ev.matched.append(Matched(
                t_ns, s.ship_id, f.track_id, rng, math.hypot(f.x_m, f.z_m) - rng,
                _wrap(b_fix - _bearing_deg(x, z)), s.outside_hull_m(i, f.x_m, f.z_m),
                f.sigma_m, f.x_m, f.z_m, max(0.0, lo - b_fix, b_fix - hi), f.sog_kn, s.speed_kn_at(i),
                y_m=f.y_m))
            ev.first_t_ns.setdefault(s.ship_id, t_ns)
            if not tracks_of[s.ship_id] or tracks_of[s.ship_id][-1] != f.track_id:
                tracks_of[s.ship_id].append(f.track_id)
        ev.false_fixes += [f for a, f in enumerate(fixes) if a not in used]
    ev.id_switches = {s.ship_id: max(0, len(tracks_of[s.ship_id]) - 1) for s in ships}
    return ev


def imo_ok(m: Matched) -> bool:
    """IMO MSC.192(79): range within 50 m or 1 % of range (the greater), bearing within 2 deg."""
    return abs(m.range_error_m) <= max(50.0, 0.01 * m.range_m) and abs(m.bearing_error_deg) <= 2.0


def imo_hull_ok(m: Matched) -> bool:
    """The IMO tolerances against the ship's hull outline instead of its bridge: the fix within
    max(50 m, 1 % of range) of the outline and its bearing within 2 deg of the hull's angular
    extent. A fix measures some visible point of the ship; this share says how often that
    point is measured to IMO accuracy. Shown beside `imo_ok` (the acceptance figure), not
    instead of it: the bridge stays the reference."""
    return m.outside_hull_m <= max(50.0, 0.01 * m.range_m) and m.bearing_outside_deg <= 2.0


def bin_rows(ev: Evaluation) -> list[dict]:
    """Per range bin: fixes, range error RMS/p95/max (m and %), bearing RMS/max, IMO share, detection."""
    rows = []
    for lo, hi in BINS_M:
        ms = [m for m in ev.matched if lo <= m.range_m < hi]
        vis = [k for k, r in ev.visible.items() if lo <= r < hi]
        hit = {(m.t_ns, m.ship_id) for m in ms}
        row = {"bin": f"{lo / 1000:.0f}-{hi / 1000:.0f} km", "fixes": len(ms),
               "detection": (sum(k in hit for k in vis) / len(vis)) if vis else None}
        if ms:
            e = np.array([m.range_error_m for m in ms])
            pct = 100 * np.abs(e) / np.array([m.range_m for m in ms])
            b = np.array([m.bearing_error_deg for m in ms])
            row.update(rms_m=float(np.sqrt(np.mean(e**2))), p95_m=float(np.percentile(np.abs(e), 95)),
                       max_m=float(np.abs(e).max()), rms_pct=float(np.sqrt(np.mean(pct**2))),
                       p95_pct=float(np.percentile(pct, 95)), max_pct=float(pct.max()),
                       bearing_rms_deg=float(np.sqrt(np.mean(b**2))), bearing_max_deg=float(np.abs(b).max()),
                       imo_share=float(np.mean([imo_ok(m) for m in ms])),
                       imo_hull_share=float(np.mean([imo_hull_ok(m) for m in ms])))
        rows.append(row)
    return rows


def sigma_check(ev: Evaluation) -> dict:
    """How the reported 1-sigma holds: fixes beyond 3 sigma of the hull outline (and of the bridge)."""
    if not ev.matched:
        return {"fixes": 0}
    hull = np.array([m.outside_hull_m / m.sigma_m for m in ev.matched])
    bridge = np.array([abs(m.range_error_m) / m.sigma_m for m in ev.matched])
    return {"fixes": len(ev.matched), "beyond_3sigma_hull": int((hull > 3).sum()),
            "max_hull_over_sigma": float(hull.max()), "beyond_3sigma_bridge_range": int((bridge > 3).sum())}


def first_t_delays(ev: Evaluation) -> dict[int, float | None]:
    """Seconds from a ship first covering MIN_SHIP_PX px to its first matched T fix (None: never)."""
    out = {}
    for sid, t0 in ev.first_visible_ns.items():
        t1 = ev.first_t_ns.get(sid)
        out[sid] = None if t1 is None else max(0.0, (t1 - t0) / 1e9)
    return out


def speed_rows(ev: Evaluation) -> dict[int, dict]:
    """Per ship: T fixes, how many carry a speed, and its error against the truth track (kn)."""
    out = {}
    for sid in sorted({m.ship_id for m in ev.matched}):
        ms = [m for m in ev.matched if m.ship_id == sid]
        e = np.array([m.sog_kn - m.truth_sog_kn for m in ms if m.sog_kn is not None])
        out[sid] = {"fixes": len(ms), "with_speed": len(e),
                    "rms_kn": float(np.sqrt(np.mean(e**2))) if len(e) else None,
                    "max_kn": float(np.abs(e).max()) if len(e) else None}
    return out
