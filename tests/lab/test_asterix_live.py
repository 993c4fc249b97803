"""The live run of `tools/asterix-check --live` (lab.asterix_live), 15 s of it: the daemon as its own
process on a looped recording, ASTERIX to a UDP receiver on loopback, every datagram the daemon
says it sent received, and tshark dissecting each one with none Malformed."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from lab.asterix_live import live_run


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed (tools/_setup.sh)")
def test_a_short_live_run_is_received_whole_and_decoded_by_tshark(recording, tmp_path: Path) -> None:
    run = live_run(15.0, recording("akashi-crossing", 30), tmp_path)
    assert run.exit_code == 0 and run.pairs > 0
    assert run.datagrams_sent > 0 and run.received == run.datagrams_sent == run.tshark.packets
    assert run.tshark.malformed == 0 and not run.tshark.error
    assert run.categories[10] > 0 and run.categories[34] > 0  # target reports and status, CAT 034 too
    assert run.tshark.message_types[1] > 0 and run.tshark.message_types[3] > 0
    assert run.tshark.tre == len(run.tshark.numbers)  # each track ends once: at its drop or the stop
    assert run.passed
