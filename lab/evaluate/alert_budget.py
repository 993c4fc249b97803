"""What alerts cost a slow NMEA line: the real scheduler and alert sentences at a baud rate, timed.

    .venv/bin/python tools/alert-budget [--baud 4800] [--tracks 1 10 30] [--seconds 120]

For each number of T tracks (all born at t = 0, stepping 10 times a second, a pair of them on a
close-quarters course raised at t = 65 s once the start's new-target alerts have ended) it runs
`NmeaScheduler` with `PortAlerts` inside the line's byte budget (90 % of baud / 10) and prints:
the share of the line the alert sentences took, when the first track update went out (the new
target ALFs and the ALC list of the start go first), how long the close-quarters ALF waited after
its raise, and the track updates per second with alerts against without.
"""

from __future__ import annotations

import argparse

from edge.alerts.manager import AlertManager
from edge.alerts.port import PortAlerts
from edge.config.alerts import AlertsConfig
from edge.fix import ShipFix, TrackStatus
from edge.outputs.nmea_serial import serial_bytes_per_s
from edge.outputs.schedule import NmeaSchedule, NmeaScheduler

T0_NS = 1_790_000_000_000_000_000
COV = (25.0, 0, 0, 0, 0, 25.0, 0, 0, 0, 0, 0.01, 0, 0, 0, 0, 0.01)
RAISE_FROM_S = 60.0  # the closing pair gets its motion here (raised confirm_s later)


def _fix(track_id: int, t_s: float) -> ShipFix:
    en = None
    if track_id in (1, 2) and t_s >= RAISE_FROM_S:
        e, n, vn = (0.0, 0.0, 3.0) if track_id == 1 else (100.0, 1800.0, -3.0)
        en = (e, n + vn * t_s, 0.0, vn)
    return ShipFix(T0_NS + round(t_s * 1e9), track_id, TrackStatus.TRACKING, 0.0, 0.0, 1000.0 + track_id,
                   1000.0, float(track_id), 34.6, 135.0, 5.0, 0.0, 10.0, 5.0, length_m=80.0, en_state=en,
                   en_cov=None if en is None else COV)


def run(tracks: int, baud: int, seconds: float, alerts: bool) -> dict[str, float | None]:
    now = [0.0]
    budget = 0.9 * serial_bytes_per_s(baud)
    sched = NmeaScheduler(NmeaSchedule(), budget, clock=lambda: now[0])
    cfg = AlertsConfig(enabled=True)
    manager = AlertManager(cfg, 99)
    if alerts:
        sched.alerts = PortAlerts(manager, cfg)
    first_track = raised = cq_sent = None
    for k in range(int(seconds * 10)):
        t = k / 10
        now[0] = t
        fixes = [_fix(i, t) for i in range(1, tracks + 1)]
        before = manager.sequence
        manager.step(fixes, T0_NS + round(t * 1e9))
        if raised is None and any(a.alert_id == 191 for _, a in manager.changes_since(before)):
            raised = t
        sent_before = sched.stats().groups_sent
        lines = [line for g in sched.step(fixes) for line in g]
        if first_track is None and sched.stats().groups_sent > sent_before:
            first_track = t
        if cq_sent is None and any(",191," in line or ",191,A," in line for line in lines):
            cq_sent = t
    total = sched.stats().bytes_sent + sched.alert_bytes_sent
    return {"alert_share": sched.alert_bytes_sent / total if total else 0.0, "first_track_s": first_track,
            "cq_wait_s": None if raised is None or cq_sent is None else cq_sent - raised,
            "updates_per_s": sched.stats().groups_sent / seconds}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baud", type=int, default=4800)
    parser.add_argument("--tracks", type=int, nargs="+", default=[2, 10, 30])
    parser.add_argument("--seconds", type=float, default=120.0)
    args = parser.parse_args(argv)
    print(f"{args.baud} baud, {args.seconds:.0f} s, 10 steps/s; close quarters raised at "
          f"{RAISE_FROM_S + AlertsConfig().confirm_s:.0f} s")
    print(f"{'tracks':>6} {'alert share':>11} {'1st track s':>11} {'CPA ALF wait s':>14} "
          f"{'updates/s':>9} {'without alerts':>14}")
    for n in args.tracks:
        r, plain = run(n, args.baud, args.seconds, True), run(n, args.baud, args.seconds, False)
        wait = "-" if r["cq_wait_s"] is None else f"{r['cq_wait_s']:.1f}"
        print(f"{n:>6} {100 * (r['alert_share'] or 0):>10.1f}% {r['first_track_s']:>11.1f} {wait:>14} "
              f"{r['updates_per_s']:>9.2f} {plain['updates_per_s']:>14.2f}")
    return 0
