"""The output fault cases (lab.faults.outputs) under pytest: serial port gone and back, a reader that
stops reading, hostile Modbus clients. Every row must pass, or be skipped for a reason that only holds
on a machine lacking something (socat)."""

from __future__ import annotations

from pathlib import Path

import pytest

from lab.faults import outputs
from lab.faults.matrix import Case, run_case

ALLOWED_SKIPS = ("socat not installed",)


@pytest.mark.parametrize("case", outputs.CASES, ids=lambda c: c.name)
def test_output_fault_case(case: Case, tmp_path: Path) -> None:
    rows = run_case(case, tmp_path)
    for row in rows:
        if row.skipped:
            assert row.skipped.startswith(ALLOWED_SKIPS), row
        else:
            assert row.passed, f"{row.fault}: expected {row.expected}; observed {row.observed}"
