"""lab.evaluate.alerts: lead time against the truth's own CPA, false alerts, the nearest bound."""

from __future__ import annotations

import numpy as np

from edge.fix import ShipFix, TrackStatus
from lab.evaluate.alerts import evaluate_alerts, format_rows, true_pair_cpa

COV = (25.0, 0, 0, 0, 0, 25.0, 0, 0, 0, 0, 0.01, 0, 0, 0, 0, 0.01)


def scene(offset_m: float) -> tuple[dict[int, list[ShipFix]], dict[int, np.ndarray]]:
    """Two ships head-on, `offset_m` apart across, closing at 6 m/s: CPA at t = 300 s. World x is
    east and z north here (the fixes' x_m/z_m carry the same numbers as en_state)."""
    truth: dict[int, list[tuple[float, ...]]] = {1: [], 2: []}
    fixes: dict[int, list[ShipFix]] = {}
    for t in range(0, 400):
        t_ns = t * 10**9
        row = []
        for sid, (e, n, vn) in {1: (0.0, 0.0, 3.0), 2: (offset_m, 1800.0, -3.0)}.items():
            north = n + vn * t
            truth[sid].append((t_ns, e, 0.0, north))
            row.append(ShipFix(t_ns, 10 + sid, TrackStatus.TRACKING, e, 0.0, north, 1000.0, 0.0, 34.6, 135.0,
                               5.8, 0.0, 10.0, 5.0, length_m=80.0, en_state=(e, north, 0.0, vn), en_cov=COV))
        fixes[t_ns] = row
    return fixes, {k: np.array(v) for k, v in truth.items()}


def test_lead_time_and_clear_against_the_truth() -> None:
    fixes, truth = scene(100.0)
    assert true_pair_cpa(truth, 1, 2) == (100.0, 300 * 10**9)
    rows, notes = evaluate_alerts(fixes, truth)
    (row,) = rows
    assert row.ships == (1, 2) and not row.false
    assert row.raised_s == 5.0 and row.lead_s == 295.0 and row.cleared_s == 316.0
    assert "least CPA + 2 sigma" in notes[-1]
    assert format_rows(rows, notes)[-2].startswith("close-quarters alerts 1, false 0, missed 0")


def test_a_wide_pass_raises_nothing() -> None:
    fixes, truth = scene(1000.0)
    rows, notes = evaluate_alerts(fixes, truth)
    assert rows == [] and not any(n.startswith("missed") for n in notes)
