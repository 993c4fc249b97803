"""edge.config.schema (the generic YAML -> dataclass loader) and edge.config.app (the appliance's AppConfig).

The loader is checked on each type and constraint with the exact key path in
the error; the real CLI (`mast-stereo check-config`, run as a subprocess) is
checked to turn every kind of bad file into one line naming the key and exit 78.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import pytest
import yaml
from helpers import run_cli
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.config.app import AppConfig, NmeaPort, ReplayCameras, V4l2Cameras, VirtualCameras, load_config
from edge.config.schema import describe, load_dataclass, load_yaml, setting
from edge.config.table import markdown_table, schema_rows
from edge.errors import EX_CONFIG, ConfigError

ROOT = Path(__file__).resolve().parents[3]


@dataclass(frozen=True)
class Port:
    url: str
    baud: int = setting(9600, min=1, max=115200)
    parity: Literal["N", "E", "O"] = "N"


@dataclass(frozen=True)
class Wired:
    kind: Literal["wired"] = "wired"
    ports: tuple[Port, ...] = ()


@dataclass(frozen=True)
class Radio:
    kind: Literal["radio"] = "radio"
    channel: int = setting(1, min=1, max=16)


@dataclass(frozen=True)
class Sample:
    gain: float = setting(1.0, positive=True)
    name: str = setting("x", pattern="[a-z]+")
    enabled: bool = False
    angles: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tags: list[str] = setting(default_factory=list, max_items=2)
    limits: dict[str, int] = setting(default_factory=dict)
    note: str | None = None
    link: Wired | Radio = setting(default_factory=Wired)
    extra: Any = None


def _error(data: Any, cls: type = Sample) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        load_dataclass(cls, data, "f.yaml")
    assert info.value.file == "f.yaml"
    return info.value


def test_defaults_and_every_type_round_trip() -> None:
    assert load_dataclass(Sample, {}, "f.yaml") == Sample()
    data = {
        "gain": 2,
        "name": "ab",
        "enabled": True,
        "angles": [1, 2.5, -3],
        "tags": ["a"],
        "limits": {"a": 3},
        "note": None,
        "link": {"kind": "radio", "channel": 4},
        "extra": {"any": [1]},
    }
    got = load_dataclass(Sample, data, "f.yaml")
    assert got == Sample(
        2.0, "ab", True, (1.0, 2.5, -3.0), ["a"], {"a": 3}, None, Radio(channel=4), {"any": [1]}
    )
    assert isinstance(got.gain, float) and isinstance(got.angles, tuple)


@pytest.mark.parametrize(
    ("data", "key", "words"),
    [
        ({"gain": "2"}, "gain", "a finite number > 0"),
        ({"gain": True}, "gain", "a finite number"),
        ({"gain": float("inf")}, "gain", "finite"),
        ({"gain": float("nan")}, "gain", "finite"),
        ({"gain": 0}, "gain", "> 0"),
        ({"name": "AB"}, "name", "matching [a-z]+"),
        ({"name": 3}, "name", "a string"),
        ({"enabled": 1}, "enabled", "true or false"),
        ({"angles": [1, 2]}, "angles", "a list of 3 numbers"),
        ({"angles": [1, 2, "x"]}, "angles[2]", "a finite number"),
        ({"tags": ["a", "b", "c"]}, "tags", "a list of at most 2 strings"),
        ({"limits": {"a": 1.5}}, "limits.a", "an integer"),
        ({"link": {"kind": "radio", "channel": 17}}, "link.channel", "[1, 16]"),
        ({"link": {"kind": "radoi"}}, "link.kind", "did you mean 'radio'?"),
        ({"link": {"channel": 2}}, "link.kind", "required key is missing"),
        (
            {"link": {"kind": "wired", "ports": [{"url": "a"}, {"url": "b", "baud": True}]}},
            "link.ports[1].baud",
            "an integer in [1, 115200]",
        ),
        (
            {"link": {"kind": "wired", "ports": [{"baud": 9600}]}},
            "link.ports[0].url",
            "required key is missing",
        ),
        (
            {"link": {"kind": "wired", "ports": [{"url": "a", "parity": "e"}]}},
            "link.ports[0].parity",
            "one of 'N', 'E', 'O'",
        ),
        (
            {"link": {"kind": "wired", "ports": [{"url": "a", "baudrate": 1}]}},
            "link.ports[0].baudrate",
            "did you mean 'baud'?",
        ),
        ({"gian": 1}, "gian", "did you mean 'gain'?"),
        ({"zzz": 1}, "zzz", "known keys: angles, enabled"),
    ],
)
def test_errors_name_the_key_path_and_the_expectation(data: dict, key: str, words: str) -> None:
    err = _error(data)
    assert err.key == key
    assert words in err.message, err.message
    assert err.message.startswith(f"f.yaml: {key}: expected ")


def test_bool_is_not_an_int_and_int_is_accepted_as_float() -> None:
    assert _error({"baud": True, "url": "u"}, Port).key == "baud"
    assert load_dataclass(Sample, {"gain": 3}, "f").gain == 3.0


def test_top_level_must_be_a_mapping() -> None:
    for data in (None, [1, 2], "text", 3):
        err = _error(data)
        assert err.key == "<top>" and "a mapping" in err.message


def test_key_prefix_is_prepended() -> None:
    with pytest.raises(ConfigError) as info:
        load_dataclass(Port, {"url": "a", "baud": 0}, "f.yaml", "outputs.nmea[3]")
    assert info.value.key == "outputs.nmea[3].baud"


def test_setting_refuses_unknown_constraints() -> None:
    with pytest.raises(TypeError, match="unknown constraint"):
        setting(1, minimum=0)


@settings(max_examples=60, deadline=None)
@given(st.integers(min_value=-(2**40), max_value=2**40))
def test_integer_range_is_enforced_exactly(value: int) -> None:
    data = {"url": "u", "baud": value}
    if 1 <= value <= 115200:
        assert load_dataclass(Port, data, "f").baud == value
    else:
        assert _error(data, Port).key == "baud"


def test_load_yaml_errors(tmp_path: Path) -> None:
    cases = {
        "missing.yaml": (None, "a readable file"),
        "bad.yaml": ("a: [1, 2\n", "a YAML document"),
        "dup.yaml": ("a: 1\nb: 2\na: 3\n", "duplicate key 'a'"),
        "bin.yaml": (b"\xff\xfe\x00", "UTF-8 text"),
    }
    for name, (content, words) in cases.items():
        path = tmp_path / name
        if isinstance(content, bytes):
            path.write_bytes(content)
        elif content is not None:
            path.write_text(content)
        with pytest.raises(ConfigError) as info:
            load_yaml(path)
        assert info.value.key == "" and words in info.value.message, info.value.message
    (tmp_path / "merge.yaml").write_text("base: &b {x: 1, y: 2}\nuse: {<<: *b, y: 3}\n")
    assert load_yaml(tmp_path / "merge.yaml")["use"] == {"x": 1, "y": 3}  # merges are not duplicates


# ---------------------------------------------------------------- AppConfig


def test_demo_config_is_the_default_and_site_example_loads() -> None:
    assert load_config(ROOT / "config/demo.yaml") == AppConfig()
    cfg = load_config(ROOT / "config/site.example.yaml")
    assert isinstance(cfg.cameras, V4l2Cameras) and cfg.cameras.trigger["kind"] == "gpio"
    assert cfg.calibration is not None and cfg.calibration.rig.baseline_m == 8.14
    assert cfg.effective_site == cfg.site and cfg.site.heading_deg == 180.0
    assert [p.baud for p in cfg.outputs.nmea] == [38400, 4800]
    assert cfg.outputs.nmea[1] == NmeaPort(url="/dev/ttyS2", baud=4800, sentences=("TLL",))


def test_defaults_describe_a_demo() -> None:
    cfg = AppConfig()
    assert cfg.cameras == VirtualCameras(scenario="akashi-crossing")
    assert cfg.outputs.modbus.tcp.enabled and cfg.outputs.modbus.tcp.port == 1502
    assert cfg.outputs.modbus.rtu.parity == "E" and cfg.outputs.modbus.rtu.baud == 19200
    assert not cfg.outputs.udp.enabled and cfg.outputs.nmea == ()
    assert dataclasses.is_dataclass(cfg) and cfg.__dataclass_params__.frozen


def _write(tmp_path: Path, data: Any, name: str = "c.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data) if not isinstance(data, str) else data)
    return path


def test_relative_paths_resolve_against_the_config_file(tmp_path: Path) -> None:
    sub = tmp_path / "etc"
    sub.mkdir()
    (sub / "cal.yaml").write_text((ROOT / "config/calibration/akashi-poly10.yaml").read_text())
    cfg = load_config(
        _write(
            sub,
            {
                "cameras": {"kind": "replay", "path": "rec"},
                "calibration": "cal.yaml",
                "outputs": {"tracks_csv": "t.csv"},
            },
        )
    )
    assert cfg.cameras == ReplayCameras(path=str(sub / "rec"))
    assert cfg.outputs.tracks_csv == str(sub / "t.csv")
    assert cfg.calibration.rig.left.to_dict()["model"] == "poly10"
    assert cfg.effective_site == cfg.calibration.site


def test_inline_calibration_and_site_override(tmp_path: Path) -> None:
    inline = yaml.safe_load((ROOT / "config/calibration/akashi-pinhole.yaml").read_text())
    site = {"lat_deg": 1.0, "lon_deg": 2.0, "height_m": 3.0, "heading_deg": 90.0}
    cfg = load_config(_write(tmp_path, {"calibration": inline, "site": site}))
    assert cfg.calibration.site.lat_deg == 34.63 and cfg.effective_site.lat_deg == 1.0


@pytest.mark.parametrize(
    ("data", "key"),
    [
        ({"cameras": {"kind": "v4l2"}}, "calibration"),
        (
            {
                "cameras": {"kind": "v4l2", "left": {"device": "/dev/a"}, "right": {"device": "/dev/a"}},
                "calibration": str(ROOT / "config/calibration/akashi-pinhole.yaml"),
            },
            "cameras.right.device",
        ),
        ({"outputs": {"nmea": [{"url": "/dev/ttyS1"}, {"url": "/dev/ttyS1"}]}}, "outputs.nmea[1].url"),
        (
            {
                "outputs": {
                    "nmea": [{"url": "/dev/ttyS1"}],
                    "modbus": {"rtu": {"enabled": True, "url": "/dev/ttyS1"}},
                }
            },
            "outputs.modbus.rtu.url",
        ),
        ({"pipeline": {"window": 16}}, "pipeline.window"),
        ({"outputs": {"udp": {"group": "192.168.1.1"}}}, "outputs.udp.group"),
        ({"outputs": {"modbus": {"tcp": {"host": "localhost"}}}}, "outputs.modbus.tcp.host"),
        ({"cameras": {"kind": "replay"}}, "cameras.path"),
        ({"version": 2}, "version"),
        ({"calibration": 5}, "calibration"),
    ],
)
def test_config_rules(tmp_path: Path, data: dict, key: str) -> None:
    with pytest.raises(ConfigError) as info:
        load_config(_write(tmp_path, data))
    assert info.value.key == key, info.value.message


def test_markdown_table_lists_every_leaf_key() -> None:
    table = markdown_table(AppConfig)
    keys = {row[0] for row in schema_rows(AppConfig)}
    for key in (
        "outputs.nmea[].baud",
        "outputs.modbus.rtu.parity",
        "cameras.kind",
        "cameras.scenario",
        "cameras.trigger",
        "outputs.udp.group",
        "health.leds.kind",
        "logging.level",
        "site",
    ):
        assert key in keys and f"`{key}`" in table
    assert "`38400`" in table and "**required**" in table
    assert describe(int, {"min": 1, "max": 2}) == "an integer in [1, 2]"
    assert describe(tuple[str, ...], {"min_items": 1, "max_items": 2}) == "a list of 1..2 strings"


# ---------------------------------------------------------------- the real CLI: exit 78, key named




BAD_CONFIGS = {
    "missing key": (
        "outputs:\n  nmea:\n    - baud: 9600\n",
        "outputs.nmea[0].url",
        "required key is missing",
    ),
    "wrong type": (
        "outputs:\n  nmea:\n    - url: loop://\n      baud: fast\n",
        "outputs.nmea[0].baud",
        "expected an integer",
    ),
    "unknown key": ("pipeline:\n  windw: 15\n", "pipeline.windw", "did you mean 'window'?"),
    "negative baseline": ("calibration: {baseline_m: -8.14}\n", "calibration.baseline_m", "> 0"),
    "non-finite value": ("pipeline:\n  experimental:\n    gate_sigma: .inf\n",
                         "pipeline.experimental.gate_sigma", "finite"),
    "not YAML": ("pipeline: {window: 15\n", "", "expected a YAML document"),
    "top not a mapping": ("- 1\n- 2\n", "<top>", "a mapping"),
    "proprietary talker": (  # $PA... would read as a proprietary sentence, not a talker
        "outputs:\n  nmea:\n    - url: loop://\n      talker: PA\n",
        "outputs.nmea[0].talker",
        "[A-OQ-Z][A-Z0-9]",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_CONFIGS))
def test_cli_refuses_bad_config_with_exit_78(tmp_path: Path, case: str) -> None:
    text, key, words = BAD_CONFIGS[case]
    path = _write(tmp_path, text, "bad.yaml")
    result = run_cli("check-config", "--config", path)
    assert result.returncode == EX_CONFIG, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr
    assert f"bad.yaml: {key}: " in lines[0] if key else "bad.yaml: expected" in lines[0]
    assert words in lines[0]


def test_cli_unreadable_config_and_missing_calibration_file(tmp_path: Path) -> None:
    result = run_cli("check-config", "--config", tmp_path / "nope.yaml")
    assert result.returncode == EX_CONFIG and "nope.yaml: expected a readable file" in result.stderr
    path = _write(tmp_path, "calibration: gone.yaml\n")
    result = run_cli("check-config", "--config", path)
    assert result.returncode == EX_CONFIG
    assert "c.yaml: calibration: expected a calibration file (a readable file)" in result.stderr
    assert "gone.yaml" in result.stderr


def test_cli_check_config_ok_prints_a_summary() -> None:
    result = run_cli("check-config", "--config", "config/site.example.yaml")
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert "OK" in out and "/dev/mast/cam-left" in out and "HFOV 43.0 deg" in out


@pytest.mark.parametrize("example", sorted((ROOT / "config/cameras").glob("*.yaml")), ids=lambda p: p.name)
def test_camera_examples_load_as_the_cameras_block_of_a_config(example: Path, tmp_path: Path) -> None:
    """Each worked example is a valid `cameras:` block once a calibration of its image size is named;
    loading it opens no device."""
    cams = yaml.safe_load(example.read_text())["cameras"]
    calibration = load_yaml(ROOT / "config/calibration/akashi-pinhole.yaml")
    calibration["image"] = {"width": cams["width"], "height": cams["height"]}
    path = tmp_path / "mast.yaml"
    path.write_text(yaml.safe_dump({"cameras": cams, "calibration": calibration}))
    cfg = load_config(path)
    assert isinstance(cfg.cameras, V4l2Cameras) and cfg.cameras.block()["trigger"] == cams["trigger"]


def test_v4l2_errors_name_the_nested_key(tmp_path: Path) -> None:
    path = tmp_path / "mast.yaml"
    base = {"calibration": str(ROOT / "config/calibration/akashi-pinhole.yaml")}
    cases = [({"kind": "v4l2", "exposure": {"value": 3}}, "cameras.exposure"),
             ({"kind": "v4l2", "right": {"device": "/dev/mast/cam-left"}}, "cameras.right.device"),
             ({"kind": "v4l2", "width": 640}, "cameras.width")]
    for cams, key in cases:
        path.write_text(yaml.safe_dump({**base, "cameras": cams}))
        with pytest.raises(ConfigError) as err:
            load_config(path)
        assert err.value.key == key, (cams, str(err.value))
