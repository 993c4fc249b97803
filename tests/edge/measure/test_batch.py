"""step_points (all tracks' follows and matches batched) gives every point exactly the state that
TrackPoint.step (per point, the reference) gives it, pair after pair, searching included."""

from __future__ import annotations

import numpy as np
from helpers import band_texture, shifted_u8

from edge.core.camera import PinholeCamera, StereoRig
from edge.core.rectify import Rectifier
from edge.measure.batch import step_points
from edge.measure.filter_designs import Designs
from edge.measure.point import TrackPoint
from edge.measure.settings import PointSettings

W, H = 320, 160
STATE = ("u", "v", "disparity", "rate_pxps", "sigma_px", "raw_disparity", "searching", "followed",
         "u_filtered", "u_rate_pxps", "accepted", "noise_px")


def _state(p: TrackPoint) -> tuple:
    return tuple(getattr(p, name) for name in STATE) + (repr(p.match),)


def test_batched_steps_equal_per_point_steps() -> None:
    cam = PinholeCamera(900.0, 900.0, (W - 1) / 2, (H - 1) / 2)
    rect = Rectifier(StereoRig(8.0, W, H, cam, cam))
    s = PointSettings(fps=10.0, window=15, max_disparity=40, baseline_m=8.0, focal_px=900.0)
    tex = band_texture(21, H, W + 60)
    starts = [(60.0 + 37.0 * k, 30.0 + 19.0 * (k % 5)) for k in range(6)] + [(9.0, 80.0), (150.0, 80.0)]
    designs = Designs(s)
    solo = [TrackPoint(u, v, s, designs) for u, v in starts]
    batch = [TrackPoint(u, v, s, Designs(s)) for u, v in starts]
    rng = np.random.default_rng(3)
    searched = jumped = 0
    for k in range(46):
        d = 16.0 if 18 <= k < 32 else 10.0              # a jump the filters refuse (searching), then back
        left = shifted_u8(tex, 0.4 * k)[:, 30:W + 30]
        right = shifted_u8(tex, 0.4 * k - d)[:, 30:W + 30]
        left = np.clip(left + rng.normal(0, 1, left.shape), 0, 255).astype(np.uint8)
        right = np.clip(right + rng.normal(0, 1, right.shape), 0, 255).astype(np.uint8)
        skipped = 1 if k == 10 else 0

        def offers(p: TrackPoint) -> list[tuple[float, float]]:
            return [(p.u + 7.0, p.v), (p.u - 9.0, p.v + 3.0)]

        alive_solo = [p.step(left, right, rect, skipped, lambda p=p: offers(p)) for p in solo]
        alive_batch = step_points([p.steps(left, right, rect, skipped, lambda p=p: offers(p)) for p in batch])
        assert alive_solo == alive_batch
        assert [_state(p) for p in solo] == [_state(p) for p in batch]
        searched += sum(p.searching for p in solo)
        jumped += sum(p.jumped != (0.0, 0.0) for p in solo)
    assert searched > 0 and jumped > 0
    assert sum(p.disparity is not None for p in solo) >= 4
