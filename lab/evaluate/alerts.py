"""Close-quarters alerts of a recording against its ground truth: lead time and false alerts (issue 18).

The product pipeline's fixes go through the daemon's `AlertManager` (default `alerts:` settings,
enabled). Each close-quarters alert's two tracks are matched to the simulated ships they follow
(the ship whose truth point is nearest to the track's fixes, by median distance); the truth's own
CPA/TCPA of that pair is the time and distance of their least separation in truth.csv (the
tracked points, eq. 18.1-18.3 on the scripted straight tracks).

Per alert: raise and clear times, lead time = true CPA time - raise time, the true CPA, and
whether it is false: its ships' true CPA is not below the CPA limit (default 500 m), or its
tracks follow no ship or the same one. A true pair that closes inside the limit without an alert
is reported as missed. For every pair of tracks it also reports how near it came to raising:
the least CPA upper bound (CPA + k sigma) while 0 < TCPA < the TCPA limit, against the limit.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from edge.alerts.manager import AlertId, AlertManager
from edge.config.alerts import AlertsConfig
from edge.core.cpa import pair_cpa
from edge.fix import ShipFix, TrackStatus

MATCH_M = 150.0  # a track follows a ship whose truth point is within this (median over its fixes)


@dataclass(frozen=True)
class AlertRow:
    tracks: tuple[int, int]
    ships: tuple[int | None, int | None]
    raised_s: float  # since the first pair
    cleared_s: float | None
    cpa_at_raise_m: float | None
    tcpa_at_raise_s: float | None
    true_cpa_m: float | None
    true_cpa_s: float | None  # since the first pair
    lead_s: float | None  # true CPA time - raise time
    false: bool


def true_pair_cpa(truth: Mapping[int, np.ndarray], a: int, b: int) -> tuple[float, int]:
    """(least distance m in the ground plane, its t_ns) between two ships of truth.csv."""
    ta, tb = truth[a], truth[b]
    common, ia, ib = np.intersect1d(ta[:, 0], tb[:, 0], return_indices=True)
    d = np.hypot(ta[ia, 1] - tb[ib, 1], ta[ia, 3] - tb[ib, 3])
    k = int(np.argmin(d))
    return float(d[k]), int(common[k])


def ship_of_track(fixes: Sequence[ShipFix], truth: Mapping[int, np.ndarray]) -> int | None:
    """The ship a track's fixes follow (median distance to its truth point <= MATCH_M), or None."""
    best: tuple[float, int] | None = None
    for sid, rows in truth.items():
        times = rows[:, 0]
        dists = []
        for f in fixes:
            k = int(np.searchsorted(times, f.t_ns))
            if k < len(times) and times[k] == f.t_ns:
                dists.append(float(np.hypot(rows[k, 1] - f.x_m, rows[k, 3] - f.z_m)))
        if dists:
            med = float(np.median(dists))
            if med <= MATCH_M and (best is None or med < best[0]):
                best = (med, sid)
    return None if best is None else best[1]


def nearest_bounds(by_time: Mapping[int, list[ShipFix]], cfg: AlertsConfig) -> list[str]:
    """Per pair of T tracks with motion: the least CPA + k sigma while 0 < TCPA < the limit."""
    best: dict[tuple[int, int], tuple[float, float, float, float]] = {}  # (upper, cpa, tcpa, t_s)
    times = sorted(by_time)
    for t_ns in times:
        known = sorted(
            (
                f
                for f in by_time[t_ns]
                if f.status is TrackStatus.TRACKING and f.en_state is not None and f.en_cov is not None
            ),
            key=lambda f: f.track_id,
        )
        if len(known) < 2:
            continue
        res = pair_cpa(
            np.array([f.en_state for f in known]), np.array([f.en_cov for f in known]).reshape(-1, 4, 4)
        )
        upper = res.cpa_m + cfg.sigmas * res.miss_sigma_m
        for k in range(len(upper)):
            if 0.0 < res.tcpa_s[k] < cfg.tcpa_s:
                pair = (known[int(res.i[k])].track_id, known[int(res.j[k])].track_id)
                if pair not in best or upper[k] < best[pair][0]:
                    best[pair] = (
                        float(upper[k]),
                        float(res.cpa_m[k]),
                        float(res.tcpa_s[k]),
                        (t_ns - times[0]) / 1e9,
                    )
    return [
        f"tracks {a}/{b}: least CPA + {cfg.sigmas:g} sigma {u:.0f} m (CPA {c:.0f} m, TCPA {tc:.0f} s, "
        f"at {t:.0f} s) against the {cfg.cpa_m:.0f} m limit"
        for (a, b), (u, c, tc, t) in sorted(best.items())
    ]


def evaluate_alerts(
    by_time: Mapping[int, list[ShipFix]],
    truth: Mapping[int, np.ndarray],
    config: AlertsConfig | None = None,
    max_tracks: int = 32,
) -> tuple[list[AlertRow], list[str]]:
    """(one row per close-quarters alert, lines naming true close-quarters pairs without one)."""
    cfg = config or AlertsConfig(enabled=True)
    manager = AlertManager(cfg, max_tracks)
    times = sorted(by_time)
    t0 = times[0] if times else 0
    per_track: dict[int, list[ShipFix]] = {}
    events: list[tuple[int, tuple[int, ...], bool, float | None, float | None]] = []
    for t_ns in times:
        fixes = by_time[t_ns]
        for f in fixes:
            per_track.setdefault(f.track_id, []).append(f)
        before = manager.sequence
        manager.step(fixes, t_ns)
        for _, alert in manager.changes_since(before):  # raises (revision 1) and clears
            if alert.alert_id is AlertId.CLOSE_QUARTERS and (alert.revision == 1 or not alert.active):
                events.append((t_ns, alert.tracks, alert.active, alert.cpa_m, alert.tcpa_s))
    ships = {tid: ship_of_track(fx, truth) for tid, fx in per_track.items()}
    rows: list[AlertRow] = []
    open_rows: dict[tuple[int, ...], int] = {}
    for t_ns, tracks, active, cpa, tcpa in events:
        if active:
            a, b = tracks[0], tracks[1]
            sa, sb = ships.get(a), ships.get(b)
            true_cpa = true_t = None
            if sa is not None and sb is not None and sa != sb:
                true_cpa, t_cpa_ns = true_pair_cpa(truth, sa, sb)
                true_t = (t_cpa_ns - t0) / 1e9
            raised = (t_ns - t0) / 1e9
            false = true_cpa is None or true_cpa >= cfg.cpa_m
            open_rows[tracks] = len(rows)
            rows.append(
                AlertRow(
                    (a, b),
                    (sa, sb),
                    raised,
                    None,
                    cpa,
                    tcpa,
                    true_cpa,
                    true_t,
                    None if true_t is None else true_t - raised,
                    false,
                )
            )
        elif tracks in open_rows:
            k = open_rows.pop(tracks)
            r = rows[k]
            rows[k] = AlertRow(
                r.tracks,
                r.ships,
                r.raised_s,
                (t_ns - t0) / 1e9,
                r.cpa_at_raise_m,
                r.tcpa_at_raise_s,
                r.true_cpa_m,
                r.true_cpa_s,
                r.lead_s,
                r.false,
            )
    missed = []
    ids = sorted(truth)
    alerted = {frozenset(r.ships) for r in rows if not r.false}
    for i, a in enumerate(ids):
        for b in ids[i + 1 :]:
            d, t_ns = true_pair_cpa(truth, a, b)
            if d < cfg.cpa_m and frozenset((a, b)) not in alerted:
                missed.append(f"missed: ships {a} and {b}: true CPA {d:.0f} m at {(t_ns - t0) / 1e9:.0f} s")
    return rows, missed + nearest_bounds(by_time, cfg)


def format_rows(rows: Sequence[AlertRow], missed: Sequence[str]) -> list[str]:
    def f(v: float | None, spec: str = ".0f") -> str:
        return "-" if v is None else format(v, spec)

    out = [
        f"{'tracks':>9} {'ships':>7} {'raised s':>8} {'cleared s':>9} {'CPA m':>6} {'TCPA s':>6} "
        f"{'true CPA m':>10} {'at s':>5} {'lead s':>6} {'false':>5}"
    ]
    for r in rows:
        ships = "/".join("-" if s is None else str(s) for s in r.ships)
        out.append(
            f"{r.tracks[0]:>4}/{r.tracks[1]:<4} {ships:>7} {r.raised_s:>8.0f} {f(r.cleared_s):>9} "
            f"{f(r.cpa_at_raise_m):>6} {f(r.tcpa_at_raise_s):>6} {f(r.true_cpa_m):>10} "
            f"{f(r.true_cpa_s):>5} {f(r.lead_s):>6} {'yes' if r.false else 'no':>5}"
        )
    n_missed = sum(m.startswith("missed") for m in missed)
    out.append(f"close-quarters alerts {len(rows)}, false {sum(r.false for r in rows)}, missed {n_missed}")
    out += list(missed)
    return out
