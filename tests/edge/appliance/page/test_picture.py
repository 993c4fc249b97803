"""The live pictures of a running daemon: scaled to page.image_width, refreshed (a new number at most
image_hz a second, only while someone looks), the sea horizon drawn green where the calibration puts
it (the masks command's horizon, computed independently at full size)."""

from __future__ import annotations

import time

import cv2
import numpy as np

from edge.appliance.page.picture import HORIZON_BGR, STATUS_BGR
from edge.config.masks import sea_grid
from edge.core.masks import horizon_rows


def picture(running, side: str) -> np.ndarray:
    image = cv2.imdecode(np.frombuffer(running.get(f"/{side}.jpg"), np.uint8), cv2.IMREAD_COLOR)
    assert image is not None
    return image


def test_pictures_refresh_at_most_twice_a_second(running) -> None:
    pics = running.app.page.pictures
    pics.get("left")
    running.wait(lambda: bool(pics.latest))
    first, t0 = pics.seq, time.monotonic()
    while time.monotonic() - t0 < 3.0:
        pics.get("left")  # someone is looking
        time.sleep(0.1)
    made = pics.seq - first
    assert 3 <= made <= 7, made  # 2/s over 3 s, give or take one at each end
    assert pics.errors == 0


def test_overlay_horizon(running) -> None:
    app = running.app
    app.page.pictures.get("left")
    running.wait(lambda: bool(app.page.pictures.latest))
    left = picture(running, "left")
    rig = app.pipeline.rig
    assert left.shape == (round(rig.height * 640 / rig.width), 640, 3)
    scale = 640 / rig.width
    rows = horizon_rows(sea_grid(rig, app.pipeline.site))
    greenish = (left[..., 1] > 180) & (left[..., 0] < 140) & (left[..., 2] < 140)
    hits = 0
    for col in range(20, 620, 40):  # the green line lies within a pixel or two of the horizon
        row = (rows[int((col + 0.5) / scale)] + 0.5) * scale - 0.5
        lo, hi = int(row) - 2, int(row) + 3
        hits += bool(greenish[lo:hi, col].any())
    assert hits >= 12, hits
    assert HORIZON_BGR == (0, 255, 0) and STATUS_BGR  # the colours the docs name
    assert picture(running, "right").shape == left.shape
