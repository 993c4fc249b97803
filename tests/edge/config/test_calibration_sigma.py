"""The calibration file's standard errors and the site's tilt bound (issue 16): older files load
unchanged, `mast-stereo calibrate` writes the fit's standard errors, round trips, clear errors."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml

from edge.cli import main
from edge.config.calibration import (
    Calibration,
    calibration_from_dict,
    calibration_to_dict,
    load_calibration,
)
from edge.core.calibfit import fit_rig, rig_sigma
from edge.core.calibsigma import CameraSigma, RigSigma
from edge.core.site import Site
from edge.errors import ConfigError

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = sorted((ROOT / "config/calibration").glob("*.yaml"))
SIGMA = RigSigma(CameraSigma((0.004, 0.006, 0.02), 0.8), CameraSigma((0.005, 0.003, 0.015), 0.6))


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_older_calibration_files_load_unchanged(path: Path) -> None:
    cal = load_calibration(path)
    assert cal.sigma is None and (cal.site is None or cal.site.tilt_sigma_deg is None)
    assert calibration_to_dict(cal) == calibration_to_dict(Calibration(cal.rig, cal.site))
    data = yaml.safe_load(path.read_text())
    assert "rotation_sigma_deg" not in str(calibration_to_dict(cal)) and "tilt" not in str(data)


def test_standard_errors_and_tilt_round_trip() -> None:
    cal = load_calibration(EXAMPLES[0])
    assert cal.site is not None
    site = Site(cal.site.lat_deg, cal.site.lon_deg, cal.site.height_m, cal.site.heading_deg, 0.02)
    data = calibration_to_dict(Calibration(cal.rig, site, SIGMA))
    assert data["cameras"]["left"]["rotation_sigma_deg"] == [0.004, 0.006, 0.02]
    assert data["cameras"]["right"]["focal_sigma_px"] == 0.6 and data["site"]["tilt_sigma_deg"] == 0.02
    back = calibration_from_dict(yaml.safe_load(yaml.safe_dump(data)), "x.yaml")
    assert back.sigma == SIGMA and back.site == site


def _with(cal_dict: dict, **cams: dict) -> dict:
    out = copy.deepcopy(cal_dict)
    for side, keys in cams.items():
        out["cameras"][side].update(keys)
    return out


@pytest.mark.parametrize(("change", "key", "expected"), [
    ({"left": {"rotation_sigma_deg": [0.01, 0.01, 0.01]}}, "cameras.left.focal_sigma_px", "together"),
    ({"left": {"rotation_sigma_deg": [0.01, 0.01, 0.01], "focal_sigma_px": 1.0}},
     "cameras.right.rotation_sigma_deg", "both cameras"),
    ({"left": {"rotation_sigma_deg": [0.01, -0.01, 0.01], "focal_sigma_px": 1.0},
      "right": {"rotation_sigma_deg": [0.01, 0.01, 0.01], "focal_sigma_px": 1.0}},
     "cameras.left.rotation_sigma_deg[1]", ""),
    ({"right": {"focal_sigma_px": "big"}}, "cameras.right.focal_sigma_px", ""),
])
def test_bad_standard_errors_name_the_key(change: dict, key: str, expected: str) -> None:
    base = calibration_to_dict(load_calibration(EXAMPLES[0]))
    with pytest.raises(ConfigError) as err:
        calibration_from_dict(_with(base, **change), "cal.yaml")
    assert err.value.key == key and expected in err.value.expected and "cal.yaml" in str(err.value)


def test_bad_tilt_names_the_key() -> None:
    base = calibration_to_dict(load_calibration(EXAMPLES[0]))
    base["site"]["tilt_sigma_deg"] = -0.1
    with pytest.raises(ConfigError) as err:
        calibration_from_dict(base, "cal.yaml")
    assert err.value.key == "site.tilt_sigma_deg"


def test_calibrate_writes_the_fit_standard_errors(tmp_path: Path) -> None:
    rig = load_calibration(EXAMPLES[0]).rig
    rng = np.random.default_rng(3)
    uv = rng.uniform((175, 20), (700, 460), size=(40, 2))
    z = np.exp(rng.uniform(np.log(80), np.log(3000), 40))
    pts = np.column_stack([rig.left.pixel_to_normalised(uv) * z[:, None], z]) - (rig.baseline_m / 2, 0, 0)
    ul, ur = rig.project(pts)
    ul, ur = ul + rng.normal(0, 0.3, ul.shape), ur + rng.normal(0, 0.3, ur.shape)
    lines = ["name,x_m,y_m,z_m,u_left,v_left,u_right,v_right"]
    lines += [",".join([f"p{i}", *(repr(float(v)) for v in (*pts[i], *ul[i], *ur[i]))]) for i in range(40)]
    (tmp_path / "lm.csv").write_text("\n".join(lines) + "\n")
    out = tmp_path / "cal.yaml"
    assert main(["calibrate", str(tmp_path / "lm.csv"), "--model", "pinhole", "--baseline", "8.14",
                 "--width", "720", "--height", "480", "--out", str(out),
                 "--report", str(tmp_path / "r.txt")]) == 0
    written = load_calibration(out)
    want = rig_sigma(fit_rig(pts, ul, ur, model="pinhole", baseline_m=8.14, width=720, height=480))
    assert written.sigma is not None
    for side in ("left", "right"):
        got, ref = getattr(written.sigma, side), getattr(want, side)
        assert got.rotation_sigma_deg == pytest.approx(ref.rotation_sigma_deg, rel=1e-9)
        assert got.focal_sigma_px == pytest.approx(ref.focal_sigma_px, rel=1e-9)
        assert 0.0 < got.rotation_sigma_deg[0] < 0.05 and 0.0 < got.focal_sigma_px < 5.0


def test_geoid_separation_round_trips_and_a_bad_one_names_the_key() -> None:
    base = calibration_to_dict(load_calibration(EXAMPLES[0]))
    base["site"]["geoid_separation_m"] = 37.4
    cal = calibration_from_dict(copy.deepcopy(base), "cal.yaml")
    assert cal.site is not None and cal.site.geoid_separation_m == 37.4
    assert calibration_to_dict(cal)["site"]["geoid_separation_m"] == 37.4
    base["site"]["geoid_separation_m"] = 300.0  # no geoid is that far from the ellipsoid
    with pytest.raises(ConfigError) as err:
        calibration_from_dict(base, "cal.yaml")
    assert err.value.key == "site.geoid_separation_m"
