"""`mast-stereo calibrate`: fit the rig's camera models from surveyed landmarks, write calibration + report.

    mast-stereo calibrate LANDMARKS.csv --model {pinhole,poly10} --baseline M --width W --height H
        [--site FILE | --site-lat DEG --site-lon DEG --site-height M --site-heading DEG]
        [--cx PX --cy PX] [--fit-k3] --out CALIB.yaml [--report REPORT.txt]

LANDMARKS.csv has a header row. Columns: `name`; then either `x_m,y_m,z_m`
(world frame: origin at the baseline midpoint, X right along the baseline,
Y down, Z forward) or `lat_deg,lon_deg,height_m` (WGS-84, height above mean
sea level; needs the site); then `u_left,v_left,u_right,v_right` (pixels,
(0, 0) = centre of the top-left pixel). A row whose world cells are empty is
a tie point (a feature seen in both images but not surveyed; it constrains
the cameras' relative rotation, eq. 3.7); a row whose left or right pixel
cells are empty is a landmark seen by one camera only. Lines starting with
`#` are comments.

--site FILE reads a YAML file holding either a `site:` mapping (an appliance
config or a calibration) or the site mapping itself (lat_deg, lon_deg,
height_m, heading_deg); the four --site-* options give the same inline. The
site is also written into the calibration. --cx/--cy fix the principal point
(default: the image centre); --fit-k3 adds the pinhole's k3 term.

Writes CALIB.yaml (the calibration format of docs/calibration.md, validated by loading it
back), with each camera's `rotation_sigma_deg` and `focal_sigma_px` (the fit's
standard errors: from its Jacobian and residual variance, edge.core.calibfit),
which the pipeline carries into the fixes' sigma and the height test's row
sigma (edge.core.calibsigma); and a report (stdout, or --report FILE): per-point residuals in px,
triangulated range error of every landmark both cameras see, the vertical
disparity left after calibration, RMS and the noise estimate, parameter
standard errors and the worst points. Bad input and layouts the landmarks
cannot determine (too few, collinear, clustered) exit 78 with one line.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from edge.config.calibration import Calibration, calibration_from_dict, calibration_to_dict, site_from_dict
from edge.config.schema import load_yaml
from edge.core.calibfit import CalibrationError, RigFit, fit_rig, relative_rotation_deg, rig_sigma
from edge.core.geodesy import geodetic_to_world
from edge.core.site import Site
from edge.errors import ConfigError

WORLD_COLUMNS = (("x_m", "y_m", "z_m"), ("lat_deg", "lon_deg", "height_m"))
PIXEL_COLUMNS = ("u_left", "v_left", "u_right", "v_right")
SITE_OPTIONS = ("site_lat", "site_lon", "site_height", "site_heading")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "landmarks", type=Path, metavar="LANDMARKS.csv", help="surveyed landmarks and tie points"
    )
    parser.add_argument("--model", choices=("pinhole", "poly10"), required=True, help="camera model to fit")
    parser.add_argument("--baseline", type=float, required=True, metavar="M", help="baseline length, metres")
    parser.add_argument("--width", type=int, required=True, metavar="W", help="image width, pixels")
    parser.add_argument("--height", type=int, required=True, metavar="H", help="image height, pixels")
    parser.add_argument("--site", type=Path, metavar="FILE", help="YAML file with the site")
    for name, unit in zip(SITE_OPTIONS, ("DEG", "DEG", "M", "DEG"), strict=True):
        parser.add_argument(f"--{name.replace('_', '-')}", type=float, metavar=unit, dest=name)
    parser.add_argument("--cx", type=float, metavar="PX", help="principal point u (default: image centre)")
    parser.add_argument("--cy", type=float, metavar="PX", help="principal point v (default: image centre)")
    parser.add_argument("--fit-k3", action="store_true", help="also fit the pinhole k3 term")
    parser.add_argument("--out", type=Path, required=True, metavar="CALIB.yaml", help="calibration to write")
    parser.add_argument("--report", type=Path, metavar="FILE", help="write the report here (default: stdout)")


def _site(args: argparse.Namespace) -> Site | None:
    given = [getattr(args, name) for name in SITE_OPTIONS]
    if args.site is not None:
        if any(v is not None for v in given):
            raise ConfigError(
                "command line", "--site", "either --site FILE or the --site-* options, not both"
            )
        data = load_yaml(args.site)
        if isinstance(data, dict) and "site" in data:
            return site_from_dict(data["site"], args.site, "site")
        return site_from_dict(data, args.site, "")
    if all(v is None for v in given):
        return None
    for name, value in zip(SITE_OPTIONS, given, strict=True):
        if value is None:
            raise ConfigError(
                "command line",
                f"--{name.replace('_', '-')}",
                "a value (the four --site-* options go together)",
            )
    data = dict(zip(("lat_deg", "lon_deg", "height_m", "heading_deg"), given, strict=True))
    return site_from_dict(data, "command line", "--site")


def _number(text: str, path: Path, key: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ConfigError(path, key, "a number", text) from None
    if not math.isfinite(value):
        raise ConfigError(path, key, "a finite number", text)
    return value


def read_landmarks(path: Path, site: Site | None) -> tuple[list[str], np.ndarray, np.ndarray, np.ndarray]:
    """(names, world_m (n, 3) NaN for tie points, uv_left (n, 2), uv_right (n, 2)) from the CSV."""
    try:
        with path.open(newline="", encoding="utf-8") as f:
            lines = [
                (i, row)
                for i, row in enumerate(csv.reader(f), start=1)
                if row and any(c.strip() for c in row) and not row[0].lstrip().startswith("#")
            ]
    except OSError as exc:
        raise ConfigError(path, "", "a readable CSV file", exc.strerror or str(exc)) from None
    except (UnicodeDecodeError, csv.Error) as exc:
        raise ConfigError(path, "", "a UTF-8 CSV file", str(exc)) from None
    if not lines:
        raise ConfigError(
            path,
            "header",
            "a header row: name, x_m, y_m, z_m (or lat_deg, lon_deg, height_m), " + ", ".join(PIXEL_COLUMNS),
        )
    header = [c.strip() for c in lines[0][1]]
    world_cols = next((cols for cols in WORLD_COLUMNS if set(cols) <= set(header)), None)
    expected = ["name", *(world_cols or WORLD_COLUMNS[0]), *PIXEL_COLUMNS]
    if world_cols is None or sorted(header) != sorted(expected):
        raise ConfigError(
            path,
            "header",
            f"the columns {', '.join(expected)} (or lat_deg, lon_deg, height_m for x_m, y_m, z_m)",
            ", ".join(header),
        )
    if world_cols == WORLD_COLUMNS[1] and site is None:
        raise ConfigError(
            path,
            "lat_deg",
            "a site to place latitude/longitude in the world frame: --site FILE "
            "or --site-lat/--site-lon/--site-height/--site-heading",
        )
    names: list[str] = []
    values = np.full((len(lines) - 1, 7), np.nan)
    for r, (line_no, row) in enumerate(lines[1:]):
        if len(row) != len(header):
            raise ConfigError(path, f"line {line_no}", f"{len(header)} cells", len(row))
        cells = dict(zip(header, (c.strip() for c in row), strict=True))
        name = cells["name"] or f"line {line_no}"
        if name in names:
            raise ConfigError(path, f"line {line_no}, name", "a name not used by another row", name)
        names.append(name)
        for group, (lo, hi) in (
            (world_cols, (0, 3)),
            (PIXEL_COLUMNS[:2], (3, 5)),
            (PIXEL_COLUMNS[2:], (5, 7)),
        ):
            present = [bool(cells[c]) for c in group]
            if any(present) and not all(present):
                missing = group[present.index(False)]
                raise ConfigError(
                    path,
                    f"line {line_no} ({name}), {missing}",
                    f"a value (fill all of {', '.join(group)} or none)",
                )
            if all(present):
                values[r, lo:hi] = [_number(cells[c], path, f"line {line_no} ({name}), {c}") for c in group]
        if np.isnan(values[r, 3:]).any() and np.isnan(values[r, :3]).any():
            raise ConfigError(
                path,
                f"line {line_no} ({name})",
                "world coordinates and at least one camera's pixels, or pixels in both cameras (a tie point)",
            )
    world = values[:, :3]
    if world_cols == WORLD_COLUMNS[1]:
        # lo, hi were column indices above, bounds here
        for c, (lo, hi) in zip(world_cols[:2], ((-90.0, 90.0), (-180.0, 180.0)), strict=True):  # type: ignore[assignment]
            col = world[:, world_cols.index(c)]
            bad = np.flatnonzero((col < lo) | (col > hi))
            if bad.size:
                raise ConfigError(
                    path, f"row {names[bad[0]]!r}, {c}", f"a value in [{lo}, {hi}]", col[bad[0]]
                )
        assert site is not None  # refused above without one
        world = geodetic_to_world(world[:, 0], world[:, 1], world[:, 2], site)
    return names, world, values[:, 3:5], values[:, 5:7]


def format_report(
    fit: RigFit, world_m: np.ndarray, uv_left: np.ndarray, uv_right: np.ndarray, header: str
) -> str:
    rig = fit.rig
    both = np.isfinite(uv_left).all(axis=1) & np.isfinite(uv_right).all(axis=1)
    z_fit = np.full(len(world_m), np.nan)
    if both.any():
        z_fit[both] = rig.triangulate(uv_left[both], uv_right[both])[:, 2]
    out = [
        header,
        f"landmarks: left {fit.left.n_observations // 2}, right {fit.right.n_observations // 2}; "
        f"tie points: {int(fit.is_tie.sum())}",
        f"pixel noise estimate sigma = sqrt(SSR / (N - P)) = {fit.sigma_px:.3f} px "
        f"(N = {fit.n_observations} residuals, P = {fit.n_parameters} parameters); "
        f"RMS residual {fit.rms_px:.3f} px",
        f"  left: RMS {fit.left.rms_px:.3f} px, sigma {fit.left.sigma_px:.3f} px; "
        f"right: RMS {fit.right.rms_px:.3f} px, sigma {fit.right.sigma_px:.3f} px",
        "",
        "per point (residual = model - observed, px; vert = vertical disparity left after calibration, px;",
        "Z err = triangulated - surveyed Z, m):",
        f"{'name':<16} {'Z m':>8} {'L du':>6} {'L dv':>6} {'R du':>6} {'R dv':>6} {'vert':>6} "
        f"{'Z err m':>8} {'Z err %':>7}",
    ]

    def cell(value: float, fmt: str, width: int) -> str:
        return f"{value:{width}{fmt}}" if np.isfinite(value) else " " * (width - 1) + "-"

    for i, name in enumerate(fit.names):
        z, dz = world_m[i, 2], z_fit[i] - world_m[i, 2]
        out.append(
            f"{name[:16]:<16} {cell(z, '.1f', 8)} "
            + " ".join(
                cell(v, ".2f", 6)
                for v in (*fit.left.residuals_px[i], *fit.right.residuals_px[i], fit.vertical_px[i])
            )
            + f" {cell(dz, '.2f', 8)} {cell(100.0 * dz / z, '.2f', 7)}"
        )
    out += ["", "parameters (value, 1-sigma standard error):"]
    for cam in (fit.left, fit.right):
        out.append(f"  {cam.side} ({cam.camera.to_dict()['model']}):")
        out += [f"    {e.name:<7} {e.value:16.9g}  +- {e.std_error:.3g}" for e in cam.estimates]
    rel = relative_rotation_deg(rig)
    out += [
        f"relative rotation of the right camera (R_l^T R_r): rx {rel[0]:.4f}, ry {rel[1]:.4f}, "
        f"rz {rel[2]:.4f} deg",
        "",
        "worst points: " + ", ".join(f"{n} {r:.2f} px" for n, r in fit.worst(5)),
    ]
    return "\n".join(out) + "\n"


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    except OSError as exc:
        raise ConfigError(path, "", "a writable file", exc.strerror or str(exc)) from None


def run(args: argparse.Namespace) -> int:
    site = _site(args)
    names, world, uv_left, uv_right = read_landmarks(args.landmarks, site)
    pp = None
    if (args.cx is None) != (args.cy is None):
        raise ConfigError("command line", "--cx/--cy", "both or neither")
    if args.cx is not None:
        pp = (args.cx, args.cy)
    try:
        fit = fit_rig(
            world,
            uv_left,
            uv_right,
            model=args.model,
            baseline_m=args.baseline,
            width=args.width,
            height=args.height,
            principal_point=pp,
            fit_k3=args.fit_k3,
            names=names,
        )
    except CalibrationError as exc:
        raise ConfigError(args.landmarks, exc.subject, exc.expected, exc.found) from None
    except ValueError as exc:  # e.g. a non-positive image size or baseline reaching StereoRig
        raise ConfigError("command line", "--baseline/--width/--height", "a valid rig", str(exc)) from None
    data: dict[str, Any] = calibration_to_dict(Calibration(fit.rig, site, rig_sigma(fit)))
    calibration_from_dict(data, args.out)  # the fitted model must pass the loader's own checks
    pp_text = "image centre" if pp is None else f"({pp[0]}, {pp[1]})"
    header = (
        f"mast-stereo calibrate: {args.model}, baseline {args.baseline} m, image {args.width}x{args.height}"
        f", principal point {pp_text} (fixed), from {args.landmarks}"
    )
    summary = (
        f"# {header}\n# sigma {fit.sigma_px:.3f} px over {fit.n_observations} residuals, "
        f"worst {fit.worst(1)[0][1]:.2f} px\n"
    )
    _write_atomic(args.out, summary + yaml.safe_dump(data, sort_keys=False, default_flow_style=None))
    report = format_report(fit, world, uv_left, uv_right, header)
    if args.report is None:
        print(report, end="")
    else:
        _write_atomic(args.report, report)
        print(f"wrote {args.out} and {args.report}: sigma {fit.sigma_px:.3f} px, RMS {fit.rms_px:.3f} px")
    return 0
