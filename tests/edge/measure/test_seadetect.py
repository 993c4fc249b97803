"""SeaDetector on synthetic seas: a small dark hull in glitter is found where the row-band detector
misses it, glitter alone stays quiet, a tilted horizon gives nothing, and the search mask is honoured."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from edge.core.camera import PinholeCamera, StereoRig
from edge.core.rectify import Rectifier
from edge.measure.detect import Detector
from edge.measure.seadetect import SeaDetector

WIDTH, HEIGHT, F_PX = 960, 540, 1100.0


def _rect(roll_deg: float = 0.0) -> Rectifier:
    cam = PinholeCamera(F_PX, F_PX, 479.5, 269.5, rotation_deg=(0.0, 0.0, roll_deg))
    return Rectifier(StereoRig(1.0, WIDTH, HEIGHT, cam, cam))


def _sea(det: Detector, rng: np.random.Generator, glitter: float = 0.004) -> np.ndarray:
    rows = np.arange(HEIGHT, dtype=np.float64)[:, None] - det.horizon_raw[None, :]
    below = np.clip(rows, 0.0, None)
    image = np.where(rows < 0, 175.0, 100.0 + 8.0 * np.exp(-below / 10.0))
    waves = cv2.GaussianBlur(rng.normal(0.0, 1.0, (HEIGHT, WIDTH)), (0, 0), 5.0, sigmaY=1.0)
    image += np.where(rows < 0, 0.0, 0.03 * below * waves / waves.std())
    sparkle = (rng.random((HEIGHT, WIDTH)) < glitter) & (rows > 4)
    image[sparkle] += 90.0
    image = cv2.GaussianBlur(image, (0, 0), 0.7) + rng.normal(0.0, 1.5, image.shape)
    return np.clip(np.round(image), 0, 255).astype(np.uint8)


def _hull(image: np.ndarray, det: Detector, x0: int, length: int, height: int,
          below_px: int = 30) -> np.ndarray:
    out = image.copy()
    bottom = int(round(det.horizon_raw[x0])) + below_px
    out[bottom - height:bottom, x0:x0 + length] = 45
    return out


@pytest.mark.parametrize("roll_deg", [0.0, 1.5])
def test_a_small_dark_hull_in_glitter_is_found(roll_deg: float) -> None:
    rng = np.random.default_rng(7)
    det = SeaDetector(_rect(roll_deg), 20.0, decimation=1, min_ship_px=8)
    image = _hull(_sea(det, rng), det, 400, 14, 5)
    found = det.detect(image)
    assert any(b.x0 <= 410 and b.x1 >= 404 for b in found), found


def test_glitter_and_waves_alone_give_fewer_blobs_than_the_rowband_detector() -> None:
    # not zero: single-frame detection cannot tell every whitecap from a white boat (the temporal
    # confirmation does); at most 2 per 960 x 540 frame here, and fewer than the row-band detector
    for roll in (0.0, 1.5):
        rng = np.random.default_rng(11)
        new = SeaDetector(_rect(roll), 20.0, decimation=1, min_ship_px=8)
        old = Detector(_rect(roll), 20.0, decimation=1, min_ship_px=8)
        images = [_sea(new, rng) for _ in range(3)]
        counts = [len(new.detect(img)) for img in images]
        assert max(counts) <= 2, counts
        assert sum(counts) < sum(len(old.detect(img)) for img in images)


def test_the_search_mask_is_honoured() -> None:
    rng = np.random.default_rng(5)
    det = SeaDetector(_rect(), 20.0, decimation=1, min_ship_px=8)
    image = _hull(_sea(det, rng), det, 400, 30, 8)
    assert any(b.x0 <= 410 and b.x1 >= 420 for b in det.detect(image))
    mask = np.ones_like(image, dtype=bool)
    mask[:, 380:460] = False
    assert not any(b.x0 <= 410 and b.x1 >= 420 for b in det.detect(image, search_mask=mask))
    with pytest.raises(ValueError):
        det.detect(image, search_mask=np.ones((4, 4), bool))


def test_nothing_in_the_sky() -> None:
    rng = np.random.default_rng(9)
    det = SeaDetector(_rect(), 20.0, decimation=1, min_ship_px=8)
    image = _sea(det, rng, glitter=0.0)
    y = int(det.horizon_raw[200]) - 60
    image[y - 6:y, 200:240] = 60  # a dark cloud or a bird above the horizon
    assert not any(b.y1 < det.horizon_raw[220] - 10 for b in det.detect(image))


def test_the_stored_verifier_matches_the_features_and_a_bad_file_is_named(tmp_path) -> None:
    from edge.core.shipfeatures import FEATURES
    from edge.measure.seadetect import load_verifier

    model = load_verifier()
    assert model.names == FEATURES
    bad = tmp_path / "v.yaml"
    bad.write_text("bias: 0\nthreshold: 0\nfeatures: {a: {edges: [], table: [0]}}\n")
    with pytest.raises(ValueError, match="v.yaml: features"):
        load_verifier(bad)


def test_detect_reports_the_verified_candidates() -> None:
    from edge.core.shipfeatures import N_FEATURES

    rng = np.random.default_rng(5)
    loose = SeaDetector(_rect(), 20.0, decimation=1, min_ship_px=8, verifier=None)
    image = _hull(_sea(loose, rng), loose, 400, 14, 5)
    blobs, feats = loose.candidates(image)
    assert feats.shape == (len(blobs), N_FEATURES)
    verified = SeaDetector(_rect(), 20.0, decimation=1, min_ship_px=8)  # fresh: the same horizon
    assert verified.verifier is not None
    keep = verified.verifier.verified(feats)
    found = verified.detect(image)
    assert set(found) <= {b for b, k in zip(blobs, keep, strict=True) if k}
