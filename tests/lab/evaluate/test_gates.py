"""tools/track-gates on a short simulated recording: every pair a track spends acquiring is charged to
exactly one gate, so a track that turned T was held for exactly its time from birth to T."""

from __future__ import annotations

from pathlib import Path

import pytest

import lab.evaluate.gates as gates

FRAMES = 14  # the freighter of akashi-crossing turns T about 1 s (10 pairs) after its birth


@pytest.fixture(scope="module")
def short_recording(recording) -> Path:
    return recording("akashi-crossing", FRAMES)


def test_acquiring_time_is_charged_to_the_gates(short_recording: Path, capsys) -> None:
    tool = gates
    info = tool.run(short_recording, set(), None)
    fps = 10.0
    turned = [rec for rec in info.values() if rec["T"] is not None]
    assert turned, "the freighter should turn T within the recording"
    for rec in info.values():
        charged = sum(rec["gates"].values())
        end = rec["T"] if rec["T"] is not None else rec["dropped"]
        if end is None:  # still acquiring at the end: charged for every pair since birth
            end = (FRAMES - 1) / fps + 1.0 / fps
        assert charged == pytest.approx(end - rec["born"], abs=0.5 / fps)
        assert rec["gates"].get("passed", 0.0) <= 1.0 / fps + 1e-9  # all gates passed: T next pair at most
    assert tool.main([str(short_recording), "--tracks", "1", "--pairs", "0", "1"]) == 0
    out = capsys.readouterr().out
    assert "id1" in out and "track" in out


def test_a_track_id_typo_is_an_argparse_error(capsys) -> None:
    with pytest.raises(SystemExit) as stop:
        gates.main(["/nonexistent", "--tracks", "2x"])
    assert stop.value.code == 2 and "--tracks" in capsys.readouterr().err
