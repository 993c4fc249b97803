"""edge.config.calibration: the calibration file (docs/calibration.md) <-> Calibration, and every
way it can be wrong.

Round trips (dict -> Calibration -> dict, and through a YAML file) must be
exact; each bad calibration must raise a ConfigError naming the key, and the
real CLI (`mast-stereo check-config --calibration`) must exit 78 with one line.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from helpers import run_cli
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.config.calibration import Calibration, calibration_from_dict, calibration_to_dict, load_calibration
from edge.core.camera import PinholeCamera, Poly10Camera, StereoRig
from edge.core.site import Site
from edge.errors import EX_CONFIG, ConfigError

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = ("akashi-pinhole.yaml", "akashi-poly10.yaml")


def example(name: str = "akashi-pinhole.yaml") -> dict[str, Any]:
    return yaml.safe_load((ROOT / "config/calibration" / name).read_text())


@pytest.mark.parametrize("name", EXAMPLES)
def test_examples_load_and_describe_the_thesis_rig(name: str) -> None:
    cal = load_calibration(ROOT / "config/calibration" / name)
    rig = cal.rig
    assert (rig.width, rig.height, rig.baseline_m) == (720, 480, 8.14)
    hfov = np.degrees(2 * np.arctan(360 / rig.focal_px()))
    assert 42.5 < hfov < 43.5
    assert cal.site == Site(34.63, 135.02, 25.0, 180.0)
    assert calibration_from_dict(calibration_to_dict(cal), "x") == cal


def test_the_two_examples_describe_the_same_rig() -> None:
    """The poly10 example was fitted to the pinhole one: same pixels for the same world points."""
    pin, poly = (load_calibration(ROOT / "config/calibration" / n).rig for n in EXAMPLES)
    u, v = np.meshgrid(np.linspace(20, 700, 9), np.linspace(20, 460, 7))
    xy = pin.left.pixel_to_normalised(np.stack([u.ravel(), v.ravel()], -1))
    points = np.concatenate([xy * 800.0, np.full((len(xy), 1), 800.0)], axis=1) - (4.07, 0, 0)
    for a, b in zip(pin.project(points), poly.project(points), strict=True):
        assert np.nanmax(np.abs(a - b)) < 0.2


finite = st.floats(min_value=-3.0, max_value=3.0, allow_nan=False)


@settings(max_examples=40, deadline=None)
@given(
    st.floats(min_value=0.1, max_value=500.0),
    st.floats(min_value=300.0, max_value=3000.0),
    st.tuples(finite, finite, finite),
    st.floats(min_value=-0.05, max_value=0.05),
    st.booleans(),
)
def test_round_trip_is_exact(baseline: float, f_px: float, rot: tuple, k1: float, with_site: bool) -> None:
    left = PinholeCamera(f_px, f_px * 1.01, 359.5, 239.5, (k1, 0.0, 1e-4, -1e-4, 0.0), rot)
    coeffs = (1 / f_px, 1e-7, 0.0, k1 / f_px**3, 0.0, 1 / f_px, 0.0, 0.0, k1 / f_px**3, 0.0)
    right = Poly10Camera(360.0, 240.0, coeffs, rot[::-1])
    cal = Calibration(
        StereoRig(baseline, 720, 480, left, right), Site(34.6, 135.0, 25.0, 180.0) if with_site else None
    )
    data = calibration_to_dict(cal)
    assert calibration_from_dict(yaml.safe_load(yaml.safe_dump(data)), "x") == cal
    assert ("site" in data) == with_site and set(data) >= {"baseline_m", "image", "cameras"}


def _mutated(path: tuple, value: Any, name: str = "akashi-pinhole.yaml") -> dict:
    data = copy.deepcopy(example(name))
    node = data
    for part in path[:-1]:
        node = node[part]
    if value is _DELETE:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return data


_DELETE = object()
BAD = [
    (("baseline_m",), -8.14, "baseline_m", "> 0"),
    (("baseline_m",), 0, "baseline_m", "> 0"),
    (("baseline_m",), _DELETE, "baseline_m", "required key is missing"),
    (("image", "width"), "720", "image.width", "an integer"),
    (("cameras", "left", "model"), "pinhol", "cameras.left.model", "did you mean 'pinhole'?"),
    (("cameras", "left", "dist"), [0.0, 0.0, 0.0, 0.0], "cameras.left.dist", "a list of 5 numbers"),
    (("cameras", "left", "fx"), float("nan"), "cameras.left.fx", "finite"),
    (("cameras", "left", "fy"), -900.0, "cameras.left.fy", "> 0"),
    (("cameras", "left", "cx"), 900.0, "cameras.left.cx", "inside the image"),
    (("cameras", "right", "rotation_deg"), [0, 0, float("inf")], "cameras.right.rotation_deg[2]", "finite"),
    (("cameras", "right", "focal"), 900, "cameras.right.focal", "a known key"),
    (("cameras", "left", "dist"), [-0.9, 0.0, 0.0, 0.0, 0.0], "cameras.left", "invertible"),
    (("site", "lat_deg"), 95.0, "site.lat_deg", "[-90.0, 90.0]"),
    (("site", "heading"), 180.0, "site.heading", "did you mean 'heading_deg'?"),
    (("cameras", "middle"), {}, "cameras.middle", "a known key"),
]


@pytest.mark.parametrize(("path", "value", "key", "words"), BAD, ids=[b[2] + ":" + b[3] for b in BAD])
def test_bad_calibrations_name_the_key(path: tuple, value: Any, key: str, words: str) -> None:
    with pytest.raises(ConfigError) as info:
        calibration_from_dict(_mutated(path, value), "cal.yaml")
    assert info.value.key == key and words in info.value.message, info.value.message


@pytest.mark.parametrize(
    ("index", "value", "key", "words"),
    [(0, -1e-3, "cameras.left.coeffs[0]", "> 0"), (5, 0.0, "cameras.left.coeffs[5]", "> 0")],
)
def test_poly10_needs_positive_a0_a5(index: int, value: float, key: str, words: str) -> None:
    data = example("akashi-poly10.yaml")
    data["cameras"]["left"]["coeffs"][index] = value
    with pytest.raises(ConfigError) as info:
        calibration_from_dict(data, "cal.yaml")
    assert info.value.key == key and words in info.value.message


def test_poly10_needs_ten_coefficients_and_key_prefix_is_used() -> None:
    data = example("akashi-poly10.yaml")
    data["cameras"]["right"]["coeffs"] = data["cameras"]["right"]["coeffs"][:9]
    with pytest.raises(ConfigError) as info:
        calibration_from_dict(data, "meta.yaml", key_prefix="calibration")
    assert info.value.key == "calibration.cameras.right.coeffs"
    assert "a list of 10 numbers" in info.value.message




@pytest.mark.parametrize(
    ("path", "value", "key"),
    [
        (("baseline_m",), -8.14, "baseline_m"),  # negative baseline
        (("image",), _DELETE, "image"),  # missing key
        (("cameras", "left", "fx"), "914", "cameras.left.fx"),  # wrong type
        (("cameras", "left", "skew"), 0.0, "cameras.left.skew"),  # unknown key
        (("cameras", "right", "cy"), float("nan"), "cameras.right.cy"),  # non-finite
    ],
)
def test_cli_refuses_bad_calibration_with_exit_78(tmp_path: Path, path: tuple, value: Any, key: str) -> None:
    bad = tmp_path / "cal.yaml"
    bad.write_text(yaml.safe_dump(_mutated(path, value)))
    result = run_cli("check-config", "--calibration", bad)
    assert result.returncode == EX_CONFIG, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert f"cal.yaml: {key}: expected" in result.stderr


def test_cli_unreadable_and_not_yaml_calibration(tmp_path: Path) -> None:
    result = run_cli("check-config", "--calibration", tmp_path / "absent.yaml")
    assert result.returncode == EX_CONFIG and "absent.yaml: expected a readable file" in result.stderr
    bad = tmp_path / "cal.yaml"
    bad.write_text("baseline_m: 8.14\ncameras: [left\n")
    result = run_cli("check-config", "--calibration", bad)
    assert result.returncode == EX_CONFIG and "cal.yaml: expected a YAML document" in result.stderr
