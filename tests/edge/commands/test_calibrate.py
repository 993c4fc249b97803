"""`mast-stereo calibrate` end to end: CSV in, calibration YAML + report out; bad input -> exit 78.

The truth is the example rig (config/calibration/akashi-pinhole.yaml); landmarks
are projected through it with 0.3 px noise and written as CSV in world X/Y/Z
or as WGS-84 latitude/longitude/height (converted back by the command through
the site). The real CLI runs as a subprocess.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml
from helpers import run_cli

from edge.config.calibration import load_calibration
from edge.core.geodesy import world_to_geodetic
from edge.errors import EX_CONFIG

ROOT = Path(__file__).resolve().parents[3]
TRUTH = load_calibration(ROOT / "config/calibration/akashi-pinhole.yaml")
RIG, SITE = TRUTH.rig, TRUTH.site
SITE_ARGS = ["--site-lat", "34.63", "--site-lon", "135.02", "--site-height", "25", "--site-heading", "180"]




def observations(n: int, seed: int, noise: float = 0.3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World points (50 m .. 3 km, over the image, inside both images) and their noisy pixels."""
    rng = np.random.default_rng(seed)
    uv = rng.uniform((175, 20), (700, 460), size=(n, 2))  # room for the ~150 px disparity at 50 m
    z = np.exp(rng.uniform(np.log(50), np.log(3000), n))
    pts = np.column_stack([RIG.left.pixel_to_normalised(uv) * z[:, None], z]) - (RIG.baseline_m / 2, 0, 0)
    ul, ur = RIG.project(pts)
    assert np.isfinite(ur).all() and (ur[:, 0] > 0).all()
    return pts, ul + rng.normal(0, noise, ul.shape), ur + rng.normal(0, noise, ur.shape)


def write_csv(
    path: Path,
    world: np.ndarray,
    ul: np.ndarray,
    ur: np.ndarray,
    columns=("x_m", "y_m", "z_m"),
    tie_rows: int = 0,
) -> Path:
    lines = [
        "# surveyed landmarks, pixels from the first frame pair",
        ",".join(["name", *columns, "u_left", "v_left", "u_right", "v_right"]),
    ]
    for i in range(len(world)):
        w = ["", "", ""] if i >= len(world) - tie_rows else [repr(float(v)) for v in world[i]]
        lines.append(",".join([f"p{i}", *w, *(repr(float(v)) for v in (*ul[i], *ur[i]))]))
    path.write_text("\n".join(lines) + "\n")
    return path


def calibrate(
    tmp_path: Path, csv: Path, *extra: str | Path, model: str = "pinhole"
) -> subprocess.CompletedProcess:
    return run_cli(
        "calibrate",
        csv,
        "--model",
        model,
        "--baseline",
        "8.14",
        "--width",
        "720",
        "--height",
        "480",
        "--out",
        tmp_path / "cal.yaml",
        *extra,
    )


@pytest.mark.parametrize("model", ["pinhole", "poly10"])
def test_calibrate_writes_a_loadable_calibration_and_a_report(tmp_path: Path, model: str) -> None:
    world, ul, ur = observations(60, seed=1)
    csv = write_csv(tmp_path / "lm.csv", world, ul, ur, tie_rows=10)
    result = calibrate(tmp_path, csv, *SITE_ARGS, "--report", tmp_path / "report.txt", model=model)
    assert result.returncode == 0, result.stderr
    cal = load_calibration(tmp_path / "cal.yaml")
    assert cal.site == SITE and cal.rig.baseline_m == 8.14 and cal.rig.left.to_dict()["model"] == model
    for side in ("left", "right"):
        got, want = getattr(cal.rig, side).rotation_deg, getattr(RIG, side).rotation_deg
        assert np.abs(np.subtract(got, want)).max() < 0.1
    report = (tmp_path / "report.txt").read_text()
    assert "sigma = sqrt(SSR / (N - P))" in report and "worst points:" in report
    assert "tie points: 10" in report and "rz_deg" in report and ("a9" in report) == (model == "poly10")
    per_point = [line for line in report.splitlines() if line.split(" ")[0] in {f"p{i}" for i in range(60)}]
    assert len(per_point) == 60
    sigma = float(report.split("sigma = sqrt(SSR / (N - P)) = ")[1].split()[0])
    assert 0.24 <= sigma <= 0.36
    assert "sigma" in result.stdout and str(tmp_path / "cal.yaml") in result.stdout


def test_latlon_landmarks_give_the_same_calibration(tmp_path: Path) -> None:
    world, ul, ur = observations(30, seed=2)
    lat, lon, h = world_to_geodetic(world, SITE)
    xyz = write_csv(tmp_path / "xyz.csv", world, ul, ur)
    geo = write_csv(
        tmp_path / "geo.csv",
        np.column_stack([lat, lon, h]),
        ul,
        ur,
        columns=("lat_deg", "lon_deg", "height_m"),
    )
    site_file = tmp_path / "site.yaml"
    site_file.write_text(
        yaml.safe_dump(
            {"site": {"lat_deg": 34.63, "lon_deg": 135.02, "height_m": 25.0, "heading_deg": 180.0}}
        )
    )
    assert calibrate(tmp_path, xyz).returncode == 0
    from_xyz = yaml.safe_load((tmp_path / "cal.yaml").read_text())
    result = calibrate(tmp_path, geo, "--site", site_file)
    assert result.returncode == 0, result.stderr
    from_geo = yaml.safe_load((tmp_path / "cal.yaml").read_text())
    for side in ("left", "right"):
        a, b = from_xyz["cameras"][side], from_geo["cameras"][side]
        assert np.allclose(a["rotation_deg"], b["rotation_deg"], atol=1e-6)
        assert np.allclose(a["fx"], b["fx"], rtol=1e-7)
    assert "site" not in from_xyz and from_geo["site"]["heading_deg"] == 180.0


def test_report_to_stdout_and_site_from_a_config_file(tmp_path: Path) -> None:
    world, ul, ur = observations(20, seed=3)
    result = calibrate(
        tmp_path,
        write_csv(tmp_path / "lm.csv", world, ul, ur),
        "--site",
        ROOT / "config/site.example.yaml",
        model="poly10",
    )
    assert result.returncode == 0, result.stderr
    assert "per point" in result.stdout and "relative rotation" in result.stdout
    assert load_calibration(tmp_path / "cal.yaml").site == SITE


def _collinear(tmp_path: Path) -> Path:
    u = np.linspace(175, 700, 20)
    uv = np.column_stack([u, 200.0 + 0.2 * np.cos(u)])
    z = np.linspace(300, 3000, 20)
    world = np.column_stack([RIG.left.pixel_to_normalised(uv) * z[:, None], z]) - (RIG.baseline_m / 2, 0, 0)
    return write_csv(tmp_path / "line.csv", world, *RIG.project(world))


def _few(tmp_path: Path) -> Path:
    return write_csv(tmp_path / "few.csv", *observations(8, seed=4))


def _csv_text(text: str):
    def make(tmp_path: Path) -> Path:
        path = tmp_path / "lm.csv"
        path.write_text(text)
        return path

    return make


HEADER = "name,x_m,y_m,z_m,u_left,v_left,u_right,v_right\n"
BAD_RUNS = {
    "degenerate layout": (_collinear, [], "line.csv: left camera: expected landmarks not all on one line"),
    "too few landmarks": (_few, [], "few.csv: left camera: expected at least 9 landmarks"),
    "wrong type": (
        _csv_text(HEADER + "a,1,2,300,abc,1,2,3\n"),
        [],
        "lm.csv: line 2 (a), u_left: expected a number",
    ),
    "non-finite value": (
        _csv_text(HEADER + "a,1,2,inf,1,1,2,3\n"),
        [],
        "line 2 (a), z_m: expected a finite number",
    ),
    "missing cell": (_csv_text(HEADER + "a,1,2,300,1,,2,3\n"), [], "line 2 (a), v_left: expected a value"),
    "unknown column": (
        _csv_text("name,x_m,y_m,z_m,u_left,v_left,u_right,v_right,colour\n"),
        [],
        "lm.csv: header: expected the columns name, x_m",
    ),
    "duplicate name": (
        _csv_text(HEADER + "a,1,2,300,1,1,2,3\na,1,2,300,1,1,2,3\n"),
        [],
        "line 3, name: expected a name not used by another row",
    ),
    "lat/lon without site": (
        _csv_text("name,lat_deg,lon_deg,height_m,u_left,v_left,u_right,v_right\na,34.6,135.0,0,1,1,2,3\n"),
        [],
        "lm.csv: lat_deg: expected a site",
    ),
    "unreadable landmarks": (
        lambda tmp_path: tmp_path / "absent.csv",
        [],
        "absent.csv: expected a readable CSV",
    ),
    "bad site file key": (
        _few,
        ["--site", "SITE:{lat_deg: 34.6, lon_deg: 135.0, height_m: 25, heading: 180}"],
        "site.yaml: heading: expected a known key (did you mean 'heading_deg'?)",
    ),
    "site out of range": (
        _few,
        ["--site", "SITE:{lat_deg: 134.6, lon_deg: 135.0, height_m: 25, heading_deg: 0}"],
        "site.yaml: lat_deg: expected a finite number in [-90.0, 90.0], found 134.6",
    ),
    "site file not YAML": (_few, ["--site", "SITE:{lat_deg: [34.6\n"], "site.yaml: expected a YAML document"),
    "partial site options": (_few, ["--site-lat", "34.6"], "--site-lon: expected a value"),
}


@pytest.mark.parametrize("case", sorted(BAD_RUNS))
def test_bad_input_exits_78_with_one_line_naming_the_key(tmp_path: Path, case: str) -> None:
    make_csv, extra, words = BAD_RUNS[case]
    args = []
    for arg in extra:
        if arg.startswith("SITE:"):
            site = tmp_path / "site.yaml"
            site.write_text(arg[5:])
            arg = str(site)
        args.append(arg)
    result = calibrate(tmp_path, make_csv(tmp_path), *args)
    assert result.returncode == EX_CONFIG, (result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mast-stereo calibrate: configuration error: ")
    assert words in lines[0], lines[0]
    assert not (tmp_path / "cal.yaml").exists()
