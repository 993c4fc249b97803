"""The fault matrix's own machinery: discovery, a failing case reported as a row, exit status."""

from __future__ import annotations

from pathlib import Path

import pytest

from lab.faults import matrix
from lab.faults.matrix import Case, Row


def test_a_case_that_raises_is_a_fail_row_not_a_crash(tmp_path: Path) -> None:
    def boom(_: Path) -> list[Row]:
        raise RuntimeError("stage exploded")

    rows = matrix.run_case(Case("boom", "test", boom), tmp_path)
    assert [r.verdict for r in rows] == ["FAIL"] and "stage exploded" in rows[0].observed


def test_exit_status_counts_fail_rows_and_ignores_skips(monkeypatch: pytest.MonkeyPatch,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    cases = [Case("a", "g", lambda _: [Row("f1", "e", "o", True, 0.5), Row("f2", "e", "o", False)]),
             Case("b", "g", lambda _: [Row("f3", "e", "o", False, skipped="no VM here")])]
    monkeypatch.setattr(matrix, "all_cases", lambda: cases)
    assert matrix.main([]) == 1
    out = capsys.readouterr().out.splitlines()
    assert [line.split()[-1] if "PASS" not in line else "PASS" for line in out[1:]][0] == "PASS"
    assert sum("FAIL" in line for line in out) == 1 and sum("SKIP" in line for line in out) == 1
    assert matrix.main(["--only", "nope"]) == 2


def test_every_case_module_is_discovered_and_names_are_unique() -> None:
    names = [c.name for c in matrix.all_cases()]
    assert len(names) == len(set(names))
