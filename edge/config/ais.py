"""The optional `ais:` block of the appliance configuration (docs/ais.md): where AIS sentences come
from, how old a position report may be, the association gate, the dark flag and the calibration
monitor. Absent (`ais: null`, the default) the feature is off and every output is as before.

A replay takes the recording's `ais.csv` whatever `input` says (the same decoder and association
as a live input); the daemon reads `input`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from edge.config.schema import setting


@dataclass(frozen=True)
class AisSerialInput:
    kind: Literal["serial"] = setting("serial", doc="an AIS receiver on a serial line")
    url: str = setting("/dev/ttyUSB0", doc="pyserial URL of the receiver (socket://, rfc2217:// work too)")
    baud: int = setting(38400, choices=(4800, 9600, 19200, 38400, 57600, 115200),
                        doc="baud rate (IEC 61162-2 AIS: 38400)")


@dataclass(frozen=True)
class AisUdpInput:
    kind: Literal["udp"] = setting("udp", doc="AIS sentences in UDP datagrams (plain lines or IEC 61162-450)")
    port: int = setting(10110, min=1, max=65535, doc="UDP port to listen on")
    host: str = setting("0.0.0.0", doc="local address to bind")
    group: str | None = setting(None, doc="multicast group to join (IEC 61162-450), null: unicast/broadcast")


@dataclass(frozen=True)
class AisMonitorConfig:
    enabled: bool = setting(True, doc="run the online calibration check on associated class-A ships")
    max_range_m: float = setting(4000.0, positive=True, doc="ships farther than this are not used")
    disparity_bound_px: float = setting(
        0.05, positive=True, doc="fault when |disparity offset| exceeds this with confidence, px")
    bearing_bound_deg: float = setting(
        0.1, positive=True, doc="fault when |bearing offset| exceeds this with confidence, deg")
    confidence_sigmas: float = setting(3.0, positive=True, doc="... by at least this many of its sigmas")
    min_reports: int = setting(20, min=2, doc="AIS reports behind an estimate before it may raise a fault")


@dataclass(frozen=True)
class AisConfig:
    input: AisSerialInput | AisUdpInput | None = setting(
        None, doc="live source of !AIVDM/!AIVDO lines; `kind` picks serial or udp (null: replay only)")
    queue_lines: int = setting(2000, min=10, max=1_000_000, doc="bounded queue between input and tracking")
    max_age_s: float = setting(
        180.0, positive=True, max=3600.0,
        doc="position reports older than this are dropped (180: a slow class-B ship's interval)")
    gate_nis: float = setting(13.8, positive=True, doc="association gate, chi-square 2 dof (13.8: 99.9 %)")
    hold_bonus: float = setting(
        6.0, min=0.0, doc="cost bonus of a track's current AIS target in the assignment (hysteresis)")
    confirm_s: float = setting(5.0, min=0.0, doc="a new association is reported after this long unchanged")
    dark_after_s: float = setting(20.0, positive=True, doc="a T track unassociated this long is dark")
    warmup_s: float = setting(
        30.0, min=0.0, doc="no track is dark before the AIS input has run this long (class-B interval); "
        "again after the receiver was lost")
    dark_prefix: str = setting("DARK", pattern="[A-Z0-9]{0,6}",
                               doc="TTM/TLL name prefix of a dark track ('': no prefix)")
    monitor: AisMonitorConfig = setting(default_factory=AisMonitorConfig)
