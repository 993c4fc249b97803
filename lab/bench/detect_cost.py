"""Cost of one detection pass at 2048 x 1536, both detectors, against StereoBM in the same run.

    .venv/bin/python tools/bench-detect-cost [--repeat R] [--decimation N]

A synthetic sea (sky over a sea whose wave texture grows toward the camera, sparkles of glitter,
a few hulls, 2 DN noise) at 2048 x 1536 through an ideal camera rolled by 0.5 degree; each detector
(edge.measure.detect.Detector, "rowband"; edge.measure.seadetect.SeaDetector, "seaclutter", and its
candidate stage alone, the verifier off: the difference is the features and the verifier) as the
pipeline builds it (decimation 2, min_ship_px 20) runs R times, alternating, with OpenCV on one
thread; OpenCV StereoBM (15 x 15 SAD, 128 disparities) on the same image pair at full resolution
runs beside them. Prints the median process CPU time per call and the ratio to StereoBM.
The budget for a detection pass is 5 ms at this size (issue 24).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse
import sys
import time
from collections.abc import Callable
from functools import partial

import cv2
import numpy as np

from edge.core.camera import PinholeCamera, StereoRig
from edge.core.rectify import Rectifier
from edge.measure.detect import Detector
from edge.measure.seadetect import SeaDetector
from lab.bench.common import table

WIDTH, HEIGHT, F_PX = 2048, 1536, 2400.0


def sea_image(det: Detector, rng: np.random.Generator) -> np.ndarray:
    rows = np.arange(HEIGHT, dtype=np.float32)[:, None] - det.horizon_raw[None, :].astype(np.float32)
    below = np.clip(rows, 0.0, None)
    image = np.where(rows < 0, 170.0, 95.0 + 10.0 * np.exp(-below / 20.0)).astype(np.float32)
    noise = rng.normal(0.0, 1.0, (HEIGHT, WIDTH)).astype(np.float32)
    waves = cv2.GaussianBlur(noise, (0, 0), 6.0, sigmaY=1.2)
    image += np.where(rows < 0, 0.0, 0.02 * below * waves / waves.std())
    glitter = (rng.random((HEIGHT, WIDTH)) < 0.002) & (rows > 20)
    image[glitter] += 80.0
    for x0, length in ((300, 24), (900, 60), (1500, 140)):
        y = int(det.horizon_raw[x0]) + 40
        image[y - length // 6:y, x0:x0 + length] = 40.0
    image += rng.normal(0.0, 2.0, image.shape).astype(np.float32)
    return np.clip(image, 0, 255).astype(np.uint8)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--repeat", type=int, default=20)
    parser.add_argument("--decimation", type=int, default=2)
    args = parser.parse_args(argv)
    cv2.setNumThreads(1)
    cam = PinholeCamera(F_PX, F_PX, 0.5 * (WIDTH - 1), 0.5 * (HEIGHT - 1), rotation_deg=(0.0, 0.0, 0.5))
    rect = Rectifier(StereoRig(1.0, WIDTH, HEIGHT, cam, cam))
    dets = {"rowband": Detector(rect, 20.0, decimation=args.decimation, min_ship_px=20),
            "seaclutter": SeaDetector(rect, 20.0, decimation=args.decimation, min_ship_px=20),
            "  (candidates only)": SeaDetector(rect, 20.0, decimation=args.decimation, min_ship_px=20,
                                               verifier=None)}
    image = sea_image(dets["rowband"], np.random.default_rng(0))
    right = np.roll(image, -8, axis=1)
    bm = cv2.StereoBM_create(numDisparities=128, blockSize=15)  # type: ignore[attr-defined]  # not in cv2's stubs
    calls: dict[str, Callable[[], object]] = {k: partial(d.detect, image) for k, d in dets.items()}
    calls["StereoBM"] = partial(bm.compute, image, right)
    times: dict[str, list[float]] = {k: [] for k in calls}
    found = {k: len(d.detect(image)) for k, d in dets.items()}
    for rep in range(args.repeat):
        for name in (list(calls) if rep % 2 == 0 else list(calls)[::-1]):
            t0 = time.process_time()
            calls[name]()
            times[name].append(1e3 * (time.process_time() - t0))
    bm_ms = float(np.median(times["StereoBM"]))
    rows = [[name, f"{float(np.median(t)):.2f}", f"{float(np.median(t)) / bm_ms:.3f}",
             str(found.get(name, "-"))] for name, t in times.items()]
    print(f"{WIDTH}x{HEIGHT}, decimation {args.decimation}, {args.repeat} calls each, one thread")
    print(table(["call", "ms (median)", "/ StereoBM", "blobs"], rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
