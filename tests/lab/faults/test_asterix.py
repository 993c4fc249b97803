"""The ASTERIX network fault case (lab.faults.asterix) under pytest: the outgoing interface down and
back, no route and then one, in a private network namespace. Every row must pass, or be skipped
because this machine allows no unprivileged network namespace."""

from __future__ import annotations

from pathlib import Path

from lab.faults import asterix
from lab.faults.matrix import run_case

ALLOWED_SKIPS = ("no private network namespace here", "unshare or ip not installed")


def test_asterix_network_faults(tmp_path: Path) -> None:
    (case,) = asterix.CASES
    rows = run_case(case, tmp_path)
    assert len(rows) == 2
    for row in rows:
        if row.skipped:
            assert row.skipped.startswith(ALLOWED_SKIPS), row
        else:
            assert row.passed, f"{row.fault}: expected {row.expected}; observed {row.observed}"
