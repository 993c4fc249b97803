"""pipeline.alias_check and pipeline.depth_check (issue 16) in the real pipeline: they only add
variance. The same points, disparities and positions as without them, each fix's sigma at least as
large, and the terms they add are the track's own window disagreements (edge.measure.aliascheck,
edge.measure.depthcheck)."""

from __future__ import annotations

import math

import pytest

from drivers.camera.replay import ReplaySource
from edge.config.app import ExperimentalConfig, PipelineConfig
from edge.config.calibration import recording_calibration
from edge.pipeline import Pipeline

FRAMES = 30  # the same recording as tests/edge/test_pipeline.py (rendered once per session)


@pytest.mark.parametrize("check", ["alias", "depth"])
def test_the_check_widens_sigma_and_changes_nothing_else(recording, check: str) -> None:
    path = recording("akashi-crossing", FRAMES)
    with ReplaySource(path) as src:
        meta, pairs = src.meta, list(src)
    runs = {}
    for on in (False, True):
        cfg = PipelineConfig(experimental=ExperimentalConfig(**{f"{check}_check": on}))
        pipe = Pipeline(recording_calibration(path, meta), cfg, fps=meta["fps"])
        runs[on] = [fix for pair in pairs for fix in pipe.step(pair)]
        if on:
            terms = [getattr(t.point, f"{check}_sigma_px") for t in pipe.table.tracks]
            checked = [len(t.point.alias.deltas) if check == "alias" else min(map(len, t.point.depth.deltas))
                       for t in pipe.table.tracks]
    off, on_ = runs[False], runs[True]
    assert len(off) == len(on_) > 0
    for a, b in zip(off, on_, strict=True):
        assert (a.track_id, a.disparity_px, a.range_m, a.bearing_deg) == \
            (b.track_id, b.disparity_px, b.range_m, b.bearing_deg)
        assert b.sigma_m >= a.sigma_m or (math.isinf(a.sigma_m) and math.isinf(b.sigma_m))
    assert max(checked) >= 3  # the check ran on every measured pair of a track
    assert all(t >= 0.0 for t in terms)
