"""Scenario files: the shipped ones load; every mistake is a ConfigError naming file and key."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from edge.errors import ConfigError
from edge.sim.scenario import SCENARIO_DIR, load_scenario, scenario_from_dict

SHIPPED = sorted(p.stem for p in SCENARIO_DIR.glob("*.yaml"))


def test_the_required_scenarios_are_shipped() -> None:
    assert {"akashi-crossing", "approach-2048", "two-ships-crossing", "small-boat-fog", "glints"} <= set(
        SHIPPED
    )


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_scenarios_load(name: str) -> None:
    scenario = load_scenario(name)
    assert scenario.name == name and scenario.spec.description and scenario.spec.ships
    assert scenario.site.height_m > 0


def test_akashi_crossing_is_the_thesis_set_up() -> None:
    s = load_scenario("akashi-crossing")
    rig = s.calibration.rig
    assert (rig.width, rig.height, rig.baseline_m, s.spec.fps, s.n_frames) == (720, 480, 8.14, 10.0, 385)
    assert 42.0 < s.horizontal_fov_deg < 44.0
    assert s.spec.atmosphere.visibility_m < 10_000  # fog
    big = load_scenario("approach-2048")
    assert (big.calibration.rig.width, big.calibration.rig.height) == (2048, 1536)


def _data() -> dict:
    return yaml.safe_load((SCENARIO_DIR / "akashi-crossing.yaml").read_text())


@pytest.mark.parametrize(
    ("edit", "key"),
    [
        (lambda d: d.update(fps=0), "fps"),
        (lambda d: d.update(colour="blue"), "colour"),
        (lambda d: d["atmosphere"].update(visibilty_m=3), "atmosphere.visibilty_m"),
        (lambda d: d["ships"][1].update(kind="frieghter"), "ships[1].kind"),
        (lambda d: d["ships"][1].update(id=1), "ships[1].id"),
        (lambda d: d["ships"][0]["track"].update(waypoints_m=[[0, 1]]), "ships[0].track.waypoints_m"),
        (lambda d: d["ships"][0]["track"].update(waypoints_m=[[0, 1], [0, 1]]), "ships[0].track"),
        (lambda d: d["ships"][0]["track"].update(speed_kn=[10, 12]), "ships[0].track"),
        (lambda d: d.update(calibration="nowhere.yaml"), "calibration"),
        (lambda d: d.update(calibration={"baseline_m": -1}), "calibration.baseline_m"),
        (
            lambda d: d.update(site={"lat_deg": 0, "lon_deg": 0, "height_m": 0.1, "heading_deg": 0}),
            "site.height_m",
        ),
        (lambda d: d["glints"].update(duration_s=[0.5, 0.1]), "glints.duration_s"),
        (lambda d: d["imaging"].update(psf_sigma_px="wide"), "imaging.psf_sigma_px"),
    ],
)
def test_mistakes_name_the_key(edit, key: str, tmp_path: Path) -> None:
    data = _data()
    edit(data)
    path = tmp_path / "scenario.yaml"
    with pytest.raises(ConfigError) as info:
        scenario_from_dict(data, SCENARIO_DIR / "akashi-crossing.yaml" if "calibration" not in key else path)
    assert info.value.key == key, info.value.message


def test_calibration_without_site_needs_one_in_the_scenario(tmp_path: Path) -> None:
    cal = yaml.safe_load((SCENARIO_DIR.parent / "calibration" / "akashi-pinhole.yaml").read_text())
    del cal["site"]
    data = {"calibration": cal, "fps": 5, "duration_s": 1}
    with pytest.raises(ConfigError) as info:
        scenario_from_dict(data, tmp_path / "s.yaml")
    assert info.value.key == "site"
    data["site"] = {"lat_deg": 34.6, "lon_deg": 135.0, "height_m": 12.0, "heading_deg": 90.0}
    assert scenario_from_dict(data, tmp_path / "s.yaml").site.height_m == 12.0


def test_unknown_scenario_name_lists_the_known_ones() -> None:
    with pytest.raises(ConfigError) as info:
        load_scenario("akashi-crosing")
    assert "akashi-crossing" in info.value.message
