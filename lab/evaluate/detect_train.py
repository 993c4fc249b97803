"""Fit the sea detector's verifier on annotated real cameras; leave-one-camera-out and held-out tables.

    .venv/bin/python tools/train-detect --images DIR [DIR...] [--labels PATH] --format yolo|coco|voc
        --vessel-classes C [C...] --geometry FILE.yaml --train-cameras A B C [--test-cameras D ...]
        [--cache DIR] [--write edge/measure/sea_verifier.yaml] [--fa-per-image 0.2]

The candidate stage of edge.measure.seadetect.SeaDetector (the loose CFAR, verifier off) runs on
every image of the named cameras, with the camera geometry of evaluate-detect
(lab/evaluate/detect_real.py: the same frames, horizons and sea masks). Each candidate is
labelled: a vessel (it touches a vessel box, as evaluate-detect scores a find), clutter (it
touches no annotated object) or neither (another annotated object: left out of the fit).

The verifier (edge.core.shipscore.AdditiveModel) is a logistic regression on bin indicators:
each feature is cut at the 1/BINS quantiles of the training candidates, one weight per bin, an
L2 penalty that also pulls neighbouring bins together (a smooth table). The threshold is the
lowest score at which the training cameras give at most `--fa-per-image` false alarms per image
on the sea (after the detector's suppression of contained boxes): it is chosen on the training
cameras only.

Printed:
  leave-one-camera-out: for each training camera, the model and threshold fitted on the others,
      scored on it (recall by box length, FA sea / img, as evaluate-detect prints them); the
      candidate stage alone (every candidate) on the line above
  held-out (--test-cameras): the model fitted on all training cameras, scored on each
With --write, the model fitted on all training cameras is stored (YAML, numbers only); the
command line that made it goes into the file's header.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse
import shlex
import sys
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import yaml

from edge.core.shipfeatures import FEATURES, N_FEATURES
from edge.core.shipscore import AdditiveModel, model_to_dict
from edge.measure.detect import Blob, Detector
from edge.measure.seadetect import SeaDetector, _suppress_contained
from lab.bench.common import table
from lab.evaluate.detect_real import (
    BINS,
    HEADERS,
    Box,
    _pct,
    bin_of,
    camera_frames,
    load_dataset,
    touches,
    waterline_on,
)

N_BINS = 6  # bins per feature (quantiles of the training candidates)
L2 = 2.0  # penalty on the weights (and on the difference of neighbouring bins)
FA_TARGET = 0.2  # false alarms per image on the sea the threshold allows on the training cameras


@dataclass
class ImageRecord:
    """The candidates of one image and what they touch."""

    boxes: np.ndarray  # (n, 4) candidate boxes, full-resolution px
    features: np.ndarray  # (n, F)
    on_sea: np.ndarray  # (n,) the candidate's waterline is on the sea (scoring mask)
    touch_any: np.ndarray  # (n,) touches some annotated object
    touch: np.ndarray  # (n, m) touches scored vessel m
    vessel_bins: np.ndarray  # (m,) length bin of each scored vessel
    touch_other: np.ndarray  # (n,) touches a vessel box that is not scored (off the sea)
    near_vessel: np.ndarray  # (n,) touches a vessel's reflection or wake zone (left out of the fit)

    @property
    def label(self) -> np.ndarray:
        """1 vessel, 0 clutter, -1 neither (another annotated object)."""
        vessel = self.touch_vessel
        return np.where(vessel, 1, np.where(self.touch_any | self.near_vessel, -1, 0))

    @property
    def touch_vessel(self) -> np.ndarray:
        return self.touch.any(axis=1) | self.touch_other


def collect(args: argparse.Namespace, cameras: list[str]) -> dict[str, list[ImageRecord]]:
    """Candidates of every image of the cameras (cached per camera in --cache when given)."""
    data = load_dataset(args)
    default, cams, ann, vessels, groups = data.default, data.cams, data.ann, data.vessels, data.groups
    out = {}
    for key in cameras:
        cache = args.cache / f"{key}.npz" if args.cache else None
        if cache is not None and cache.exists():
            out[key] = _load(cache)
            continue
        if key not in groups:
            raise SystemExit(f"train-detect: no annotated images of camera {key}")
        geo = cams.get(key, default)
        records = []
        kinds: dict[str, type[Detector]] = {"NEW": SeaDetector}
        for frame in camera_frames(groups[key], geo, args.decimation, args.min_ship_px, kinds,
                                   verifier=None):
            det = frame.detectors["NEW"]
            assert isinstance(det, SeaDetector)
            blobs, feats = det.candidates(frame.image, search_mask=frame.search)
            records.append(_record(blobs, feats, ann[frame.path], vessels, frame.mask))
        out[key] = records
        if cache is not None:
            cache.parent.mkdir(parents=True, exist_ok=True)
            _save(cache, records)
    return out


def _record(blobs: list[Blob], feats: np.ndarray, boxes: list[Box], vessels: set[str],
            mask: np.ndarray) -> ImageRecord:
    scored = [b for b in boxes if b.label in vessels and waterline_on(mask, b)]
    other_vessels = [b for b in boxes if b.label in vessels and not waterline_on(mask, b)]
    zones = [reflection_zone(b) for b in boxes if b.label in vessels]
    return ImageRecord(
        boxes=np.array([[b.x0, b.y0, b.x1, b.y1] for b in blobs], np.int64).reshape(-1, 4),
        features=feats.reshape(-1, N_FEATURES),
        on_sea=np.array([waterline_on(mask, b) for b in blobs], bool),
        touch_any=np.array([any(touches(b, x) for x in boxes) for b in blobs], bool),
        touch=np.array([[touches(b, x) for x in scored] for b in blobs], bool
                       ).reshape(len(blobs), len(scored)),
        vessel_bins=np.array([bin_of(x.length_px) for x in scored], np.int64),
        touch_other=np.array([any(touches(b, x) for x in other_vessels) for b in blobs], bool),
        near_vessel=np.array([any(touches(b, x) for x in zones) for b in blobs], bool))


def reflection_zone(box: Box) -> Box:
    """Where a vessel's reflection and wake lie: under its box, its height deep, half as wide again.
    A candidate there is neither the annotated vessel nor clutter: it is left out of the fit (it
    still counts as a false alarm when the detector reports it)."""
    w, h = box.x1 - box.x0, box.y1 - box.y0
    return Box(box.x0 - 0.25 * w, box.y1 - 0.5 * h, box.x1 + 0.25 * w, box.y1 + h, box.label)


def _save(path: Path, records: list[ImageRecord]) -> None:
    arrays = {}
    for i, r in enumerate(records):
        for name in ("boxes", "features", "on_sea", "touch_any", "touch", "vessel_bins", "touch_other",
                     "near_vessel"):
            arrays[f"{i}.{name}"] = getattr(r, name)
    np.savez_compressed(path, n=len(records), **arrays)


def _load(path: Path) -> list[ImageRecord]:
    data = np.load(path)
    out = []
    for i in range(int(data["n"])):
        names = ("boxes", "features", "on_sea", "touch_any", "touch", "vessel_bins", "touch_other",
                 "near_vessel")
        out.append(ImageRecord(*(data[f"{i}.{k}"] for k in names)))
    return out


# ----------------------------------------------------------------------------- fit
def bin_edges(x: np.ndarray, n_bins: int = N_BINS) -> list[np.ndarray]:
    """Per feature: the inner quantile edges (unique; a constant feature has none)."""
    qs = np.linspace(0, 1, n_bins + 1)[1:-1]
    return [np.unique(np.quantile(x[:, i], qs)) for i in range(x.shape[1])]


def design(x: np.ndarray, edges: list[np.ndarray]) -> tuple[np.ndarray, list[slice]]:
    """One-hot bin indicators of every feature side by side, and each feature's columns."""
    cols, slices, at = [], [], 0
    for i, e in enumerate(edges):
        b = np.searchsorted(e, x[:, i], side="right")
        onehot = np.zeros((len(x), len(e) + 1))
        onehot[np.arange(len(x)), b] = 1.0
        cols.append(onehot)
        slices.append(slice(at, at + len(e) + 1))
        at += len(e) + 1
    return np.hstack(cols), slices


def fit_logistic(z: np.ndarray, y: np.ndarray, penalty: np.ndarray, sample_w: np.ndarray,
                 iterations: int = 50) -> tuple[np.ndarray, float]:
    """Weights and bias minimising the weighted log-loss + 1/2 w' P w (Newton steps)."""
    n, d = z.shape
    a = np.hstack([z, np.ones((n, 1))])
    p_full = np.zeros((d + 1, d + 1))
    p_full[:d, :d] = penalty
    theta = np.zeros(d + 1)
    for _ in range(iterations):
        s = a @ theta
        p = 1.0 / (1.0 + np.exp(-np.clip(s, -30, 30)))
        grad = a.T @ (sample_w * (p - y)) + p_full @ theta
        hess = (a * (sample_w * p * (1 - p))[:, None]).T @ a + p_full + 1e-9 * np.eye(d + 1)
        step = np.linalg.solve(hess, grad)
        theta -= step
        if float(np.abs(step).max()) < 1e-7:
            break
    return theta[:d], float(theta[d])


def fit_model(records: list[ImageRecord], fa_target: float = FA_TARGET, n_bins: int = N_BINS,
              l2: float = L2) -> AdditiveModel:
    """The additive model on these images' labelled candidates, its threshold set for fa_target."""
    x = np.vstack([r.features for r in records])
    lab = np.concatenate([r.label for r in records])
    use = lab >= 0
    x, y = x[use], lab[use].astype(np.float64)
    edges = bin_edges(x, n_bins)
    z, slices = design(x, edges)
    # balance the classes: the positives' total weight equals the negatives'
    pos = max(1.0, float(y.sum()))
    neg = max(1.0, float(len(y) - y.sum()))
    sample_w = np.where(y > 0, 0.5 * len(y) / pos, 0.5 * len(y) / neg) / len(y) * 1000.0
    d = z.shape[1]
    penalty = l2 * np.eye(d) * 0.1
    for sl in slices:  # neighbouring bins of one feature pulled together (smooth tables)
        for j in range(sl.start, sl.stop - 1):
            diff = np.zeros(d)
            diff[j], diff[j + 1] = 1.0, -1.0
            penalty += l2 * np.outer(diff, diff)
    w, bias = fit_logistic(z, y, penalty, sample_w)
    tables = tuple(w[sl] for sl in slices)
    model = AdditiveModel(FEATURES, tuple(edges), tables, bias, 0.0)
    thr = choose_threshold(model, records, fa_target)
    return AdditiveModel(FEATURES, tuple(edges), tables, bias, thr)


# ----------------------------------------------------------------------------- scoring
@dataclass
class Result:
    found: np.ndarray
    total: np.ndarray
    fa_sea: int
    images: int


def evaluate(records: list[ImageRecord], keep: list[np.ndarray]) -> Result:
    """Recall by length bin and false alarms on the sea, as evaluate-detect scores them, for the
    candidates kept in each image (after the detector's suppression of contained boxes)."""
    found = np.zeros(len(BINS), int)
    total = np.zeros(len(BINS), int)
    fa = 0
    for r, k in zip(records, keep, strict=True):
        idx = np.flatnonzero(k)
        blobs = [Blob(int(r.boxes[i, 0]), int(r.boxes[i, 1]), int(r.boxes[i, 2]), int(r.boxes[i, 3]), 0, 0.0)
                 for i in idx]
        kept = _suppress_contained(blobs)
        ids = {id(b) for b in kept}
        sel = np.array([i for i, b in zip(idx, blobs, strict=True) if id(b) in ids], np.int64)
        np.add.at(total, r.vessel_bins, 1)
        if len(sel):
            hit = r.touch[sel].any(axis=0)
            np.add.at(found, r.vessel_bins[hit], 1)
            fa += int((~r.touch_any[sel] & r.on_sea[sel]).sum())
    return Result(found, total, fa, len(records))


def choose_threshold(model: AdditiveModel, records: list[ImageRecord], fa_target: float) -> float:
    """The lowest score threshold (Q8 steps) with at most fa_target false alarms per image."""
    scores = [model.score_q(r.features) if len(r.features) else np.zeros(0, np.int64) for r in records]
    allq = np.concatenate(scores) if scores else np.zeros(0)
    if allq.size == 0:
        return 0.0
    lo, hi = int(allq.min()), int(allq.max()) + 1
    while lo < hi:  # FA falls as the threshold rises: bisect on Q8 integers
        mid = (lo + hi) // 2
        res = evaluate(records, [s >= mid for s in scores])
        if res.fa_sea <= fa_target * res.images:
            hi = mid
        else:
            lo = mid + 1
    return lo / 256.0


def result_row(name: str, det: str, res: Result) -> list[str]:
    big = slice(2, None)
    return ([name, det, str(res.images)]
            + [_pct(int(res.found[i]), int(res.total[i])) for i in range(len(BINS))]
            + [_pct(int(res.found[big].sum()), int(res.total[big].sum())),
               f"{res.fa_sea / max(1, res.images):.2f}"])


OPERATING_FA = (0.2, 0.5, 1.0, 2.0, 5.0)


def operating_points(data: dict[str, list[ImageRecord]], train: list[str]) -> str:
    """Leave-one-camera-out recall (>= 20 px, 10-20 px) and FA on the sea when the threshold is set
    on the other cameras for each of OPERATING_FA false alarms per image: the trade-off curve."""
    rows = []
    for cam in train:
        others = [r for c in train if c != cam for r in data[c]]
        model = fit_model(others)
        for fa in OPERATING_FA:
            thr = choose_threshold(model, others, fa)
            res = evaluate(data[cam], [model.score_q(r.features) >= round(thr * 256)
                                       if len(r.features) else np.zeros(0, bool) for r in data[cam]])
            big = slice(2, None)
            rows.append([cam, f"{fa:g}", _pct(int(res.found[big].sum()), int(res.total[big].sum())),
                         _pct(int(res.found[1]), int(res.total[1])),
                         f"{res.fa_sea / max(1, res.images):.2f}"])
    return ("leave-one-camera-out operating points (threshold set on the other cameras for the target)\n"
            + table(["camera", "target FA/img", ">=20", "10-20", "FA sea/img"], rows))


def run(args: argparse.Namespace) -> int:
    cv2.setNumThreads(1)
    train = list(args.train_cameras)
    test = list(args.test_cameras or [])
    data = collect(args, train + test)
    headers = HEADERS[:-2]
    rows = []
    for cam in train:
        others = [r for c in train if c != cam for r in data[c]]
        model = fit_model(others, args.fa_per_image, args.bins, args.l2)
        rows.append(result_row(cam, "cand", evaluate(data[cam], [np.ones(len(r.boxes), bool)
                                                               for r in data[cam]])))
        rows.append(result_row(cam, "LOCO", evaluate(data[cam], [model.verified(r.features)
                                                               if len(r.features) else np.zeros(0, bool)
                                                               for r in data[cam]])))
    print(f"leave-one-camera-out (fitted on the other training cameras; threshold for "
          f"{args.fa_per_image} FA/img on them)")
    print(table(headers, rows))
    print(operating_points(data, train))
    full = fit_model([r for c in train for r in data[c]], args.fa_per_image, args.bins, args.l2)
    if test:
        rows = []
        for cam in test:
            rows.append(result_row(cam, "cand", evaluate(data[cam], [np.ones(len(r.boxes), bool)
                                                                   for r in data[cam]])))
            rows.append(result_row(cam, "held", evaluate(data[cam], [full.verified(r.features)
                                                                   if len(r.features) else np.zeros(0, bool)
                                                                   for r in data[cam]])))
        print(f"held out (fitted on {', '.join(train)})")
        print(table(headers, rows))
    if args.write:
        cmd = "tools/train-detect " + " ".join(shlex.quote(a) for a in (args.argv or []))
        header = (f"# The sea detector's verifier (edge.core.shipscore), fitted on cameras "
                  f"{', '.join(train)}\n"
                  f"# by: {cmd}\n# Numbers only; regenerate with the command above.\n")
        args.write.write_text(header + yaml.safe_dump(model_to_dict(full), sort_keys=False,
                                                      default_flow_style=None, width=200))
        print(f"wrote {args.write}")
    return 0


def main(argv: list[str] | None = None) -> int:
    doc = __doc__ or ""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0], epilog=doc,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--images", type=Path, nargs="+", required=True)
    parser.add_argument("--labels", type=Path, default=None)
    parser.add_argument("--format", choices=("coco", "yolo", "voc"), required=True)
    parser.add_argument("--vessel-classes", nargs="+", required=True)
    parser.add_argument("--geometry", type=Path, required=True)
    parser.add_argument("--train-cameras", nargs="+", required=True)
    parser.add_argument("--test-cameras", nargs="*", default=None)
    parser.add_argument("--cache", type=Path, default=None, help="folder for the candidates per camera")
    parser.add_argument("--write", type=Path, default=None,
                        help="store the model fitted on all training cameras")
    parser.add_argument("--fa-per-image", type=float, default=FA_TARGET)
    parser.add_argument("--bins", type=int, default=N_BINS)
    parser.add_argument("--l2", type=float, default=L2)
    parser.add_argument("--decimation", type=int, default=1)
    parser.add_argument("--min-ship-px", type=int, default=8)
    args = parser.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)
    return run(args)


if __name__ == "__main__":
    sys.exit(main())
