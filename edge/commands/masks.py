"""`mast-stereo masks`: draw the configured site masks and the horizon over a captured left frame.

    mast-stereo masks --config FILE [--frame PNG | --recording DIR] --out PNG

For a technician setting up `masks:` (docs/site-masks.md): the same loader and checks as the daemon
(a bad polygon is one line naming the key and the vertex, exit 78), then a PNG of the left frame with
every excluded pixel tinted red, each image polygon outlined in yellow and each geographic one in
magenta with its name, and the sea horizon in green (where the rays start to meet the sea). The
frame is `--frame` (a left image at the calibration's size), the first left frame of `--recording`
(a `mast-stereo record` capture), or, with neither, the configured replay recording's; failing all,
a grey canvas. Calibration and site come from the configuration (for virtual cameras the scenario's).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from edge.appliance.sources import plan_source
from edge.config.app import ReplayCameras, load_config
from edge.config.masks import MasksConfig, build_search_mask, geo_polygons_xz, sea_grid
from edge.core.masks import horizon_rows, inside_polygon, open_sea_share
from edge.errors import ConfigError

EXCLUDED_BGR = (0, 0, 255)
IMAGE_BGR = (0, 255, 255)
GEO_BGR = (255, 0, 255)
HORIZON_BGR = (0, 255, 0)
TINT = 0.45  # weight of the red over an excluded pixel


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", type=Path, required=True, metavar="FILE", help="appliance configuration")
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--frame", type=Path, metavar="PNG", help="a left frame at the calibration's size")
    source.add_argument("--recording", type=Path, metavar="DIR", help="a recording: its first left frame")
    parser.add_argument("--out", type=Path, required=True, metavar="PNG", help="the picture to write")


def _frame(args: argparse.Namespace, recording: Path | None, width: int,
           height: int) -> tuple[np.ndarray, str]:
    """The left frame as BGR and where it came from."""
    if args.frame is not None:
        image = cv2.imread(str(args.frame), cv2.IMREAD_COLOR)
        if image is None:
            raise ConfigError("command line", "--frame", "a readable image file", str(args.frame))
        where = str(args.frame)
    elif recording is not None:
        from edge.replay import open_recording

        with open_recording(recording) as source:
            pair = next(iter(source), None)
        if pair is None:
            raise ConfigError("command line", "--recording", "a recording with at least one pair",
                              str(recording))
        left = pair.left
        image = cv2.cvtColor(left, cv2.COLOR_GRAY2BGR) if left.ndim == 2 else left
        where = f"{recording} (first pair)"
    else:
        return np.full((height, width, 3), 96, np.uint8), "a grey canvas (no frame given)"
    if image.shape[:2] != (height, width):
        raise ConfigError("command line", "--frame" if args.frame is not None else "--recording",
                          f"a {width}x{height} left image (the calibration's size)",
                          f"{image.shape[1]}x{image.shape[0]}")
    return image, where


def draw(image: np.ndarray, masks: MasksConfig, mask: np.ndarray, sea_xz: np.ndarray,
         geo_xz: list[np.ndarray]) -> np.ndarray:
    """The frame with the excluded pixels tinted, the polygons outlined and named, the horizon drawn."""
    out = image.copy()
    excluded = ~mask
    out[excluded] = (out[excluded] * (1.0 - TINT) + np.array(EXCLUDED_BGR) * TINT).astype(np.uint8)
    h, w = mask.shape
    for m in masks.image:
        pts = np.round(np.array(m.polygon)).astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(out, [pts], True, IMAGE_BGR, 1, cv2.LINE_AA)
        _label(out, m.name, np.array(m.polygon).mean(axis=0), IMAGE_BGR)
    for g, xz in zip(masks.geo, geo_xz, strict=True):
        region = inside_polygon(sea_xz[..., 0], sea_xz[..., 1], xz).astype(np.uint8)
        contours, _ = cv2.findContours(region, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(out, contours, -1, GEO_BGR, 1, cv2.LINE_AA)
        if contours:
            ys, xs = np.nonzero(region)
            _label(out, g.name, np.array([xs.mean(), ys.mean()]), GEO_BGR)
    rows = horizon_rows(sea_xz)
    cols = np.flatnonzero(np.isfinite(rows))
    if len(cols) >= 2:
        pts = np.stack([cols, rows[cols]], axis=-1)
        line = np.round(pts).astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(out, [line], False, HORIZON_BGR, 1, cv2.LINE_AA)
    scale = max(0.4, w / 1800)
    text = (f"excluded: red; image polygons: yellow; geo: magenta; horizon: green; "
            f"sea open {100 * open_sea_share(mask, sea_xz):.0f} %")
    cv2.putText(out, text, (8, int(22 * scale)), cv2.FONT_HERSHEY_SIMPLEX, 0.5 * scale, (255, 255, 255), 1,
                cv2.LINE_AA)
    return out


def _label(image: np.ndarray, name: str, at: np.ndarray, colour: tuple[int, int, int]) -> None:
    if name:
        scale = max(0.4, image.shape[1] / 1800)
        cv2.putText(image, name, (int(at[0]), int(at[1])), cv2.FONT_HERSHEY_SIMPLEX, 0.5 * scale, colour, 1,
                    cv2.LINE_AA)


def run(args: argparse.Namespace) -> int:
    config = load_config(args.config)
    plan = plan_source(config, args.config)
    rig, site = plan.calibration.rig, plan.calibration.site
    if site is None:
        raise ConfigError(args.config, "site", "a site (lat_deg, lon_deg, height_m, heading_deg)")
    sea_xz = sea_grid(rig, site)
    mask = build_search_mask(config.masks, rig, site, args.config, sea_xz)
    if mask is None:
        mask = np.ones((rig.height, rig.width), dtype=bool)
    recording = args.recording
    if recording is None and args.frame is None and isinstance(config.cameras, ReplayCameras):
        recording = Path(config.cameras.path)
    image, where = _frame(args, recording, rig.width, rig.height)
    picture = draw(image, config.masks, mask, sea_xz, geo_polygons_xz(config.masks, site))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(args.out), picture):
        raise ConfigError("command line", "--out", "a writable PNG path", str(args.out))
    print(f"{args.out}: {rig.width}x{rig.height} over {where}; {len(config.masks.image)} image and "
          f"{len(config.masks.geo)} geo masks exclude {100 * float((~mask).mean()):.1f} % of the image, "
          f"{100 * (1 - open_sea_share(mask, sea_xz)):.1f} % of the sea")
    return 0

