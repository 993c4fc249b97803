"""journal: the journal handler exactly when $JOURNAL_STREAM is stderr; faults logged once as they
start and once as they clear, with their stage and MESSAGE_ID as structured fields."""

from __future__ import annotations

import logging
import os
from pathlib import Path

import pytest

from edge.appliance.health import HealthMonitor, standard_stages
from edge.appliance.journal import MESSAGE_IDS, FaultLog, journal_stream_is_stderr, setup_logging


class Clock:
    def __init__(self) -> None:
        self.t_s = 0.0

    def __call__(self) -> float:
        return self.t_s


def test_journal_stream_must_name_this_very_stream(tmp_path: Path, monkeypatch) -> None:
    with open(tmp_path / "stderr", "w") as stream, open(tmp_path / "other", "w") as other:
        st = os.fstat(stream.fileno())
        monkeypatch.setenv("JOURNAL_STREAM", f"{st.st_dev}:{st.st_ino}")
        assert journal_stream_is_stderr(stream) and not journal_stream_is_stderr(other)
        monkeypatch.setenv("JOURNAL_STREAM", "garbage")
        assert not journal_stream_is_stderr(stream)
        root = logging.getLogger()
        saved = list(root.handlers), root.level
        try:
            monkeypatch.setenv("JOURNAL_STREAM", f"{st.st_dev}:{st.st_ino}")
            assert setup_logging("INFO", stream)
            assert type(root.handlers[0]).__name__ == "JournalHandler"
            monkeypatch.delenv("JOURNAL_STREAM")
            assert not setup_logging("INFO", stream)
            assert isinstance(root.handlers[0], logging.StreamHandler)
        finally:
            root.handlers[:] = saved[0]
            root.setLevel(saved[1])


def test_a_fault_is_logged_once_when_it_starts_and_once_when_it_clears(caplog: pytest.LogCaptureFixture
                                                                       ) -> None:
    clock = Clock()
    health = HealthMonitor(standard_stages(), clock=clock)
    faults = FaultLog(logging.getLogger("test.faults"))
    caplog.set_level(logging.INFO, logger="test.faults")
    for step in range(50):  # a camera unplugged for 30 steps, then back
        clock.t_s = step * 0.1
        gone = 10 <= step < 40
        health.beat("camera_left", fault="device gone" if gone else None, frames=0 if gone else 1)
        health.beat("camera_right", frames=1)
        health.beat("processing", frames=1)
        faults.observe(health.snapshot())
    records = [r for r in caplog.records if getattr(r, "STAGE", None) == "camera_left"]
    assert [(r.levelno, r.MESSAGE_ID) for r in records] == [(logging.ERROR, MESSAGE_IDS["fault"]),
                                                           (logging.INFO, MESSAGE_IDS["cleared"])]
    assert records[0].FAULT == "device gone" and not faults.active
    clock.t_s += 5.0  # everything silent: stuck code is a no-heartbeat fault, logged once per stage
    faults.observe(health.snapshot())
    faults.observe(health.snapshot())
    stale = [r for r in caplog.records if getattr(r, "MESSAGE_ID", None) == MESSAGE_IDS["no_heartbeat"]]
    assert sorted(r.STAGE for r in stale) == ["camera_left", "camera_right", "processing"]
