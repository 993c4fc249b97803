"""lab.evaluate.diagnose: the window scan's table (mean and RMS per range bin and leg)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import lab.evaluate.diagnose as ed


def _probe(range_m: float, receding: bool, scan: tuple[float, ...]) -> ed.Probe:
    return ed.Probe(range_m, "decks", 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 21, receding=receding, scan_px=scan)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.floats(0.0, 4999.0), st.booleans(),
                          st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4)), min_size=1, max_size=30))
def test_scan_table_gives_each_bin_and_legs_mean_and_rms(rows) -> None:
    """One line per (bin, leg) that has probes, with their count and, per scanned window, the mean and
    RMS of the finite values (a nan, an invalid match, is left out)."""
    probes = [_probe(r, rec, tuple(math.nan if abs(v) > 0.9 else v for v in scan)) for r, rec, scan in rows]
    lines = ed.scan_table(probes)
    assert len(ed.SCAN_WINDOWS) == 4 and all(f"win {w}" in lines[0] for w in ed.SCAN_WINDOWS)
    groups = {(int(p.range_m // 1000), p.receding) for p in probes}
    assert len(lines) == 1 + len(groups)
    for line in lines[1:]:
        km, _, leg, n = line.split()[:4]
        lo = int(km.split("-")[0])
        mine = [p for p in probes if int(p.range_m // 1000) == lo and p.receding == (leg == "receding")]
        assert int(n) == len(mine)
        x = np.array([p.scan_px for p in mine])
        cells = line.split()[4:]
        k = 0
        for j in range(4):
            col = x[np.isfinite(x[:, j]), j]
            if not col.size:
                assert cells[k] == "-"
                k += 1
                continue
            printed = 5e-4 + 1e-9  # 3 decimals
            assert abs(float(cells[k]) - np.mean(col)) <= printed
            assert abs(float(cells[k + 1].strip("()")) - math.sqrt(np.mean(col**2))) <= printed
            k += 2
