"""TrackTable: box overlap, the sea/ship slope test on synthetic planes, ids and the Q -> T lifecycle
on a rendered recording."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from drivers.camera.replay import ReplaySource
from edge.core.camera import PinholeCamera, StereoRig
from edge.core.rectify import Rectifier
from edge.fix import TrackStatus
from edge.pipeline import Pipeline
from edge.replay import recording_calibration
from edge.tracking import TableSettings, TrackTable, _overlap
from edge.trackpoint import Designs, PointSettings, TrackPoint

W, H, F, B, HEIGHT = 400, 300, 900.0, 8.0, 25.0


def test_overlap_is_a_column_iou_for_boxes_in_the_same_rows() -> None:
    a = np.array([10.0, 100.0, 50.0, 110.0])
    assert _overlap(a, a) == pytest.approx(1.0)
    b = np.array([30.0, 98.0, 70.0, 112.0])
    assert _overlap(a, b) == pytest.approx(20 / 60) == pytest.approx(_overlap(b, a))
    assert _overlap(a, a + [0, 40, 0, 40]) == 0.0  # far below: another ship
    assert _overlap(a, a + [45, 0, 45, 0]) == 0.0  # no common column


def _pair(disparity_of_row) -> tuple[np.ndarray, np.ndarray]:
    """Textured left image and a right image shifted row by row by disparity_of_row(v)."""
    rng = np.random.default_rng(3)
    tex = 128 + 50 * cv2.GaussianBlur(rng.normal(0, 1, (H, W + 80)), (0, 0), 1.0)
    tex = tex[:, 40:W + 40].astype(np.float32)
    vv, uu = np.mgrid[0:H, 0:W].astype(np.float32)
    d = np.array([disparity_of_row(v) for v in range(H)], np.float32)[:, None]
    right = cv2.remap(tex, uu + d, vv, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
    to8 = lambda a: np.clip(np.round(a), 0, 255).astype(np.uint8)  # noqa: E731
    return to8(tex), to8(right)


@pytest.mark.parametrize("sea", [True, False])
def test_slope_tells_the_sea_from_a_ship_side(sea: bool) -> None:
    """The sea's disparity grows by L_B / h per row below the horizon (flat-sea approximation,
    exact enough here); a vertical hull keeps one disparity."""
    cam = PinholeCamera(F, F, (W - 1) / 2, (H - 1) / 2)
    rect = Rectifier(StereoRig(B, W, H, cam, cam))
    horizon = (H - 1) / 2 + F * 0.0028
    left, right = _pair((lambda v: max(0.0, B * (v - horizon) / HEIGHT)) if sea else (lambda v: 14.0))
    s = PointSettings(fps=10.0, max_disparity=64, baseline_m=B, focal_px=F)
    table = TrackTable(rect, HEIGHT, s, TableSettings())
    point = TrackPoint(200.0, 200.0, s, Designs(s))
    point.step(left, right, rect)
    slope = table._slope(point, left, right)
    assert slope is not None
    if sea:
        assert slope == pytest.approx(B / HEIGHT, rel=0.15)
    else:
        assert abs(slope) < 0.02


def test_ids_are_never_reused_and_q_needs_confirmations(recording) -> None:
    path = recording("akashi-crossing", 30)
    with ReplaySource(path) as src:
        pairs, meta = list(src), src.meta
    pipe = Pipeline(recording_calibration(path, meta), fps=meta["fps"])
    seen_ids: list[int] = []
    first_t: dict[int, float] = {}
    born: dict[int, float] = {}
    for pair in pairs:
        pipe.step(pair)
        for t in pipe.table.tracks:
            if t.id not in born:
                born[t.id] = pair.t_ns / 1e9
                assert not seen_ids or t.id > max(seen_ids)  # fresh ids only, increasing
                seen_ids.append(t.id)
            if t.status is TrackStatus.TRACKING and t.id not in first_t:
                first_t[t.id] = pair.t_ns / 1e9
    assert len(set(seen_ids)) == len(seen_ids) == pipe.table.births
    period = pipe.cfg.detect_every / meta["fps"]
    assert first_t, "the freighter must become T"
    for tid, t in first_t.items():  # confirm_n detection passes, the birth being the first
        assert t - born[tid] >= (pipe.table.s.confirm_n - 1) * period - 1e-9
