"""The `alerts:` block and the ports' alert keys: defaults off, bad values name file and key."""

from __future__ import annotations

import pytest

from edge.config.app import AppConfig, config_from_dict
from edge.errors import ConfigError


def test_alerts_are_off_by_default() -> None:
    cfg = AppConfig()
    assert not cfg.alerts.enabled and cfg.alerts.cpa_m == 500.0 and cfg.alerts.tcpa_s == 360.0


@pytest.mark.parametrize(
    ("data", "key"),
    [
        ({"alerts": {"enabled": True, "repeat_s": 90}}, "alerts.repeat_s"),
        ({"alerts": {"heartbeat_s": 1000}}, "alerts.heartbeat_s"),
        ({"alerts": {"manufacturer": "xx"}}, "alerts.manufacturer"),
        ({"outputs": {"nmea": [{"url": "loop://", "alerts": "ALR"}]}}, "outputs.nmea[0].alerts"),
        ({"alerts": {"enabled": True}, "pipeline": {"max_tracks": 40}}, "pipeline.max_tracks"),
    ],
)
def test_bad_alert_settings_name_file_and_key(data: dict, key: str) -> None:
    with pytest.raises(ConfigError) as err:
        config_from_dict(data, "mast.yaml")
    assert "mast.yaml" in str(err.value) and key in str(err.value)


def test_a_legacy_port_with_acn() -> None:
    cfg = config_from_dict(
        {
            "alerts": {"enabled": True},
            "outputs": {"nmea": [{"url": "loop://", "alerts": "alr", "accept_acn": True}]},
        },
        None,
    )
    assert cfg.outputs.nmea[0].alerts == "alr" and cfg.outputs.nmea[0].accept_acn
