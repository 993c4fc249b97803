"""The `masks:` block: every bad polygon is a ConfigError naming the key down to the vertex (exit 78 from
the CLI), good ones load, and the search mask built from them excludes what they cover."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from helpers import run_cli
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.config.app import config_from_dict
from edge.config.calibration import load_calibration
from edge.config.masks import build_search_mask
from edge.core.geodesy import world_to_geodetic
from edge.core.site import Site
from edge.errors import EX_CONFIG, ConfigError

ROOT = Path(__file__).resolve().parents[3]
CALIBRATION = ROOT / "config/calibration/akashi-pinhole.yaml"
SITE = Site(34.63, 135.02, 25.0, 180.0)
SQUARE = [[100, 300], [300, 300], [300, 400], [100, 400]]


def _config(masks: dict, calibration: bool = True) -> dict:
    return {"calibration": str(CALIBRATION), "masks": masks} if calibration else {"masks": masks}


def _error(masks: dict, calibration: bool = True) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        config_from_dict(_config(masks, calibration), "site.yaml")
    return info.value


def test_a_good_block_loads() -> None:
    cfg = config_from_dict(
        _config(
            {
                "image": [{"name": "railing", "polygon": SQUARE}],
                "geo": [{"polygon": [[34.62, 135.01], [34.62, 135.02], [34.61, 135.02]]}],
            }
        ),
        "site.yaml",
    )
    assert cfg.masks.image[0].name == "railing" and cfg.masks.image[0].polygon[2] == (300.0, 400.0)
    assert len(cfg.masks.geo[0].polygon) == 3


@pytest.mark.parametrize(
    ("masks", "key", "words"),
    [
        (
            {"image": [{"polygon": [[0, 0], [10, 10], [10, 0], [0, 10]]}]},
            "masks.image[0].polygon[2]",
            "simple polygon",
        ),
        (
            {"image": [{"polygon": SQUARE}, {"polygon": [[0, 0], [50, 0]]}]},
            "masks.image[1].polygon",
            "at least 3",
        ),
        (
            {"image": [{"polygon": [[0, 0], [50, 0], [800, 100]]}]},
            "masks.image[0].polygon[2]",
            "inside the 720x480",
        ),
        (
            {"image": [{"polygon": [[0, 0], [50, 0], [20, -3]]}]},
            "masks.image[0].polygon[2]",
            "inside the 720x480",
        ),
        (
            {"image": [{"polygon": [[0, 0], [50, "x"], [20, 30]]}]},
            "masks.image[0].polygon[1]",
            "2 finite numbers",
        ),
        (
            {"geo": [{"polygon": [[34.6, 135.0], [91.0, 135.0], [34.5, 135.1]]}]},
            "masks.geo[0].polygon[1]",
            "latitude",
        ),
        (
            {"geo": [{"polygon": [[34.6, 135.0], [34.6, 181.0], [34.5, 135.1]]}]},
            "masks.geo[0].polygon[1]",
            "longitude",
        ),
        (
            {"geo": [{"polygon": [[34.62, 135.01], [34.62, 135.02], [34.61, 135.01], [34.61, 135.02]]}]},
            "masks.geo[0].polygon[3]",
            "simple polygon",
        ),
        ({"geo": [{"name": "pier"}]}, "masks.geo[0].polygon", "required"),
    ],
)
def test_bad_polygons_name_the_key_and_vertex(masks: dict, key: str, words: str) -> None:
    err = _error(masks)
    assert err.key == key and words in err.expected, err.message
    assert err.file == "site.yaml"


def test_vertex_outside_the_image_is_caught_once_the_size_is_known() -> None:
    cfg = config_from_dict(
        _config({"image": [{"polygon": [[0, 0], [50, 0], [800, 100]]}]}, calibration=False), "site.yaml"
    )  # a scenario's calibration: not known at load
    rig = load_calibration(CALIBRATION).rig
    with pytest.raises(ConfigError) as info:
        build_search_mask(cfg.masks, rig, SITE, "site.yaml")
    assert info.value.key == "masks.image[0].polygon[2]"


def test_check_config_exits_78_naming_the_vertex(tmp_path: Path) -> None:
    path = tmp_path / "config.yaml"
    path.write_text(
        yaml.safe_dump(_config({"geo": [{"polygon": [[34.6, 135.0], [-95.0, 135.0], [34.5, 135.1]]}]}))
    )
    out = run_cli("check-config", "--config", path)
    assert out.returncode == EX_CONFIG
    assert (
        "masks.geo[0].polygon[1]" in out.stderr and "latitude" in out.stderr and "Traceback" not in out.stderr
    )


@settings(max_examples=25, deadline=None)
@given(st.floats(300.0, 700.0), st.floats(0.0, 700.0), st.integers(0, 10_000))
def test_a_geo_rectangle_on_the_sea_excludes_its_sea_and_nothing_else(
    near_m: float, depth_m: float, seed: int
) -> None:
    """A rectangle given by the lat/lon of its corners masks exactly the pixels whose sea point falls in
    it: its interior, seen through the lens model, is masked, the sea beyond it is not."""
    rig = load_calibration(CALIBRATION).rig
    far_m = near_m + 200.0 + depth_m
    corners = np.array(
        [[-300.0, 0.0, near_m], [300.0, 0.0, near_m], [300.0, 0.0, far_m], [-300.0, 0.0, far_m]]
    )
    lat, lon, _ = world_to_geodetic(corners, SITE)
    cfg = config_from_dict(
        _config({"geo": [{"polygon": [[float(a), float(o)] for a, o in zip(lat, lon, strict=True)]}]}),
        "site.yaml",
    )
    mask = build_search_mask(cfg.masks, rig, SITE, "site.yaml")
    assert mask is not None
    rng = np.random.default_rng(seed)
    r_e = 6_371_000.0 / 0.87
    middle = 0.5 * (near_m + far_m)
    # a pixel row spans up to ~10 % of the range here: points a fifth of the range from every edge
    for z, masked in ((middle, True), (far_m * 1.25 + 50.0, False), (near_m * 0.75, False)):
        x = float(rng.uniform(-0.5, 0.5)) * min(300.0, 300.0 - 0.2 * z)
        uv, _ = rig.project(np.array([x, SITE.height_m + (x * x + z * z) / (2 * r_e), z]))
        u, v = int(round(uv[0])), int(round(uv[1]))
        if 0 <= u < rig.width and 0 <= v < rig.height:
            assert mask[v, u] == (not masked), (x, z)
