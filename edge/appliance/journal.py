"""Logging for the daemon: structured journal records under systemd, readable lines elsewhere,
and faults logged once when they start and once when they clear.

Under systemd, stderr is connected to the journal and $JOURNAL_STREAM holds its device and inode;
when they match stderr, records go to the journal through systemd-python's `JournalHandler`, so
fields passed as `extra` (`STAGE`, `FAULT`, `DEVICE`, `TRACK_ID`, `MESSAGE_ID`) become journal
fields a technician can filter on (`journalctl -u mast-stereo STAGE=camera_left`). Elsewhere
(a terminal, the demo, tests) a plain formatter writes one line per record to stderr.

`FaultLog` watches the health snapshots and logs each stage's fault as it starts and as it
clears, with a MESSAGE_ID per fault kind, so a camera that stays unplugged for a week is two
journal entries, not six million; it counts the starts per stage and kind (/metrics).
"""

from __future__ import annotations

import logging
import os
import sys
from collections import Counter
from typing import TextIO

from edge.appliance.health import HealthSnapshot

IDENTIFIER = "mast-stereo"
# journal MESSAGE_IDs (128-bit, `systemd-id128 new`), one per kind of event
MESSAGE_IDS = {
    "no_heartbeat": "3f1c6a2e9b7d4e0a8c5b1d2f4a6e8c01",
    "fault": "7a2d4c6e8f0b4a1c9e3d5f7b9a1c3e02",
    "cleared": "c4e6a8b0d2f44e6a8c0e2a4c6e8a0c03",
    "reload": "5b7d9f1a3c5e4b7d9f1a3c5e7b9d1f04",
    "reload_refused": "9e1b3d5f7a9c4e1b3d5f7a9c1e3b5d05",
    "state_lost": "2d8f0b4e6a1c4d3f8b5e7a9c0d2f4b06",  # appliance.state: the state file missing or corrupt
}


def journal_stream_is_stderr(stream: TextIO | None = None) -> bool:
    """True when $JOURNAL_STREAM names the device:inode of stderr (systemd.exec(5))."""
    value = os.environ.get("JOURNAL_STREAM", "")
    try:
        dev, ino = (int(part) for part in value.split(":"))
        st = os.fstat((stream or sys.stderr).fileno())
    except (ValueError, OSError, AttributeError):
        return False
    return (st.st_dev, st.st_ino) == (dev, ino)


def setup_logging(level: str, stream: TextIO | None = None) -> bool:
    """Configure the root logger; returns True when records go to the journal."""
    root = logging.getLogger()
    for handler in list(root.handlers):
        root.removeHandler(handler)
    root.setLevel(level)
    if journal_stream_is_stderr(stream):
        from systemd.journal import JournalHandler  # only under systemd

        root.addHandler(JournalHandler(SYSLOG_IDENTIFIER=IDENTIFIER))
        return True
    handler = logging.StreamHandler(stream or sys.stderr)
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    root.addHandler(handler)
    return False


class FaultLog:
    """Logs each health stage's problem once as it starts and once as it clears."""

    def __init__(self, logger: logging.Logger) -> None:
        self.log = logger
        self._active: dict[str, str] = {}  # stage -> the problem logged for it
        self.started: Counter[tuple[str, str]] = Counter()  # (stage, kind) -> faults begun (/metrics)

    def observe(self, snapshot: HealthSnapshot) -> None:
        for stage in snapshot.stages:
            if stage.age_s is None:
                continue  # never beat yet: starting up, not a fault to log
            problem = stage.fault if stage.fresh else f"no heartbeat for {stage.age_s:.1f} s"
            kind = "fault" if stage.fresh else "no_heartbeat"
            before = self._active.get(stage.name)
            if problem is not None and before is None:
                self._active[stage.name] = problem
                self.started[stage.name, kind] += 1
                self.log.error("%s: %s", stage.name, problem,
                               extra={"STAGE": stage.name, "FAULT": problem, "MESSAGE_ID": MESSAGE_IDS[kind]})
            elif problem is None and before is not None:
                del self._active[stage.name]
                fields = {"STAGE": stage.name, "FAULT": before, "MESSAGE_ID": MESSAGE_IDS["cleared"]}
                self.log.info("%s: recovered (was: %s)", stage.name, before, extra=fields)

    @property
    def active(self) -> dict[str, str]:
        return dict(self._active)
