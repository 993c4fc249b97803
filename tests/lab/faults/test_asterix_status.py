"""lab/faults/asterix_status.py's cases against the running daemon on fake V4L2 cameras, with a UDP
receiver on loopback as the VTS: a camera unplugged sets I010/550 NOGO in the next status message
and the replug clears it; an unsynchronised clock sets TSV and its return clears it. Every row passes."""

from __future__ import annotations

from pathlib import Path

import pytest

from lab.faults import asterix_status
from lab.faults.matrix import Case, failures, run_case

pytest.importorskip("asterix")  # asterix-decoder decodes what the receiver got (test extra)


@pytest.mark.parametrize("case", asterix_status.CASES, ids=lambda c: c.name)
def test_every_row_passes(case: Case, tmp_path: Path) -> None:
    rows = run_case(case, tmp_path)
    assert not failures(rows), failures(rows)
    assert len(rows) == 2 and all(r.passed and not r.skipped for r in rows)
