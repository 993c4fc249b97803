"""The input fault cases (edge.faults.inputs) under pytest: configuration and calibration fuzzing with
real `mast-stereo run`/`check-config` subprocesses, and damaged recordings through `mast-stereo
replay`. Every row must pass (nothing here needs more than Python, the package and its config/)."""

from __future__ import annotations

from pathlib import Path

import pytest

from edge.faults import inputs
from edge.faults.matrix import Case, run_case


@pytest.mark.parametrize("case", inputs.CASES, ids=lambda c: c.name)
def test_input_fault_case(case: Case, tmp_path: Path) -> None:
    rows = run_case(case, tmp_path)
    for row in rows:
        assert not row.skipped and row.passed, f"{row.fault}: expected {row.expected}; got {row.observed}"
