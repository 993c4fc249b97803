"""lab/faults/lifecycle.py's cases against the running daemon: every row passes, or is skipped only
for what this machine lacks (root for the tmpfs; the appliance VM for the slow systemd case, which
tests/vm runs in its own single boot)."""

from __future__ import annotations

from pathlib import Path

import pytest

from lab.faults import lifecycle
from lab.faults.matrix import Case, failures, run_case

MACHINE_LACKS = ("needs root to mount a tmpfs", "mount -t tmpfs failed here")


@pytest.mark.parametrize("case", [c for c in lifecycle.CASES if not c.slow], ids=lambda c: c.name)
def test_every_row_passes(case: Case, tmp_path: Path) -> None:
    rows = run_case(case, tmp_path)
    failed = failures(rows)
    assert not failed, failed
    assert all(r.passed or r.skipped in MACHINE_LACKS for r in rows), [r.skipped for r in rows]


def test_the_systemd_restart_row_points_at_the_vm_test() -> None:
    slow = [c for c in lifecycle.CASES if c.slow]
    assert [c.name for c in slow] == ["watchdog-restart"]
    assert "test_a_stopped_daemon_is_restarted_by_the_watchdog" in lifecycle.__doc__  # type: ignore[operator]
    vm_tests = (Path(__file__).resolve().parents[2] / "vm" / "test_systemd_vm.py").read_text()
    assert "def test_a_stopped_daemon_is_restarted_by_the_watchdog" in vm_tests
