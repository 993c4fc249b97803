"""tools/evaluate on a short real recording: exit status 0 when every pair was processed, 1 (with the
reason on stderr) when the pipeline abandoned pairs, since its figures then are not the pipeline's."""

from __future__ import annotations

from pathlib import Path

import pytest

import lab.evaluate.report as report
from edge.measure.tracks import TrackTable


def _evaluate():
    return report


@pytest.fixture(scope="module")
def short_recording(recording) -> Path:
    return recording("akashi-crossing", 6)


def test_exit_status_says_whether_every_pair_was_processed(short_recording: Path, monkeypatch,
                                                           capsys) -> None:
    evaluate = _evaluate()
    assert evaluate.main([str(short_recording), "--no-stages"]) == 0
    assert "abandoned" not in capsys.readouterr().err

    def boom(*_args, **_kwargs):
        raise RuntimeError("injected")

    monkeypatch.setattr(TrackTable, "step", boom)
    assert evaluate.main([str(short_recording), "--no-stages"]) == 1
    assert "6 pairs abandoned by the product pipeline" in capsys.readouterr().err
