"""evaluate-detect's loaders: the same boxes written as YOLO, COCO and VOC read back alike; the
geometry file's errors name the key."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from lab.evaluate.detect_real import load_annotations, load_geometry

W, H = 64, 48
BOXES = [(4.0, 6.0, 20.0, 14.0, "2"), (30.0, 10.0, 62.0, 40.0, "0")]


def _images(root: Path) -> list[Path]:
    (root / "images").mkdir(parents=True)
    paths = []
    for name in ("camA_1.png", "camA_2.png"):
        p = root / "images" / name
        cv2.imwrite(str(p), np.zeros((H, W), np.uint8))
        paths.append(p)
    return paths


def _write_yolo(root: Path, images: list[Path]) -> None:
    (root / "labels").mkdir()
    for img in images:
        lines = [f"{c} {(x0 + x1) / 2 / W} {(y0 + y1) / 2 / H} {(x1 - x0) / W} {(y1 - y0) / H}"
                 for x0, y0, x1, y1, c in BOXES]
        (root / "labels" / (img.stem + ".txt")).write_text("\n".join(lines))


def _write_coco(path: Path, images: list[Path]) -> None:
    cats = sorted({c for *_, c in BOXES})
    data = {"categories": [{"id": i, "name": c} for i, c in enumerate(cats)],
            "images": [{"id": k, "file_name": f"some/dir/{p.name}"} for k, p in enumerate(images)],
            "annotations": [{"image_id": k, "category_id": cats.index(c), "bbox": [x0, y0, x1 - x0, y1 - y0]}
                            for k in range(len(images)) for x0, y0, x1, y1, c in BOXES]}
    path.write_text(json.dumps(data))


def _write_voc(folder: Path, images: list[Path]) -> None:
    folder.mkdir()
    for img in images:
        objs = "".join(f"<object><name>{c}</name><bndbox><xmin>{x0}</xmin><ymin>{y0}</ymin>"
                       f"<xmax>{x1}</xmax><ymax>{y1}</ymax></bndbox></object>" for x0, y0, x1, y1, c in BOXES)
        (folder / (img.stem + ".xml")).write_text(f"<annotation>{objs}</annotation>")


def test_yolo_coco_and_voc_read_back_the_same_boxes(tmp_path: Path) -> None:
    images = _images(tmp_path)
    _write_yolo(tmp_path, images)
    _write_coco(tmp_path / "ann.json", images)
    _write_voc(tmp_path / "voc", images)
    read = {"yolo": load_annotations(images, None, "yolo"),
            "coco": load_annotations(images, tmp_path / "ann.json", "coco"),
            "voc": load_annotations(images, tmp_path / "voc", "voc")}
    for fmt, ann in read.items():
        assert sorted(ann) == sorted(images), fmt
        for img in images:
            got = sorted((round(b.x0, 6), round(b.y0, 6), round(b.x1, 6), round(b.y1, 6), b.label)
                         for b in ann[img])
            assert got == sorted(BOXES), fmt


def test_geometry_errors_name_the_key(tmp_path: Path) -> None:
    path = tmp_path / "geo.yaml"
    path.write_text("cameras:\n  camA:\n    horizon: [[0, 1]]\n")
    with pytest.raises(SystemExit, match="cameras.camA.horizon"):
        load_geometry(path)
    path.write_text("cameras:\n  camA:\n    sea: [[[0, 1], [2, 3]]]\n")
    with pytest.raises(SystemExit, match="cameras.camA.sea"):
        load_geometry(path)
    path.write_text("default:\n  hfov_deg: 60\ncameras:\n  camA:\n    site_height_m: 35\n")
    default, cams = load_geometry(path)
    assert cams["camA"].site_height_m == 35 and cams["camA"].hfov_deg == 60
