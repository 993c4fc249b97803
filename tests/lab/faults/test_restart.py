"""The restart fault cases (lab.faults.restart) under pytest, on a recording this session renders
once (the golden suite's two-ships-crossing clip, looped at full speed)."""

from __future__ import annotations

from pathlib import Path

import pytest

from lab.faults.matrix import failures, run_case
from lab.faults.restart import CASES


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_restart_case(case, tmp_path: Path, recording, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MAST_FAULTS_RECORDING", str(recording("two-ships-crossing", 60)))
    rows = run_case(case, tmp_path)
    failed = failures(rows)
    assert not failed, "\n".join(failed)
