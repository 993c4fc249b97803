"""Cost and output of ship detection alone on recordings, against another revision's detector.

    .venv/bin/python tools/bench-detect RECORDING... [--baseline REV] [--frames N] [--repeat R]

Loads edge/detect.py from this tree and from git revision REV (default `main`), builds
both detectors for each recording's calibration and site (decimation and minimum ship
length as the pipeline's defaults), and runs them on the same N left images spread over
the recording, alternating which goes first, R times, in one process with OpenCV on one
thread. Prints per recording the median process CPU time per
call of each, their ratio, and the blobs per call each found. Images are read outside the
timed calls; each detector keeps its own horizon state, as in the pipeline.
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from edge.config.app import PipelineConfig
from edge.config.calibration import recording_calibration
from edge.core.rectify import Rectifier
from edge.replay import open_recording

ROOT = Path(__file__).resolve().parents[2]
DETECT_PATHS = ("edge/measure/detect.py", "edge/detect.py")  # this tree; revisions before the house


def load_module(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None  # a .py file
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def _baseline_source(revision: str) -> str:
    """The detector's source at a git revision, wherever it lived then."""
    for path in DETECT_PATHS:
        shown = subprocess.run(["git", "-C", str(ROOT), "show", f"{revision}:{path}"], capture_output=True,
                               text=True)
        if shown.returncode == 0:
            return shown.stdout
    raise SystemExit(f"bench-detect: no detector at revision {revision!r} ({' or '.join(DETECT_PATHS)})")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recordings", nargs="+", type=Path, metavar="RECORDING")
    parser.add_argument("--baseline", default="main", help="git revision of the detector to compare with")
    parser.add_argument("--frames", type=int, default=40)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    cv2.setNumThreads(1)
    source = _baseline_source(args.baseline)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "detect_baseline.py"
        path.write_text(source)
        baseline = load_module("detect_baseline", path)
    current = load_module("detect_current", ROOT / DETECT_PATHS[0])
    cfg = PipelineConfig()
    print(f"{'recording':20s} {'size':>9s} {args.baseline[:10]:>10s} {'this tree':>10s} {'ratio':>6s}"
          f" {'blobs/call':>10s} {'blobs/call':>10s}")
    print(f"{'':20s} {'':>9s} {'ms/call':>10s} {'ms/call':>10s} {'':>6s} {args.baseline[:10]:>10s}"
          f" {'this tree':>10s}")
    for root in args.recordings:
        src = open_recording(root)
        cal = recording_calibration(root, src.meta)
        rect = Rectifier(cal.rig)
        assert cal.site is not None  # the recordings benched state their site
        detectors = [m.Detector(rect, cal.site.height_m, decimation=cfg.detect_decimation,
                                min_ship_px=cfg.min_ship_px) for m in (baseline, current)]
        n = len(src)
        picks = np.linspace(0, n - 1, min(args.frames, n)).astype(int)
        images = [cv2.imread(str(root / "left" / f"{k:06d}.png"), cv2.IMREAD_GRAYSCALE) for k in picks]
        images = [img for img in images if img is not None]
        times: list[list[float]] = [[], []]
        blobs = [0, 0]
        for rep in range(args.repeat):
            for image in images:
                for j in ((0, 1) if rep % 2 == 0 else (1, 0)):
                    t0 = time.process_time()
                    found = detectors[j].detect(image)
                    times[j].append(time.process_time() - t0)
                    blobs[j] += len(found)
        calls = len(images) * args.repeat
        b_ms, c_ms = (1e3 * float(np.median(t)) for t in times)
        assert images[0] is not None  # unreadable images were dropped
        h, w = images[0].shape
        print(f"{root.name:20s} {w:4d}x{h:<4d} {b_ms:10.2f} {c_ms:10.2f} {c_ms / b_ms:6.2f}"
              f" {blobs[0] / calls:10.2f} {blobs[1] / calls:10.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
