"""Speed of the pipeline per pair, against a dense StereoBM baseline measured in the same run.

    .venv/bin/python tools/bench [--sizes 720,2048] [--tracks 1,8,32] [--frames 40] [--cache DIR] [--stages]
                                 [--subpixel METHOD]

For each image size (the thesis rig at 720x480 and in 2048x1536 photo mode) and each
number of ships (1, 8, 32) it renders a short scene once with the simulator (tugs laid out
in rows of range so that the detector sees each as a blob of its own, see `layout`; cached
in --cache (default out/bench)), then, in a fresh child process with OpenCV and the BLAS on
one thread:

- pipeline: `Pipeline.step` per pair (detection every k-th pair included), after a warm-up
  in which the ships are found and confirmed; median, p99 and mean per pair, and the live
  tracks;
- baseline: what a dense pipeline would do for the same fixes: rectify both full images
  (the same remap tables), cv2.StereoBM (15 x 15 SAD, 128 disparities) over the whole pair,
  and sample its disparity at the tracks' points; median per pair;
- the ratio baseline / pipeline, and the child's peak RSS.

--stages adds a second table from an extra run per scene with wrappers around the main
stages (detection, association, the batched follows and matches with the compiled kernels' share,
or on the NumPy path their batched sub-pixel fits and per-point remainder, patch rectification, the
disparity filter, the fixes with the ground-plane filter's share): mean CPU ms per pair.

Images are read from disk outside the timed sections. Times are the child's CPU time
(time.process_time: all threads, one here), not wall time: on a machine shared with other
work the wall clock also counts the time the child waits for a core, which is not the
pipeline's cost (on an idle machine the two agree). Prints one table; the cost per track is
the slope of the median against the live tracks (cost grows linearly if it is flat).
--subpixel runs the pipeline with another sub-pixel method than its default (what a method
costs in the pipeline, e.g. the opt-in "refit").
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import lab.subpix  # noqa: F401  (registers the research sub-pixel methods, "refit")
from edge.measure.settings import SUBPIXELS, PointSettings

ROOT = Path(__file__).resolve().parents[2]  # the checkout: config/ and out/

# per image width: the tugs' length in the image (px, above the detector's 20 px minimum), and
# the rows of the layout: the bottom of the nearest row (px below the horizon) and the clear rows
# left between one row's top and the next row's bottom
LAYOUT = {720: (22.0, 34.0, 8.0), 2048: (40.0, 56.0, 12.0)}
SHIP_KIND = "tug"
SPACING = 1.8  # centre to centre, in ship lengths, along a row (the gap is well beyond the detector's merge)
ROW_SHARE = 0.95  # of the image width
WARMUP_PAIRS = 15


def _calibration(size: int) -> dict:
    from edge.config.schema import load_yaml

    if size == 720:
        return load_yaml(ROOT / "config/calibration/akashi-pinhole.yaml")
    return load_yaml(ROOT / "config/scenarios/approach-2048.yaml")["calibration"]


def layout(size: int, count: int) -> list[dict]:
    """`count` tugs, each the same length in the image, in rows of range from near to far, so that
    the detector sees every one as a blob of its own: the rows are clear of each other vertically
    (flat-sea estimate: a waterline at range z sits h f / z below the horizon) and alternate rows are
    shifted by half a spacing."""
    from edge.config.calibration import calibration_from_dict
    from edge.sim.ships import ShipModel

    cal = calibration_from_dict(_calibration(size), "bench")
    assert cal.site is not None  # the bench scenario states its site
    f, width, h = cal.rig.focal_px(), cal.rig.width, cal.site.height_m
    length_px, bottom_px, gap_px = LAYOUT[size]
    height_share = float(ShipModel.build(SHIP_KIND, 20.0).extent_local[1, 2]) / 20.0  # top / length
    per_row = int((ROW_SHARE * width) // (SPACING * length_px))
    ships: list[dict] = []
    row = 0
    while len(ships) < count and bottom_px > length_px * height_share + 1.0:
        z = h * f / bottom_px
        ship_m = length_px * z / f
        half_width_m = 0.5 * ROW_SHARE * width / f * z
        for k in range(per_row if row % 2 == 0 else per_row - 1):
            if len(ships) == count:
                break
            x = -half_width_m + (k + 0.5 + 0.5 * (row % 2)) * 2 * half_width_m / per_row
            ships.append({"id": len(ships) + 1, "kind": SHIP_KIND, "length_m": round(ship_m, 2),
                          "motion": 0.5,
                          "track": {"waypoints_m": [[x, z], [x + 200.0, z]], "speed_kn": [4.0]}})
        bottom_px -= length_px * height_share * 1.3 + gap_px   # up past this row (masts: margin), a gap
        row += 1
    return ships


def render(size: int, count: int, frames: int, cache: Path) -> Path:
    out = cache / f"{size}-{count}"
    if (out / "frames.csv").is_file():
        return out
    from edge.sim.render_recording import default_jobs, write_recording
    from edge.sim.scenario import scenario_from_dict
    from edge.sim.simulator import Simulation

    data: dict[str, Any] = {"calibration": _calibration(size), "fps": 10, "duration_s": frames / 10 + 0.05,
            "atmosphere": {"visibility_m": 20000}, "ships": layout(size, count)}
    sim = Simulation(scenario_from_dict(data, cache / "bench.yaml", f"bench-{size}-{count}"), seed=1)
    print(f"rendering {out} ({len(data['ships'])} ships, {frames} pairs) ...", file=sys.stderr)
    write_recording(sim, out, frames=frames, jobs=default_jobs(), overwrite=True)
    return out


def child(recording: Path, subpixel: str) -> dict:
    """Time the pipeline and the baseline on one recording (one thread); JSON to stdout."""
    import cv2
    import numpy as np

    cv2.setNumThreads(1)
    from drivers.camera.replay import ReplaySource
    from edge.config.app import PipelineConfig
    from edge.config.calibration import recording_calibration
    from edge.pipeline import Pipeline

    source = ReplaySource(recording)
    cal = recording_calibration(recording, source.meta)
    pipe = Pipeline(cal, PipelineConfig(), fps=float(source.meta["fps"]), subpixel=subpixel)
    rect = pipe.rect
    bm = cv2.StereoBM_create(numDisparities=128, blockSize=15)  # type: ignore[attr-defined]  # not in cv2's stubs
    times, base, live = [], [], []
    for k, pair in enumerate(source):
        t0 = time.process_time()
        pipe.step(pair)
        t1 = time.process_time()
        tracks = [(t.point.u, t.point.v) for t in pipe.table.tracks]
        t2 = time.process_time()  # baseline: rectify the whole pair, dense disparity, sample at the tracks
        w, h = cal.rig.width, cal.rig.height
        left, right = rect.patch(pair.left, 0, 0, 0, w, h), rect.patch(pair.right, 1, 0, 0, w, h)
        disparity = bm.compute(left, right)
        samples = [disparity[min(h - 1, max(0, round(v))), min(w - 1, max(0, round(u)))] / 16.0
                   for u, v in tracks]
        t3 = time.process_time()
        del samples
        if k >= WARMUP_PAIRS:
            times.append(t1 - t0)
            base.append(t3 - t2)
            live.append(len(tracks))
    ms = np.array(times) * 1e3
    return {"pairs": len(ms), "median_ms": float(np.median(ms)), "p99_ms": float(np.percentile(ms, 99)),
            "mean_ms": float(ms.mean()), "baseline_ms": float(np.median(base) * 1e3),
            "tracks": float(np.median(live)),
            "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


STAGES = (  # (label, object path, attribute): where a pair's time goes (--stages)
    ("detect", "pipe.detector", "detect"),
    ("associate", "pipe.table", "_associate"),
    ("follow+match", "edge.measure.batch", "answer_all"),
    # the compiled kernels (native/: integer search, gates and sub-pixel fit; absent without them) ...
    ("  match (C)", "mast_native", "match"),
    ("  follow (C)", "mast_native", "follow"),
    # ... and the NumPy path's parts (0 while the kernels run)
    ("  match finish", "edge.core.batchmatch", "finish_match"),  # gates, the Match (and per-point refine)
    ("  match sub-pixel", "edge.core.batchmatch", "_refine_gauss"),  # the batched Gaussian cancellation
    ("  follow finish", "edge.core.batchmatch", "finish_follow"),
    ("  follow sub-pixel", "edge.core.batchmatch", "_axis_fits"),  # the batched parabola fits
    ("patches", "edge.core.rectify.Rectifier", "patch"),
    ("filter", "edge.measure.point.TrackPoint", "_filter"),
    ("fixes", "pipe", "_fixes"),
    ("  ground filter", "edge.measure.groundtrack.GroundTracks", "step"),
)


def stages_child(recording: Path, subpixel: str) -> dict:
    """CPU time per pair in each of STAGES (mean over the timed pairs; stages nest, so they do not add
    up) and in the whole step, from wrappers around those functions (a run of its own: the wrappers
    cost time)."""
    import importlib

    import cv2

    cv2.setNumThreads(1)
    from drivers.camera.replay import ReplaySource
    from edge.config.app import PipelineConfig
    from edge.config.calibration import recording_calibration
    from edge.pipeline import Pipeline

    source = ReplaySource(recording)
    cal = recording_calibration(recording, source.meta)
    pipe = Pipeline(cal, PipelineConfig(), fps=float(source.meta["fps"]), subpixel=subpixel)
    spent = dict.fromkeys([label for label, _, _ in STAGES], 0.0)
    timed = [False]

    def wrapped(label: str, fn):  # noqa: ANN001, ANN202
        def run(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
            t0 = time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                if timed[0]:
                    spent[label] += time.process_time() - t0
        return run

    for label, where, name in STAGES:
        if where.startswith("pipe"):
            owner = pipe if where == "pipe" else getattr(pipe, where.split(".")[1])
        elif where[0].isupper() or where.split(".")[-1][0].isupper():
            module, cls = where.rsplit(".", 1)
            owner = getattr(importlib.import_module(module), cls)
        else:
            try:
                owner = importlib.import_module(where)
            except ImportError:  # the compiled kernels not installed: the row stays 0
                continue
        setattr(owner, name, wrapped(label, getattr(owner, name)))
    total, pairs = 0.0, 0
    for k, pair in enumerate(source):
        timed[0] = k >= WARMUP_PAIRS
        t0 = time.process_time()
        pipe.step(pair)
        if timed[0]:
            total += time.process_time() - t0
            pairs += 1
    return {"step": total / pairs * 1e3, **{label: v / pairs * 1e3 for label, v in spent.items()},
            "tracks": len(pipe.table.tracks)}


SIZES = (720, 2048)  # image widths with a calibration (`_calibration`)


def _counts(text: str, allowed: tuple[int, ...] | None = None) -> list[int]:
    """A comma-separated list of positive integers (of `allowed` if given), for argparse."""
    try:
        values = [int(part) for part in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}") from None
    bad = [v for v in values if v < 1 or (allowed is not None and v not in allowed)]
    if bad:
        raise argparse.ArgumentTypeError(f"{bad[0]} is not one of {allowed}" if allowed
                                         else f"{bad[0]} is not a positive integer")
    return values


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=lambda t: _counts(t, SIZES), default=list(SIZES),
                        help="image widths, comma-separated: 720 (720x480) and/or 2048 (2048x1536)")
    parser.add_argument("--tracks", type=_counts, default=[1, 8, 32],
                        help="ships laid out per scene, comma-separated")
    parser.add_argument("--frames", type=int, default=40)
    parser.add_argument("--cache", type=Path, default=ROOT / "out" / "bench")
    parser.add_argument("--stages", action="store_true",
                        help="also show where a pair's time goes (mean CPU ms per pair by stage, extra runs)")
    parser.add_argument("--subpixel", choices=SUBPIXELS + ("refit",), default=PointSettings.subpixel,
                        help="the pipeline's sub-pixel method (default %(default)s)")
    parser.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--stages-child", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child is not None:
        print(json.dumps(child(args.child, args.subpixel)))
        return 0
    if args.stages_child is not None:
        print(json.dumps(stages_child(args.stages_child, args.subpixel)))
        return 0
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    rows, stage_rows = [], []
    for size in args.sizes:
        for count in args.tracks:
            rec = render(size, count, args.frames, args.cache)
            out = subprocess.run([sys.executable, "-m", "lab.bench.pipeline", "--child", str(rec),
                                  "--subpixel", args.subpixel],
                                 env=env, check=True, capture_output=True, text=True).stdout
            rows.append((size, count, json.loads(out)))
            if args.stages:
                out = subprocess.run([sys.executable, "-m", "lab.bench.pipeline", "--stages-child", str(rec),
                                      "--subpixel", args.subpixel], env=env,
                                     check=True, capture_output=True, text=True).stdout
                stage_rows.append((size, count, json.loads(out)))
    print(f"{'size':>10} {'ships':>5} {'tracks':>6} {'median ms':>9} {'p99 ms':>7} {'mean ms':>7} "
          f"{'StereoBM ms':>11} {'ratio':>6} {'RSS MB':>7}")
    for size, count, r in rows:
        wh = "720x480" if size == 720 else "2048x1536"
        print(f"{wh:>10} {count:>5} {r['tracks']:>6.0f} {r['median_ms']:>9.2f} {r['p99_ms']:>7.2f} "
              f"{r['mean_ms']:>7.2f} {r['baseline_ms']:>11.1f} {r['baseline_ms'] / r['median_ms']:>5.0f}x "
              f"{r['rss_mb']:>7.0f}")
    for size in sorted({s for s, _, _ in rows}):
        pts = [(r["tracks"], r["median_ms"]) for s, _, r in rows if s == size]
        if len(pts) >= 2 and pts[-1][0] != pts[0][0]:
            slope = (pts[-1][1] - pts[0][1]) / (pts[-1][0] - pts[0][0])
            print(f"{size}: {slope:.3f} ms per additional track "
                  f"(median, {pts[0][0]:.0f} -> {pts[-1][0]:.0f} tracks)")
    if stage_rows:
        labels = ["step"] + [label for label, _, _ in STAGES]
        print("\nwhere the time goes: mean CPU ms per pair (timed pairs, detection pairs included; nested)")
        print(f"{'stage':<20}" + "".join(f"{f'{s}/{n}':>11}" for s, n, _ in stage_rows))
        for label in labels:
            print(f"{label:<20}" + "".join(f"{r[label]:>11.2f}" for _, _, r in stage_rows))
    return 0 if all(math.isfinite(r["median_ms"]) for _, _, r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
