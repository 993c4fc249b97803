"""Detection: the horizon from the dip through the camera model, the crossing ship found where its
truth projects, nothing in the sky, and the sea range of a pixel consistent with geo."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drivers.camera.replay import ReplaySource
from edge.config.calibration import recording_calibration
from edge.core.camera import PinholeCamera, StereoRig
from edge.core.geo import horizon_dip_rad, sea_range_m
from edge.core.rectify import Rectifier
from edge.measure.detect import Detector, sea_range_at
from edge.recording.format import read_truth


def test_predicted_horizon_is_the_dip_cone_through_an_ideal_camera() -> None:
    cam = PinholeCamera(900.0, 900.0, 359.5, 239.5)
    det = Detector(Rectifier(StereoRig(8.0, 720, 480, cam, cam)), 25.0)
    t = math.tan(horizon_dip_rad(25.0))
    for u in (0, 200, 359, 719):
        x = (u - 359.5) / 900.0
        assert det.horizon_raw[u] == pytest.approx(239.5 + 900.0 * t * math.sqrt(1 + x * x), abs=0.01)


def test_sea_range_of_a_pixel_matches_geo() -> None:
    cam = PinholeCamera(900.0, 900.0, 359.5, 239.5)
    rect = Rectifier(StereoRig(8.0, 720, 480, cam, cam))
    for u, v in ((359.5, 300.0), (10.0, 260.0), (700.0, 400.0)):
        x, y = (u - 359.5) / 900.0, (v - 239.5) / 900.0
        expected = float(sea_range_m(math.atan2(y, math.hypot(1.0, x)), 25.0))
        assert sea_range_at(rect, 25.0, u, v) == pytest.approx(expected)
    assert math.isinf(sea_range_at(rect, 25.0, 359.5, 200.0))  # above the horizon


@pytest.fixture(scope="module")
def akashi(recording):
    path = recording("akashi-crossing", 30)
    with ReplaySource(path) as src:
        pairs = list(src)
        meta = src.meta
    return path, pairs, recording_calibration(path, meta)


def test_the_crossing_ship_is_detected_where_its_bridge_projects(akashi) -> None:
    path, pairs, cal = akashi
    det = Detector(Rectifier(cal.rig), cal.site.height_m, decimation=2, min_ship_px=20)
    truth = read_truth(path)[1]  # the 150 m freighter
    for k in (0, 10, 20):
        uv = cal.rig.project(truth[k, 1:4])[0]
        blobs = det.detect(pairs[k].left)
        hits = [b for b in blobs if b.x0 <= uv[0] < b.x1 and b.y0 - 3 <= uv[1] < b.y1]
        assert len(hits) == 1, (k, uv, blobs)
        assert hits[0].width >= 0.7 * 150 * cal.rig.focal_px() / np.linalg.norm(truth[k, [1, 3]])


def test_nothing_is_detected_in_the_sky(recording) -> None:
    path = recording("akashi-crossing", 25, edit="no-ships")
    with ReplaySource(path) as src:
        pairs = list(src)
        cal = recording_calibration(path, src.meta)
    det = Detector(Rectifier(cal.rig), cal.site.height_m)
    for pair in pairs[::5]:
        for blob in det.detect(pair.left):
            horizon = float(np.median(det.horizon_raw[blob.x0:blob.x1]))
            assert blob.y1 >= horizon - 4, blob  # everything found sits on the sea
