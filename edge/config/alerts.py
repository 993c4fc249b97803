"""The `alerts:` configuration block (issue 18); absent or `enabled: false`: no alert is computed or sent.

Defaults suit a harbour approach and say where they come from:
- CPA limit: max(`cpa_m`, `length_factor` x the longer ship's apparent length). 500 m and 3 x length
  are the vessel-proximity rule of MarineTraffic (3 x the longer ship's length, at most 1000 m) with
  a floor for the small ships our length estimate under-reads; 500 m is also 0.27 NM, inside MSC.192
  table 3's 0.3 NM CPA accuracy of a 3-min track, so a raised alert is a real close-quarters situation.
- TCPA limit 6 min (`tcpa_s` 360): the Japanese VTS study (KAKEN 15K01243) gives its final warning
  at TCPA 3-4 min; raising at 6 min leaves the operator those minutes and a margin.
- `sigmas` 2 (about 95 % one-sided): the CPA's upper bound CPA + 2 sigma must be under the limit.
"""

from __future__ import annotations

from dataclasses import dataclass

from edge.config.schema import setting


@dataclass(frozen=True)
class AlertsConfig:
    enabled: bool = setting(False, doc="compute alerts and send them on every NMEA port and Modbus")
    cpa_m: float = setting(500.0, positive=True, max=10000.0, doc="close quarters: CPA limit floor, m")
    length_factor: float = setting(
        3.0,
        min=0.0,
        max=20.0,
        doc="close quarters: CPA limit is at least this times the longer ship's length",
    )
    tcpa_s: float = setting(360.0, positive=True, max=3600.0, doc="close quarters: 0 < TCPA below this, s")
    sigmas: float = setting(
        2.0, min=0.0, max=5.0, doc="raise only while CPA + sigmas x its 1-sigma is below the limit"
    )
    confirm_s: float = setting(
        5.0, min=0.0, max=600.0, doc="a condition must hold this long (and >= 3 updates) to raise or clear"
    )
    clear_factor: float = setting(
        1.2, min=1.0, max=5.0, doc="hysteresis: clear once CPA - sigmas x sigma exceeds this times the limit"
    )
    passed_s: float = setting(
        10.0, min=0.0, max=600.0, doc="close quarters clears once TCPA is below -passed_s (the ships passed)"
    )
    event_hold_s: float = setting(
        60.0,
        positive=True,
        max=3600.0,
        doc="new and lost target alerts stay active this long unless acknowledged (60: as the quarantine)",
    )
    capacity_share: float = setting(
        0.95, positive=True, max=1.0, doc="capacity caution at this share of pipeline.max_tracks"
    )
    repeat_s: float = setting(
        30.0,
        positive=True,
        max=60.0,
        doc="active alerts' ALF (or ALR) repeated this often (IEC 61162-1: <= 60 s)",
    )
    alc_s: float = setting(
        30.0, positive=True, max=60.0, doc="ALC (alert list) every this while any is active"
    )
    heartbeat_s: int = setting(60, min=0, max=999, doc="HBT every this many seconds; 0: none")
    manufacturer: str = setting(
        "XXX",
        pattern="[A-Z]{3}",
        doc="ALF/ALC mnemonic of the proprietary alert ids (>= 10000); must be assigned",
    )
