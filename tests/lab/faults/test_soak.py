"""The short soak (lab.faults.soak's CASES): a few thousand pairs of a looped clip at full speed,
the accounting (computed = emitted + dropped per output), flat threads and fds, no track id or
NMEA target number reused; the RSS bound needs the long run of tools/soak."""

from __future__ import annotations

from pathlib import Path

import pytest

from lab.faults.matrix import failures, run_case
from lab.faults.soak import CASES


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_soak_case(case, tmp_path: Path, recording, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MAST_FAULTS_RECORDING", str(recording("two-ships-crossing", 60)))
    rows = run_case(case, tmp_path)
    failed = failures(rows)
    assert not failed, "\n".join(failed)
    assert len(rows) >= 8
