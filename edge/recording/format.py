"""The recording directory (docs/recordings.md): its one writer (atomic, pair by pair), and reading
its ground truth and AIS.

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
import os
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

import cv2
import numpy as np
import yaml

from drivers.camera.base import FramePair
from drivers.camera.replay import FRAMES_HEADER, SUPPORTED_FORMAT
from edge.config.calibration import Calibration, calibration_to_dict, site_to_dict
from edge.core.site import Site

FORMAT_VERSION = SUPPORTED_FORMAT  # the reader (drivers.camera.replay) and the writer agree by construction
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


PART = ".part"  # suffix of a file being written; renamed once complete


def encode_png(image: np.ndarray) -> bytes:
    """Lossless PNG bytes of an 8-bit grey or BGR image."""
    ok, buf = cv2.imencode(".png", image, PNG_PARAMS)
    if not ok:
        raise ValueError(f"cannot encode a {image.dtype} image of shape {image.shape} as PNG")
    return buf.tobytes()


def write_file_atomic(path: Path, data: bytes) -> None:
    """`data` at `path`, which either appears complete or not at all (a `.part` file renamed)."""
    part = path.with_name(path.name + PART)
    try:
        with open(part, "wb") as f:
            f.write(data)
        os.replace(part, path)
    except BaseException:
        part.unlink(missing_ok=True)
        raise


def write_png(path: Path, image: np.ndarray) -> None:
    """One PNG of a pair, atomically. OSError (ENOSPC included, with its errno) when the disk refuses it."""
    write_file_atomic(path, encode_png(image))


def _yaml(meta: dict) -> bytes:
    return yaml.safe_dump(meta, sort_keys=False, allow_unicode=True).encode("utf-8")


class RecordingWriter:
    """The one writer of a recording directory: meta.yaml, frames.csv, the PNGs and, when asked,
    truth.csv; each pair is added all or nothing. `record` and the live recorder add whole pairs
    (`add`); the simulator renders PNGs in worker processes (`write_png`) and adds their rows."""

    def __init__(self, root: str | Path, meta: dict, overwrite: bool = False, truth: bool = False) -> None:
        self.root = prepare_directory(root, overwrite)
        self.meta = meta
        write_file_atomic(self.root / "meta.yaml", _yaml(meta))
        self._fd = os.open(self.root / "frames.csv", os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        self._size = 0  # bytes of frames.csv that are complete rows
        self._append(",".join(FRAMES_HEADER) + "\n")
        self._truth: TextIO | None = None
        if truth:
            self._truth = open(self.root / "truth.csv", "w", encoding="ascii", newline="")  # noqa: SIM115
            self._truth.write(",".join(TRUTH_HEADER) + "\n")
        self.pairs = 0

    def add(self, index: int, pair: FramePair) -> None:
        """Both PNGs of pair `index`, then its frames.csv row; on any error neither stays."""
        left_path, right_path = image_paths(self.root, index)
        try:
            write_png(left_path, pair.left)
            write_png(right_path, pair.right)
            self.add_row(index, pair.t_ns, pair.seq_left, pair.seq_right, pair.t_left_ns, pair.t_right_ns)
        except BaseException:
            left_path.unlink(missing_ok=True)
            right_path.unlink(missing_ok=True)
            raise

    def add_row(
        self, index: int, t_ns: int, seq_left: int, seq_right: int, t_left_ns: int, t_right_ns: int
    ) -> None:
        """frames.csv's row of pair `index`, whose two PNGs are already complete."""
        row = (index, t_ns, seq_left, seq_right, t_left_ns, t_right_ns)
        self._append(",".join(str(int(v)) for v in row) + "\n")
        self.pairs += 1

    def add_truth(self, t_ns: int, ship_id: int, xyz_m: np.ndarray) -> None:
        """One truth.csv row: the ship's tracked point in the world frame at `t_ns`."""
        if self._truth is None:
            raise ValueError("this recording was opened without truth.csv (truth=False)")
        x, y, z = (float(v) for v in xyz_m)
        self._truth.write(f"{int(t_ns)},{int(ship_id)},{x:.6f},{y:.6f},{z:.6f}\n")

    def _append(self, text: str) -> None:
        view = memoryview(text.encode("ascii"))
        try:
            while view:
                view = view[self._write_some(self._fd, view):]
        except BaseException:
            os.ftruncate(self._fd, self._size)  # never leave half a row: replay would refuse the file
            os.lseek(self._fd, self._size, os.SEEK_SET)
            raise
        self._size += len(text)

    _write_some: Callable[[int, memoryview], int] = staticmethod(os.write)  # tests make it fail

    def update_meta(self, **extra: object) -> bool:
        """Rewrite meta.yaml with `extra` keys merged in; False (the old one stays) if the disk refuses."""
        meta = {**self.meta, **extra}
        try:
            write_file_atomic(self.root / "meta.yaml", _yaml(meta))
        except OSError:
            return False
        self.meta = meta
        return True

    def close(self) -> None:
        if self._truth is not None:
            self._truth.close()
            self._truth = None
        if self._fd < 0:
            return
        try:
            os.fsync(self._fd)
        except OSError:
            pass  # the rows already written are in the page cache; close still publishes them
        finally:
            os.close(self._fd)
            self._fd = -1

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
