"""The input fault cases (lab.faults.inputs) under pytest: configuration and calibration fuzzing with
real `mast-stereo run`/`check-config` subprocesses, and damaged recordings through `mast-stereo
replay`. Every row must pass. Sizes are cut for the suite's time budget: the fuzzing runs fewer
mutations (tests/edge/config/test_fuzzing.py adds hypothesis over the same mutator) and the clean
recording is the one tests/edge/test_replay.py renders (rendering is the slow part)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from functools import partial
from pathlib import Path

import pytest

from lab.faults import _recording, inputs
from lab.faults.matrix import Case, run_case


@pytest.mark.parametrize("case", inputs.CASES, ids=lambda c: c.name)
def test_input_fault_case(case: Case, tmp_path: Path, recording: Callable[..., Path]) -> None:
    if case.name == "recording-damage":  # the recording tests/edge/test_replay.py renders: rendered once
        clean = recording("akashi-crossing", _recording.FRAMES)
        case = replace(case, run=partial(_recording.recording_damage, clean=clean))
    elif case.name == "config-fuzz":
        case = replace(case, run=partial(inputs.config_fuzz, mutations=40, blobs=10))
    rows = run_case(case, tmp_path)
    for row in rows:
        assert not row.skipped and row.passed, f"{row.fault}: expected {row.expected}; got {row.observed}"
