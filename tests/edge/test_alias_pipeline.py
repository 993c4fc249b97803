"""pipeline.alias_check (issue 16) in the real pipeline: it only adds variance. The same points,
disparities and positions as without it, each fix's sigma at least as large, and the term it adds
is the track's own window disagreement (edge.measure.aliascheck)."""

from __future__ import annotations

import math

from drivers.camera.replay import ReplaySource
from edge.config.app import PipelineConfig
from edge.config.calibration import recording_calibration
from edge.pipeline import Pipeline

FRAMES = 30  # the same recording as tests/edge/test_pipeline.py (rendered once per session)


def test_the_check_widens_sigma_and_changes_nothing_else(recording) -> None:
    path = recording("akashi-crossing", FRAMES)
    with ReplaySource(path) as src:
        meta, pairs = src.meta, list(src)
    runs = {}
    for on in (False, True):
        pipe = Pipeline(recording_calibration(path, meta), PipelineConfig(alias_check=on), fps=meta["fps"])
        runs[on] = [fix for pair in pairs for fix in pipe.step(pair)]
        if on:
            terms = [t.point.alias_sigma_px for t in pipe.table.tracks]
            checked = [len(t.point.alias.deltas) for t in pipe.table.tracks]
    off, on_ = runs[False], runs[True]
    assert len(off) == len(on_) > 0
    for a, b in zip(off, on_, strict=True):
        assert (a.track_id, a.disparity_px, a.range_m, a.bearing_deg) == \
            (b.track_id, b.disparity_px, b.range_m, b.bearing_deg)
        assert b.sigma_m >= a.sigma_m or (math.isinf(a.sigma_m) and math.isinf(b.sigma_m))
    assert max(checked) >= 3  # the check ran on every measured pair of a track
    assert all(t >= 0.0 for t in terms)
