"""The maintenance page's fault case (lab.faults.page) under pytest: 2,000 garbage HTTP connections
against a real daemon replaying the session's recording; the pair rate stays within 10 %, the page
answers during and after, the flood is refused and counted. Every row must pass."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from lab.faults import page
from lab.faults.matrix import failures


def test_http_garbage_flood(tmp_path: Path, recording: Callable[..., Path]) -> None:
    rows = page.http_garbage_flood(tmp_path, recording("akashi-crossing", 30))
    assert len(rows) == 3
    assert not failures(rows), failures(rows)
