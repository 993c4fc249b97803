"""lab/faults/cameras.py's cases against the running daemon on fake V4L2 cameras: every row passes."""

from __future__ import annotations

from pathlib import Path

import pytest

from lab.faults import cameras
from lab.faults.matrix import Case, failures, run_case


@pytest.mark.parametrize("case", [c for c in cameras.CASES if not c.slow], ids=lambda c: c.name)
def test_every_row_passes(case: Case, tmp_path: Path) -> None:
    rows = run_case(case, tmp_path)
    failed = failures(rows)
    assert not failed, failed
    assert all(r.passed for r in rows), [r.skipped for r in rows]  # nothing here may be skipped
