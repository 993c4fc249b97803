"""`mast-stereo masks`: writes a real PNG of the frame with the excluded pixels tinted red, the polygon
outlined and the horizon drawn, read back here; a bad vertex is exit 78 before anything is drawn."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import yaml
from helpers import run_cli

from edge.config.calibration import load_calibration
from edge.core.geo import horizon_dip_rad
from edge.errors import EX_CONFIG

ROOT = Path(__file__).resolve().parents[3]
CALIBRATION = ROOT / "config/calibration/akashi-pinhole.yaml"


def _config(tmp_path: Path, masks: dict) -> Path:
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump({"calibration": str(CALIBRATION),
                                    "site": {"lat_deg": 34.63, "lon_deg": 135.02, "height_m": 25.0,
                                             "heading_deg": 180.0},
                                    "masks": masks}))
    return path


def test_masks_draws_the_polygons_and_the_horizon_over_the_frame(tmp_path: Path) -> None:
    frame = np.full((480, 720), 100, np.uint8)
    frame_path = tmp_path / "left.png"
    assert cv2.imwrite(str(frame_path), frame)
    config = _config(tmp_path, {"image": [{"name": "railing", "polygon": [[0, 420], [719, 420], [719, 479],
                                                                         [0, 479]]}]})
    out_path = tmp_path / "out" / "masks.png"
    out = run_cli("masks", "--config", config, "--frame", frame_path, "--out", out_path)
    assert out.returncode == 0, out.stderr
    assert "12.5 % of the image" in out.stdout  # 60 of 480 rows
    picture = cv2.imread(str(out_path), cv2.IMREAD_COLOR)
    assert picture is not None and picture.shape == (480, 720, 3)
    b, g, r = (picture[450, 360].astype(int)).tolist()  # inside the railing: tinted red
    assert r > 150 and g < 100 and b < 100
    assert picture[300, 360].tolist() == [100, 100, 100]  # open sea: the frame as it was
    # the horizon: where the ray's depression is the dip for 25 m, through the calibration's left camera
    left = load_calibration(CALIBRATION).rig.left
    u, v = left.normalised_to_pixel(np.array([0.0, math.tan(horizon_dip_rad(25.0))]))
    greenish = (picture[:, :, 1] > 200) & (picture[:, :, 0] < 100) & (picture[:, :, 2] < 100)
    rows = np.flatnonzero(greenish[:, int(round(u))])
    assert len(rows) and abs(rows.mean() - v) <= 1.5


def test_a_bad_vertex_is_exit_78_and_no_picture(tmp_path: Path) -> None:
    config = _config(tmp_path, {"image": [{"polygon": [[0, 0], [900, 0], [0, 100]]}]})
    out_path = tmp_path / "masks.png"
    out = run_cli("masks", "--config", config, "--out", out_path)
    assert out.returncode == EX_CONFIG and "masks.image[0].polygon[1]" in out.stderr
    assert not out_path.exists()
