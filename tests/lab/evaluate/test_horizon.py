"""tools/horizon-offset on a short simulated recording (rendered with exactly the calibration it
states): the image horizon lies below the sea horizon (the haze hides the far sea, it never shows
sea above the horizon), and a pitch error given to the calibration moves the measured offset by
the predicted horizon's shift."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import lab.evaluate.horizon as horizon
from edge.measure.detect import HORIZON_BANDS

FRAMES = 30  # 6 detection passes
ERROR_DEG = 0.05


@pytest.fixture(scope="module")
def short_recording(recording) -> Path:
    return recording("akashi-crossing", FRAMES)


def test_the_offset_follows_a_pitch_error_and_is_below_the_sea_horizon(short_recording: Path,
                                                                        capsys) -> None:
    tool = horizon
    exact = tool.measure(short_recording)
    wrong = tool.measure(short_recording, ERROR_DEG)
    assert exact["shift_px"] == 0.0
    f_px = 914.0  # the recording's left camera (akashi-pinhole: fx 913.9, fy 914.6)
    assert abs(wrong["shift_px"]) == pytest.approx(f_px * math.tan(math.radians(ERROR_DEG)), rel=0.1)
    # the same images, the same edge found: the offsets differ by the prediction's shift alone
    moved = np.nanmedian(wrong["offset_px"]) - np.nanmedian(exact["offset_px"])
    assert moved == pytest.approx(wrong["shift_px"], abs=0.15)
    assert np.nanmedian(exact["offset_px"]) > 0.2  # fog at 25 m height: the sea horizon (19 km) is unseen
    assert np.all(exact["found"] <= HORIZON_BANDS)
    assert tool.main([str(short_recording), "--pitch-error-deg", str(ERROR_DEG)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3 and lines[1].split()[0] == short_recording.name
