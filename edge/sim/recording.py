"""The recording directory (docs/recordings.md): writing it, and reading its ground truth.

```
meta.yaml    format: 1, fps, width, height, calibration: {...}, site: {...}, notes (+ extra keys)
frames.csv   index,t_ns,seq_left,seq_right,t_left_ns,t_right_ns
left/000000.png, right/000000.png     8-bit grey lossless PNG
truth.csv    t_ns,ship_id,x_m,y_m,z_m  (world frame, the ship's tracked point)
ais.csv      t_ns,sentence  (optional, issue 17: raw !AIVDM lines with checksum, recording clock)
```

`index` counts the pairs written (file names follow it); a dropped pair leaves
no row, and shows as a jump in the sequence numbers. The calibration mapping
in meta.yaml is `calibration_to_dict` without its site, which sits beside it.
Pixels are stored losslessly and numbers in full precision, so a recording
read back (drivers/camera/replay.py) gives exactly what was written.
"""

from __future__ import annotations

import csv
import shutil
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from edge.config.calibration import Calibration, calibration_to_dict, site_to_dict
from edge.core.site import Site

FORMAT_VERSION = 1
FRAMES_HEADER = ("index", "t_ns", "seq_left", "seq_right", "t_left_ns", "t_right_ns")
TRUTH_HEADER = ("t_ns", "ship_id", "x_m", "y_m", "z_m")
AIS_HEADER = ("t_ns", "sentence")
AIS_FILE = "ais.csv"
PNG_PARAMS = [cv2.IMWRITE_PNG_COMPRESSION, 3]


def build_meta(
    calibration: Calibration, fps: float, notes: str, site: Site | None = None, **extra: Any
) -> dict:
    """meta.yaml content: the fixed keys first, then any extra (scenario, seed, ships, ...)."""
    cal = calibration_to_dict(calibration)
    cal.pop("site", None)
    site = site or calibration.site
    meta = {
        "format": FORMAT_VERSION,
        "fps": float(fps),
        "width": int(calibration.rig.width),
        "height": int(calibration.rig.height),
        "calibration": cal,
        "site": None if site is None else site_to_dict(site),
        "notes": notes,
    }
    meta.update(extra)
    return meta


def image_paths(root: str | Path, index: int) -> tuple[Path, Path]:
    root = Path(root)
    name = f"{index:06d}.png"
    return root / "left" / name, root / "right" / name


def write_png(path: Path, image: np.ndarray) -> None:
    if not cv2.imwrite(str(path), image, PNG_PARAMS):
        raise OSError(f"could not write {path}")


def prepare_directory(root: str | Path, overwrite: bool = False) -> Path:
    """An empty recording directory with left/ and right/; only a recording is ever replaced."""
    root = Path(root)
    if root.exists() and any(root.iterdir()):
        if not (overwrite and (root / "meta.yaml").is_file()):
            what = "replace it with --force" if (root / "meta.yaml").is_file() else "not a recording"
            raise FileExistsError(f"{root} exists and is not empty ({what})")
        shutil.rmtree(root)
    for sub in ("left", "right"):
        (root / sub).mkdir(parents=True, exist_ok=True)
    return root


class RecordingWriter:
    """Creates a recording directory; add pairs and truth rows, then `close()` (or use `with`)."""

    def __init__(self, root: str | Path, meta: dict, overwrite: bool = False) -> None:
        self.root = prepare_directory(root, overwrite)
        with open(self.root / "meta.yaml", "w", encoding="utf-8") as f:
            yaml.safe_dump(meta, f, sort_keys=False, allow_unicode=True)
        self._frames = open(self.root / "frames.csv", "w", encoding="utf-8", newline="")  # noqa: SIM115
        self._truth = open(self.root / "truth.csv", "w", encoding="utf-8", newline="")  # noqa: SIM115
        self._frames_csv = csv.writer(self._frames, lineterminator="\n")
        self._truth_csv = csv.writer(self._truth, lineterminator="\n")
        self._frames_csv.writerow(FRAMES_HEADER)
        self._truth_csv.writerow(TRUTH_HEADER)
        self.pairs = 0

    def write_pair(self, index: int, left: np.ndarray, right: np.ndarray) -> None:
        """The two PNGs of pair `index` (they may also be written by worker processes via write_png)."""
        for path, image in zip(image_paths(self.root, index), (left, right), strict=True):
            write_png(path, image)

    def add_frame(
        self, index: int, t_ns: int, seq_left: int, seq_right: int, t_left_ns: int, t_right_ns: int
    ) -> None:
        self._frames_csv.writerow(
            (int(index), int(t_ns), int(seq_left), int(seq_right), int(t_left_ns), int(t_right_ns))
        )
        self.pairs += 1

    def add_truth(self, t_ns: int, ship_id: int, xyz_m: np.ndarray) -> None:
        x, y, z = (float(v) for v in xyz_m)
        self._truth_csv.writerow((int(t_ns), int(ship_id), f"{x:.6f}", f"{y:.6f}", f"{z:.6f}"))

    def close(self) -> None:
        self._frames.close()
        self._truth.close()

    def __enter__(self) -> RecordingWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def read_truth(root: str | Path) -> dict[int, np.ndarray]:
    """truth.csv as {ship_id: (n, 4) array of t_ns, x_m, y_m, z_m} (float64; t_ns exact below 2^53)."""
    path = Path(root) / "truth.csv"
    rows: dict[int, list[tuple[float, ...]]] = {}
    with open(path, encoding="utf-8", newline="") as f:
        reader = csv.reader(f)
        header = tuple(next(reader, ()))
        if header != TRUTH_HEADER:
            raise ValueError(f"{path}: expected header {','.join(TRUTH_HEADER)}, found {','.join(header)}")
        for t_ns, ship_id, x, y, z in reader:
            rows.setdefault(int(ship_id), []).append((float(t_ns), float(x), float(y), float(z)))
    return {k: np.array(v) for k, v in rows.items()}


def write_ais(root: str | Path, lines: list[tuple[int, str]]) -> None:
    """ais.csv: one row per received line (t_ns on the recording's clock, the raw sentence)."""
    with open(Path(root) / AIS_FILE, "w", encoding="ascii", newline="") as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(AIS_HEADER)
        for t_ns, line in lines:
            writer.writerow((int(t_ns), line))


def read_ais(root: str | Path) -> list[tuple[int, str]] | None:
    """ais.csv as (t_ns, line) in file order; None when the recording has none (older recordings).
    A row that does not parse is kept as an empty line at the previous time, so the AIS decoder
    counts it (garbage is the decoder's to count, not the reader's to hide)."""
    path = Path(root) / AIS_FILE
    if not path.is_file():
        return None
    out: list[tuple[int, str]] = []
    with open(path, encoding="ascii", errors="replace", newline="") as f:
        reader = csv.reader(f)
        header = tuple(next(reader, ()))
        if header != AIS_HEADER:
            raise ValueError(f"{path}: expected header {','.join(AIS_HEADER)}, found {','.join(header)}")
        for row in reader:
            try:
                out.append((int(row[0]), ",".join(row[1:])))
            except (ValueError, IndexError):
                out.append((out[-1][0] if out else 0, ",".join(row)))
    return out
