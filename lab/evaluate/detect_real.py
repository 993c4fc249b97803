"""The product's ship detectors on real annotated imagery: recall by box length, false alarms, cost.

    .venv/bin/python tools/evaluate-detect --images DIR [DIR...] [--labels PATH] --format yolo|coco|voc
        --vessel-classes C [C...] --geometry FILE.yaml [--out DIR] [--decimation N] [--min-ship-px N]
        [--cameras NAME...] [--limit N]

Both detectors run on every image in one process (OLD: edge.measure.detect.Detector; NEW:
edge.measure.seadetect.SeaDetector), each built for the image's camera geometry: a pinhole
camera whose focal length follows the stated horizontal field of view, pitched and rolled so
that the product's own horizon prediction (the dip at the site height, through the camera
model) passes through the stated horizon points, or through the line the horizon finder
(edge.core.horizon) finds in the camera's images when the horizon is `auto`. The detectors
then refine it from each image as they do on the mast.

Printed per camera and for all images, per detector:
  recall by box length (the box's longer side, px: <10, 10-20, 20-40, 40-80, >=80): vessel boxes
      whose waterline (bottom centre) lies on the sea (inside the `sea` polygons, or below the
      horizon when none are given) that some detection touches (the intersection is at least
      30 % of the smaller box); vessels off the sea (moored inside a harbour the mask leaves out)
      are not scored
  FA sea / img: detections touching no annotated object (any class), waterline on the sea
  FA else / img: the same elsewhere (land, quays, above the horizon)
  ms / img: process CPU time per detect call, median (OpenCV on one thread)
With --out, one PNG per image with a miss or a false alarm: misses red, false alarms yellow,
hits green, other annotated objects grey, the horizon cyan; OLD left, NEW right.

Geometry file (YAML):

    default:                   # applies to every camera unless overridden
      hfov_deg: 60             # horizontal field of view, degrees
      site_height_m: 20        # camera height above the sea, m (the horizon's dip)
      horizon: auto            # or [[x0, y0], [x1, y1]]: two image points on the sea horizon
                               # (or the far shore's waterline), full-resolution pixels
      horizon_rows: [0.2, 0.8] # with auto: search between these shares of the image height
    cameras:                   # images whose file name starts with the key
      519srew5:
        horizon: [[0, 505], [1919, 497]]
        sea: [[[0, 510], [1919, 500], [1919, 900], [0, 760]]]   # polygons, image px (optional)
        skip: false            # true: leave this camera out of the run

Images of cameras the file does not name use `default`. Data stays outside the repository: the
tool takes its paths as arguments.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse
import json
import math
import sys
import time
import xml.etree.ElementTree as ET
from collections import defaultdict
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import yaml
from scipy.optimize import least_squares

from edge.core.camera import PinholeCamera, StereoRig
from edge.core.geo import horizon_dip_rad
from edge.core.horizon import find_horizon
from edge.core.rectify import Rectifier
from edge.measure.detect import Blob, Detector
from edge.measure.seadetect import SeaDetector
from lab.bench.common import table

BINS = [(0, 10, "<10"), (10, 20, "10-20"), (20, 40, "20-40"), (40, 80, "40-80"), (80, 10**9, ">=80")]
TOUCH_SHARE = 0.3  # a detection touches a box when they share this much of the smaller one's area
HORIZON_SLACK = 0.004  # share of the image height above the horizon that still counts as the sea
IMAGE_EXT = (".jpg", ".jpeg", ".png", ".bmp")
DETECTORS = ("OLD", "NEW")


@dataclass(frozen=True)
class Box:
    x0: float
    y0: float
    x1: float
    y1: float
    label: str

    @property
    def length_px(self) -> float:
        return max(self.x1 - self.x0, self.y1 - self.y0)


@dataclass
class CameraGeometry:
    hfov_deg: float = 60.0
    site_height_m: float = 20.0
    horizon: list[list[float]] | str = "auto"
    horizon_rows: tuple[float, float] = (0.2, 0.8)
    sea: list[list[list[float]]] = field(default_factory=list)
    skip: bool = False


# ----------------------------------------------------------------------------- annotations
def load_annotations(images: list[Path], labels: Path | None, fmt: str) -> dict[Path, list[Box]]:
    """Boxes per image path (full-resolution px). YOLO: `labels` is a folder of .txt (default: the
    image folder with `images` replaced by `labels`); VOC: a folder of .xml (default: the image's
    folder); COCO: the .json file."""
    out: dict[Path, list[Box]] = {}
    if fmt == "coco":
        if labels is None:
            raise SystemExit("evaluate-detect: COCO needs --labels FILE.json")
        data = json.loads(labels.read_text())
        names = {c["id"]: c["name"] for c in data["categories"]}
        by_id = {im["id"]: Path(im["file_name"]).name for im in data["images"]}
        boxes: dict[str, list[Box]] = defaultdict(list)
        for a in data["annotations"]:
            x, y, w, h = a["bbox"]
            boxes[by_id[a["image_id"]]].append(Box(x, y, x + w, y + h, names[a["category_id"]]))
        known = set(by_id.values())
        for img in images:
            if img.name in known:
                out[img] = boxes.get(img.name, [])
        return out
    for img in images:
        if fmt == "yolo":
            folder = labels if labels is not None else Path(str(img.parent).replace("images", "labels"))
            path = folder / (img.stem + ".txt")
            if not path.exists():
                continue
            w, h = _image_size(img)
            found = []
            for line in path.read_text().splitlines():
                parts = line.split()
                if len(parts) < 5:
                    continue
                c, xc, yc, bw, bh = parts[0], *(float(v) for v in parts[1:5])
                found.append(Box((xc - bw / 2) * w, (yc - bh / 2) * h, (xc + bw / 2) * w,
                                 (yc + bh / 2) * h, c))
            out[img] = found
        elif fmt == "voc":
            folder = labels if labels is not None else img.parent
            path = folder / (img.stem + ".xml")
            if not path.exists():
                continue
            root = ET.parse(path).getroot()
            found = []
            for obj in root.iter("object"):
                bb = obj.find("bndbox")
                if bb is None:
                    continue
                v = [float(bb.findtext(k) or "nan") for k in ("xmin", "ymin", "xmax", "ymax")]
                found.append(Box(v[0], v[1], v[2], v[3], obj.findtext("name") or ""))
            out[img] = found
        else:
            raise SystemExit(f"evaluate-detect: unknown format {fmt!r} (coco, yolo or voc)")
    return out


_SIZES: dict[Path, tuple[int, int]] = {}


def _image_size(path: Path) -> tuple[int, int]:
    if path not in _SIZES:
        img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise SystemExit(f"evaluate-detect: cannot read {path}")
        _SIZES[path] = (img.shape[1], img.shape[0])
    return _SIZES[path]


# ----------------------------------------------------------------------------- geometry
def load_geometry(path: Path) -> tuple[CameraGeometry, dict[str, CameraGeometry]]:
    """The default geometry and the per-camera ones from the YAML file (format in the module doc)."""
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except (OSError, yaml.YAMLError) as exc:
        raise SystemExit(f"evaluate-detect: {path}: {exc}") from exc

    def parse(key: str, values: dict, base: CameraGeometry) -> CameraGeometry:
        if not isinstance(values, dict):
            raise SystemExit(f"evaluate-detect: {path}: {key} must be a mapping")
        merged = {**base.__dict__, **values}
        unknown = set(values) - set(CameraGeometry.__dataclass_fields__)
        if unknown:
            raise SystemExit(f"evaluate-detect: {path}: {key}: unknown keys {sorted(unknown)}")
        geo = CameraGeometry(**merged)
        hz = geo.horizon
        if hz != "auto" and not (isinstance(hz, list) and len(hz) == 2 and all(len(p) == 2 for p in hz)):
            raise SystemExit(f"evaluate-detect: {path}: {key}.horizon must be auto or [[x0, y0], [x1, y1]]")
        if not 1.0 <= float(geo.hfov_deg) <= 170.0 or not 0.5 <= float(geo.site_height_m) <= 2000.0:
            raise SystemExit(f"evaluate-detect: {path}: {key}: hfov_deg in 1..170, "
                             "site_height_m in 0.5..2000")
        for poly in geo.sea:
            if len(poly) < 3 or any(len(p) != 2 for p in poly):
                raise SystemExit(f"evaluate-detect: {path}: {key}.sea: polygons of at least 3 [x, y] points")
        return geo

    default = parse("default", data.get("default", {}), CameraGeometry())
    cams = {str(k): parse(f"cameras.{k}", v or {}, default) for k, v in (data.get("cameras") or {}).items()}
    return default, cams


def horizon_rows(camera: PinholeCamera, site_height_m: float, xs: np.ndarray) -> np.ndarray:
    """Rows of the predicted sea horizon (the dip cone) at image columns xs, through the camera."""
    t = math.tan(horizon_dip_rad(site_height_m))
    xn = np.linspace(-3.0, 3.0, 601)
    uv = camera.normalised_to_pixel(np.stack([xn, t * np.sqrt(1.0 + xn * xn)], -1))
    ok = np.isfinite(uv).all(axis=1)
    order = np.argsort(uv[ok, 0])
    return np.interp(xs, uv[ok, 0][order], uv[ok, 1][order])


def camera_for_horizon(width: int, height: int, hfov_deg: float, site_height_m: float,
                       p0: tuple[float, float], p1: tuple[float, float]) -> PinholeCamera:
    """A pinhole of the field of view, pitched and rolled so its predicted horizon passes p0 and p1."""
    f = 0.5 * width / math.tan(math.radians(0.5 * hfov_deg))
    cx, cy = 0.5 * (width - 1), 0.5 * (height - 1)
    xs = np.array([p0[0], p1[0]], float)
    ys = np.array([p0[1], p1[1]], float)

    def cam(params: np.ndarray) -> PinholeCamera:
        return PinholeCamera(f, f, cx, cy, rotation_deg=(float(params[0]), 0.0, float(params[1])))

    def residual(params: np.ndarray) -> np.ndarray:
        return horizon_rows(cam(params), site_height_m, xs) - ys

    pitch0 = -math.degrees(math.atan2(0.5 * (ys[0] + ys[1]) - cy, f))
    fit = least_squares(residual, np.array([pitch0, 0.0]), x_scale=1.0)
    return cam(fit.x)


def detectors_for(camera: PinholeCamera, width: int, height: int, site_height_m: float, decimation: int,
                  min_ship_px: int, kinds: dict[str, type[Detector]] | None = None,
                  **options: object) -> dict[str, Detector]:
    """The detectors (default: OLD and NEW) for one camera geometry; `options` go to each."""
    rig = StereoRig(1.0, width, height, camera, camera)
    rect = Rectifier(rig)
    kinds = kinds or {"OLD": Detector, "NEW": SeaDetector}
    return {name: kind(rect, site_height_m, decimation=decimation, min_ship_px=min_ship_px,
                       **options)
            for name, kind in kinds.items()}


def sea_mask(width: int, height: int, geo: CameraGeometry, horizon: np.ndarray) -> np.ndarray:
    """True on the sea: inside the polygons when given, and below the horizon row of each column."""
    rows = np.arange(height)[:, None]
    mask = rows >= np.floor(horizon - HORIZON_SLACK * height)[None, :]  # a far hull sits on it
    if geo.sea:
        poly = np.zeros((height, width), np.uint8)
        cv2.fillPoly(poly, [np.round(np.array(p, float)).astype(np.int32) for p in geo.sea], 1)
        mask &= poly.astype(bool)
    return mask


# ----------------------------------------------------------------------------- scoring
def touches(a: Box | Blob, b: Box | Blob) -> bool:
    ix = min(a.x1, b.x1) - max(a.x0, b.x0)
    iy = min(a.y1, b.y1) - max(a.y0, b.y0)
    if ix <= 0 or iy <= 0:
        return False
    small = min((a.x1 - a.x0) * (a.y1 - a.y0), (b.x1 - b.x0) * (b.y1 - b.y0))
    return ix * iy >= TOUCH_SHARE * max(small, 1e-9)


def waterline_on(mask: np.ndarray, box: Box | Blob) -> bool:
    h, w = mask.shape
    x = int(np.clip(round(0.5 * (box.x0 + box.x1)), 0, w - 1))
    y = int(np.clip(round(box.y1 - 1), 0, h - 1))
    return bool(mask[y, x])


@dataclass
class Tally:
    found: np.ndarray = field(default_factory=lambda: np.zeros(len(BINS), int))
    total: np.ndarray = field(default_factory=lambda: np.zeros(len(BINS), int))
    fa_sea: int = 0
    fa_else: int = 0
    images: int = 0
    ms: list[float] = field(default_factory=list)

    def add(self, other: Tally) -> None:
        self.found += other.found
        self.total += other.total
        self.fa_sea += other.fa_sea
        self.fa_else += other.fa_else
        self.images += other.images
        self.ms += other.ms


def bin_of(length_px: float) -> int:
    return next(i for i, (lo, hi, _) in enumerate(BINS) if lo <= length_px < hi)


def score(blobs: list[Blob], boxes: list[Box], vessels: set[str], mask: np.ndarray, tally: Tally
          ) -> tuple[list[Box], list[Blob], list[Box]]:
    """Add one image to the tally; (missed vessel boxes, false alarms, found vessel boxes)."""
    missed, hits = [], []
    for box in boxes:
        if box.label not in vessels or not waterline_on(mask, box):
            continue
        k = bin_of(box.length_px)
        tally.total[k] += 1
        if any(touches(b, box) for b in blobs):
            tally.found[k] += 1
            hits.append(box)
        else:
            missed.append(box)
    false = [b for b in blobs if not any(touches(b, box) for box in boxes)]
    for b in false:
        if waterline_on(mask, b):
            tally.fa_sea += 1
        else:
            tally.fa_else += 1
    tally.images += 1
    return missed, false, hits


def _pct(found: int, total: int) -> str:
    return f"{100.0 * found / total:.0f}% ({found}/{total})" if total else "-"


def report_rows(name: str, tallies: dict[str, Tally]) -> list[list[str]]:
    rows = []
    for det in DETECTORS:
        t = tallies[det]
        big = slice(2, None)
        rows.append([name, det, str(t.images)]
                    + [_pct(int(t.found[i]), int(t.total[i])) for i in range(len(BINS))]
                    + [_pct(int(t.found[big].sum()), int(t.total[big].sum())),
                       f"{t.fa_sea / max(1, t.images):.2f}", f"{t.fa_else / max(1, t.images):.2f}",
                       f"{float(np.median(t.ms)) if t.ms else float('nan'):.1f}"])
    return rows


HEADERS = ["set", "det", "imgs", *[b[2] for b in BINS], ">=20", "FA sea/img", "FA else/img", "ms/img"]


# ----------------------------------------------------------------------------- overlays
def overlay(image: np.ndarray, horizon: np.ndarray,
            results: dict[str, tuple[list[Box], list[Blob], list[Box]]],
            others: list[Box], max_width: int = 1600) -> np.ndarray:
    panels = []
    for det in DETECTORS:
        missed, false, hits = results[det]
        img = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        xs = np.arange(len(horizon))
        pts = np.stack([xs, horizon], -1)[:: max(1, len(xs) // 64)]
        cv2.polylines(img, [np.round(pts).astype(np.int32)], False, (255, 255, 0), 1)
        for boxes, colour in ((others, (128, 128, 128)), (hits, (0, 200, 0)), (missed, (0, 0, 255))):
            for box in boxes:
                cv2.rectangle(img, (int(box.x0) - 2, int(box.y0) - 2), (int(box.x1) + 2, int(box.y1) + 2),
                              colour, 2)
        for blob in false:
            cv2.rectangle(img, (blob.x0 - 3, blob.y0 - 3), (blob.x1 + 3, blob.y1 + 3), (0, 255, 255), 2)
        cv2.putText(img, det, (10, 40), cv2.FONT_HERSHEY_SIMPLEX, 1.2, (0, 255, 255), 2)
        panels.append(img)
    both = np.hstack(panels)
    if both.shape[1] > max_width:
        s = max_width / both.shape[1]
        both = cv2.resize(both, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
    return both


# ----------------------------------------------------------------------------- run
@dataclass
class Frame:
    """One annotated image of a camera, with the detectors of its geometry and its sea mask."""

    path: Path
    image: np.ndarray
    detectors: dict[str, Detector]
    horizon: np.ndarray  # the stated (or found) horizon row per column, before refinement
    mask: np.ndarray  # True on the sea (scoring)
    search: np.ndarray | None  # the detector's search mask (the sea polygons), or None


def camera_frames(paths: list[Path], geo: CameraGeometry, decimation: int, min_ship_px: int,
                  kinds: dict[str, type[Detector]] | None = None, **options: object) -> Iterator[Frame]:
    """The images of one camera in order, each with detectors built for its horizon (rebuilt when
    the horizon moves by more than 1.5 px: the webcams pan and shake) and its sea mask."""
    width, height = _image_size(paths[0])
    fixed = None
    if isinstance(geo.horizon, list):
        (x0, y0), (x1, y1) = geo.horizon
        fixed = (float(x0), float(y0)), (float(x1), float(y1))
    line: tuple[tuple[float, float], tuple[float, float]] | None = None
    dets: dict[str, Detector] = {}
    for path in paths:
        image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        if image is None or image.shape != (height, width):
            continue
        # a webcam may pan or shake between frames: with `auto` the horizon is found in each image
        found = fixed or find_horizon(image, (geo.horizon_rows[0] * height, geo.horizon_rows[1] * height))
        if found is None and line is None:
            found = auto_horizon(paths, geo)
        if found is not None and (line is None or max(abs(found[0][1] - line[0][1]),
                                                       abs(found[1][1] - line[1][1])) > 1.5):
            line = found
            camera = camera_for_horizon(width, height, geo.hfov_deg, geo.site_height_m, *line)
            dets = detectors_for(camera, width, height, geo.site_height_m, decimation, min_ship_px, kinds,
                                 **options)
        first = next(iter(dets.values()))
        horizon = first.horizon_row.copy()  # before this image's refinement: the stated one
        mask = sea_mask(width, height, geo, horizon)
        yield Frame(path, image, dets, horizon, mask, mask if geo.sea else None)


def camera_key(path: Path, known: dict[str, CameraGeometry]) -> str:
    for key in sorted(known, key=len, reverse=True):
        if path.name.startswith(key):
            return key
    return path.name.split("_")[0] if "_" in path.name else "default"


def list_images(folders: list[Path]) -> list[Path]:
    out = []
    for folder in folders:
        if folder.is_file():
            out.append(folder)
            continue
        out += sorted(p for p in folder.rglob("*") if p.suffix.lower() in IMAGE_EXT)
    return out


def auto_horizon(paths: list[Path], geo: CameraGeometry) -> tuple[tuple[float, float], tuple[float, float]]:
    """The median of the horizon finder's lines over up to 9 of a camera's images."""
    lines = []
    for p in paths[:: max(1, len(paths) // 9)][:9]:
        img = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        if img is None:
            continue
        h = img.shape[0]
        line = find_horizon(img, (geo.horizon_rows[0] * h, geo.horizon_rows[1] * h))
        if line is not None:
            lines.append([line[0][1], line[1][1]])
    if not lines:
        raise SystemExit(f"evaluate-detect: no horizon found in {paths[0].parent} (give horizon points)")
    y0, y1 = np.median(np.array(lines), axis=0)
    w = _image_size(paths[0])[0]
    return (0.0, float(y0)), (float(w - 1), float(y1))


@dataclass
class Dataset:
    """An annotated image folder with its camera geometry, the images grouped by camera."""

    default: CameraGeometry
    cams: dict[str, CameraGeometry]
    ann: dict[Path, list[Box]]
    vessels: set[str]
    groups: dict[str, list[Path]]


def load_dataset(args: argparse.Namespace) -> Dataset:
    """The images, boxes and geometry the command line names (evaluate-detect and train-detect)."""
    default, cams = load_geometry(args.geometry)
    ann = load_annotations(list_images(args.images), args.labels, args.format)
    groups: dict[str, list[Path]] = defaultdict(list)
    for img in ann:
        groups[camera_key(img, cams)].append(img)
    return Dataset(default, cams, ann, set(args.vessel_classes), groups)


def run(args: argparse.Namespace) -> int:
    cv2.setNumThreads(1)
    data = load_dataset(args)
    default, cams, ann, vessels, groups = data.default, data.cams, data.ann, data.vessels, data.groups
    if args.cameras:
        groups = {k: v for k, v in groups.items() if k in args.cameras}
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
    totals = {d: Tally() for d in DETECTORS}
    rows = []
    for key in sorted(groups):
        geo = cams.get(key, default)
        if geo.skip:
            continue
        paths = groups[key][: args.limit] if args.limit else groups[key]
        tallies = {d: Tally() for d in DETECTORS}
        for n, frame in enumerate(camera_frames(paths, geo, args.decimation, args.min_ship_px)):
            path, image, dets, horizon, mask, search = (frame.path, frame.image, frame.detectors,
                                                        frame.horizon, frame.mask, frame.search)
            results = {}
            for det in (DETECTORS if n % 2 == 0 else DETECTORS[::-1]):
                t0 = time.process_time()
                if det == "NEW":
                    blobs = dets[det].detect(image, search_mask=search)  # type: ignore[call-arg]
                else:
                    blobs = dets[det].detect(image)
                tallies[det].ms.append(1e3 * (time.process_time() - t0))
                results[det] = score(blobs, ann[path], vessels, mask, tallies[det])
            if args.out and any(results[d][0] or results[d][1] for d in DETECTORS):
                others = [b for b in ann[path] if b.label not in vessels or not waterline_on(mask, b)]
                cv2.imwrite(str(args.out / f"{path.stem}.png"), overlay(image, horizon, results, others))
        rows += report_rows(key, tallies)
        for d in DETECTORS:
            totals[d].add(tallies[d])
    rows += report_rows("all", totals)
    print(f"images: {', '.join(str(p) for p in args.images)}; decimation {args.decimation}, "
          f"min_ship_px {args.min_ship_px}")
    print(table(HEADERS, rows))
    print("recall: found/scored vessel boxes on the sea by box length (px, longer side); "
          "FA: detections touching no annotated object, per image")
    return 0


def main(argv: list[str] | None = None) -> int:
    doc = __doc__ or ""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0], epilog=doc,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--images", type=Path, nargs="+", required=True,
                        help="image folders (searched recursively)")
    parser.add_argument("--labels", type=Path, default=None, help="label folder (YOLO/VOC) or COCO .json")
    parser.add_argument("--format", choices=("coco", "yolo", "voc"), required=True)
    parser.add_argument("--vessel-classes", nargs="+", required=True,
                        help="class ids (YOLO) or names (COCO/VOC) that are vessels")
    parser.add_argument("--geometry", type=Path, required=True, help="camera geometry YAML (see below)")
    parser.add_argument("--out", type=Path, default=None, help="folder for overlay PNGs")
    parser.add_argument("--decimation", type=int, default=1)
    parser.add_argument("--min-ship-px", type=int, default=8)
    parser.add_argument("--cameras", nargs="*", default=None, help="only these cameras (file-name prefixes)")
    parser.add_argument("--limit", type=int, default=0, help="at most this many images per camera")
    args = parser.parse_args(argv)
    return run(args)


if __name__ == "__main__":
    sys.exit(main())
