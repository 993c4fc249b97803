"""The appliance's configuration: one YAML file -> a frozen `AppConfig` (schema below).

`load_config(path)` reads the file with `edge.config.schema` (types, ranges, unknown
keys, duplicate keys: every mistake is a `ConfigError` naming the file and
the key path, exit 78 from the CLI) and then checks what spans several keys.
Relative paths (calibration file, replay recording, scenario file) are taken
relative to the configuration file's directory and stored absolute.

Every key has a default, and the defaults are the demo: simulated cameras
running the `akashi-crossing` scenario, Modbus TCP on 127.0.0.1:1502, no
serial port. `AppConfig()` is therefore a working configuration, and
config/demo.yaml spells the same thing out. `markdown_table(AppConfig)`
renders this schema for docs/configuration.md.

`calibration` is a path to a calibration YAML (edge.config.calibration) or the same
mapping inline; when absent, virtual cameras take the scenario's calibration
and replay the recording's. `site`, when given, overrides the calibration's.
"""

from __future__ import annotations

import dataclasses
import ipaddress
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

from edge.config.ais import AisConfig
from edge.config.alerts import AlertsConfig
from edge.config.asterix import AsterixConfig
from edge.config.calibration import Calibration, calibration_ref, optional_site, resolve_path
from edge.config.masks import MasksConfig, check_image_polygons
from edge.config.page import PageConfig
from edge.config.schema import load_dataclass, load_yaml, setting
from edge.config.table import markdown_table
from edge.core.site import Site
from edge.encode.registers import MAX_TRACKS_WITH_ALERTS
from edge.errors import ConfigError

BAUD_RATES = (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200)


def _multicast(value: str) -> str | None:
    try:
        ok = ipaddress.IPv4Address(value).is_multicast
    except ValueError:
        ok = False
    return None if ok else "an IPv4 multicast address (224.0.0.0/4; IEC 61162-450 uses 239.192.0.1-64)"


def _ipv4(value: str) -> str | None:
    try:
        ipaddress.IPv4Address(value)
    except ValueError:
        return "an IPv4 address such as 0.0.0.0 or 192.168.1.10"
    return None


def _odd(value: int) -> str | None:
    return None if value % 2 == 1 else "an odd integer (the window is centred on the point)"


# ---------------------------------------------------------------- cameras


@dataclass(frozen=True)
class V4l2Cameras:
    """Two V4L2 cameras; the driver (`drivers.camera.v4l2_config`) checks the nested blocks
    (per-camera devices, exposure/gain controls, the trigger) and `config_from_dict` turns its
    complaints into errors naming the key. Worked examples: config/cameras/*.yaml."""

    kind: Literal["v4l2"] = setting("v4l2", doc="two V4L2 capture devices")
    left: dict[str, Any] = setting(
        default_factory=lambda: {"device": "/dev/mast/cam-left"},
        accepts="a mapping: device, and optionally subdevice, input, controls",
        doc="left camera: {device: /dev/mast/cam-left} (udev stable names), subdevice for its controls")
    right: dict[str, Any] = setting(
        default_factory=lambda: {"device": "/dev/mast/cam-right"},
        accepts="a mapping: device, and optionally subdevice, input, controls", doc="right camera, as left")
    width: int = setting(720, min=16, max=16384, doc="image width, px (the calibration's)")
    height: int = setting(480, min=16, max=16384, doc="image height, px")
    pixel_format: Literal["GREY", "Y16", "YUYV", "MJPEG"] = setting(
        "GREY", doc="V4L2 format, converted to 8-bit grey")
    fps: float | None = setting(None, positive=True, max=240.0,
                                doc="frame rate to request (S_PARM); null: the trigger sets it")
    exposure: Any = setting("auto", accepts="'auto' or {control, value[, mode_control, mode_value]}",
                            doc="exposure by control name, or the camera's automatic")
    gain: Any = setting("auto", accepts="'auto' or {control, value}",
                        doc="gain by control name, or automatic")
    controls: dict[str, Any] = setting(default_factory=dict, doc="other controls for both cameras, by name")
    buffers: int = setting(4, min=2, max=32, doc="V4L2 buffers per camera")
    skip_frames: int = setting(0, min=0, max=100, doc="frames dropped after each STREAMON (stale ones)")
    max_skew_ms: float | None = setting(None, positive=True,
                                        doc="pairing tolerance; null: half the trigger period")
    trigger: dict[str, Any] = setting(
        default_factory=lambda: {"kind": "none", "rate_hz": 10.0},
        accepts="a mapping: kind (controls, gpio, external, none), rate_hz, ...",
        doc="external trigger (drivers/trigger/config.py; examples in config/cameras/)")

    def block(self) -> dict[str, Any]:
        """The `cameras:` mapping in the driver's terms."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


@dataclass(frozen=True, kw_only=True)
class ReplayCameras:
    kind: Literal["replay"] = setting("replay", doc="frame pairs from a recording directory")
    path: str = setting(doc="recording directory (relative to this file)")
    pace: bool = setting(True, doc="at the recorded frame rate (false: as fast as possible)")
    loop: bool = setting(False, doc="start over at the end")


@dataclass(frozen=True)
class VirtualCameras:
    kind: Literal["virtual"] = setting("virtual", doc="the simulator renders live pairs")
    scenario: str = setting("akashi-crossing", doc="scenario name in config/scenarios, or a .yaml path")
    seed: int = setting(0, min=0, doc="noise seed (same seed, same frames)")
    pace: bool = setting(True, doc="in real time at the scenario's frame rate")
    loop: bool = setting(True, doc="start the scenario over at its end")


# ---------------------------------------------------------------- processing


@dataclass(frozen=True)
class ExperimentalConfig:
    """Research switches (`pipeline.experimental`): for measuring alternatives in the lab, not for
    operators. The defaults are the product; turning the cross-checks off leaves the fixes' sigma
    smaller than their real error, and another filter or cost has not been validated like them."""

    detector: Literal["rowband", "seaclutter"] = setting(
        "rowband", doc="rowband: contrast against each row band's spread (edge.measure.detect); seaclutter: "
        "local sea-clutter CFAR candidates on an image pyramid scored by a fitted verifier "
        "(edge.measure.seadetect, docs/detection-real.md)")
    cost: Literal["zssd", "ssd"] = setting("zssd", doc="zero-mean SSD (robust to gain/offset) or plain SSD")
    filter: Literal["kalman", "butterworth"] = setting("kalman", doc="disparity filter (Butterworth eq. 6.1)")
    butterworth_cutoff_hz: float = setting(0.5, positive=True, doc="cut-off of the Butterworth filter")
    gate_sigma: float = setting(3.0, positive=True, doc="innovation gate of the Kalman filter, sigmas")
    alias_check: bool = setting(
        True, doc="cross-check every match with a 4-px smaller window and widen the fix's sigma by their "
        "persistent disagreement, at most 0.1 px (aliasing on sharp optics; one more match per track)"
    )
    depth_check: bool = setting(
        True, doc="match four 7-px sub-windows around every point and widen the fix's sigma by 1.5x their "
        "persistent disagreement with the 15-px match, at most 0.5 px (the depth a near end-on ship spans "
        "in one window; four small matches per track)"
    )


@dataclass(frozen=True)
class PipelineConfig:
    window: int = setting(15, min=3, max=63, check=_odd, doc="matching window side, px (eq. 3.8)")
    max_disparity: int = setting(128, min=1, max=2048, doc="disparity search range, px")
    prefilter: Literal["none", "xsobel"] = setting(
        "none", doc="xsobel for real cameras: clipped horizontal Sobel before matching, robust to "
        "response-curve/vignetting differences; costs accuracy on clean renders"
    )
    detect_every: int = setting(5, min=1, max=1000, doc="run ship detection on every k-th pair")
    detect_decimation: int = setting(2, min=1, max=8, doc="detection works on an image shrunk by this")
    min_ship_px: int = setting(20, min=2, max=1000, doc="smallest ship length to detect, px (eq. 3.12)")
    max_tracks: int = setting(32, min=1, max=99, doc="live tracks at most (NMEA numbers 01-99)")
    coast_s: float = setting(3.0, min=0.0, max=600.0, doc="a track unseen this long turns lost (L)")
    max_sog_sigma_kn: float = setting(
        0.75, positive=True, max=50.0,
        doc="SOG is reported once the ground-plane filter's 1-sigma is at most this, knots (0.75: table 3's "
        "1-min 1.5 kn at 95 %)")
    max_cog_sigma_deg: float = setting(
        5.5, positive=True, max=180.0,
        doc="COG is reported once its 1-sigma is at most this (and SOG's meets its bound), degrees (5.5: "
        "table 3's 1-min 11 deg at 95 %)")
    experimental: ExperimentalConfig = setting(
        default_factory=ExperimentalConfig,
        doc="research switches, not for operators: the defaults are the validated product")


# ---------------------------------------------------------------- outputs


@dataclass(frozen=True)
class ProprietaryConfig:
    enabled: bool = setting(False, doc="also send the proprietary x/y sentence ($P<mfr>TXY)")
    manufacturer: str = setting("XXX", pattern="[A-Z]{3}", doc="NMEA manufacturer code (must be assigned)")


_SENTENCES = "sentences sent for each track update"


@dataclass(frozen=True)
class NmeaPort:
    url: str = setting(doc="pyserial URL: /dev/ttyS1, loop://, socket://host:port, spy:///dev/ttyS1")
    baud: int = setting(38400, choices=BAUD_RATES, doc="baud rate")
    bytesize: Literal[7, 8] = setting(8, doc="data bits")
    parity: Literal["N", "E", "O"] = setting("N", doc="parity")
    stopbits: Literal[1, 2] = setting(1, doc="stop bits")
    talker: str = setting(
        "RA", pattern="[A-OQ-Z][A-Z0-9]", doc="talker id (RA radar, II, U0..U9; P is proprietary)"
    )
    sentences: tuple[Literal["TTM", "TLL"], ...] = setting(
        ("TTM", "TLL"), min_items=1, max_items=2, doc=_SENTENCES
    )
    send_acquiring: bool = setting(False, doc="also report acquiring (Q) tracks")
    proprietary: ProprietaryConfig = setting(default_factory=ProprietaryConfig)
    alerts: Literal["alf", "alr", "both", "none"] = setting(
        "alf", doc="with alerts.enabled: IEC 61162-1 ed. 5 ALF/ALC, the legacy ALR, both, or none here")
    accept_acn: bool = setting(
        False, doc="read this port: ACN acknowledges an alert; every other line is ignored and counted")


@dataclass(frozen=True)
class UdpConfig:
    enabled: bool = setting(False, doc="IEC 61162-450 over UDP multicast")
    group: str = setting("239.192.0.2", check=_multicast, doc="multicast group (TGTD: target data)")
    port: int = setting(60002, min=1, max=65535, doc="UDP port")
    interface: str = setting("0.0.0.0", check=_ipv4, doc="local address of the sending interface")
    ttl: int = setting(1, min=0, max=255, doc="multicast TTL")
    source: str = setting(
        "RA0001", pattern="[A-OQ-Z][A-Z0-9][0-9]{4}", doc="tag block s: (talker + 4 digits)"
    )
    sentences: tuple[Literal["TTM", "TLL"], ...] = setting(
        ("TTM", "TLL"), min_items=1, max_items=2, doc=_SENTENCES
    )


@dataclass(frozen=True)
class ModbusTcp:
    enabled: bool = setting(True, doc="serve Modbus TCP")
    host: str = setting("127.0.0.1", check=_ipv4, doc="listen address (0.0.0.0: all interfaces)")
    port: int = setting(1502, min=1, max=65535, doc="TCP port (502 needs CAP_NET_BIND_SERVICE)")


@dataclass(frozen=True)
class ModbusRtu:
    enabled: bool = setting(False, doc="serve Modbus RTU on a serial line")
    url: str = setting("/dev/ttyS2", doc="serial port (pyserial URL)")
    baud: int = setting(19200, choices=BAUD_RATES, doc="baud rate")
    parity: Literal["N", "E", "O"] = setting("E", doc="parity (Modbus serial default: 8E1)")
    stopbits: Literal[1, 2] = setting(1, doc="stop bits (2 when parity is N)")
    unit: int = setting(1, min=1, max=247, doc="RTU unit (slave) address")


@dataclass(frozen=True)
class ModbusConfig:
    tcp: ModbusTcp = setting(default_factory=ModbusTcp)
    rtu: ModbusRtu = setting(default_factory=ModbusRtu)
    word_order: Literal["high_first", "low_first"] = setting("high_first", doc="32-bit values: ABCD or CDAB")


@dataclass(frozen=True)
class OutputsConfig:
    nmea: tuple[NmeaPort, ...] = setting((), doc="serial NMEA 0183 ports")
    udp: UdpConfig = setting(default_factory=UdpConfig)
    modbus: ModbusConfig = setting(default_factory=ModbusConfig)
    tracks_csv: str | None = setting(None, doc="append every fix to this CSV file")
    asterix: AsterixConfig = setting(default_factory=AsterixConfig, doc="ASTERIX CAT 010 over UDP")


# ---------------------------------------------------------------- health, logging, top level


@dataclass(frozen=True)
class LedsConfig:
    kind: Literal["none", "sysfs", "virtual"] = setting("virtual", doc="status LEDs driver")
    ok: str = setting("mast:green:ok", doc="green LED under /sys/class/leds (kind sysfs): heartbeat while OK")
    fault: str = setting("mast:red:fault", doc="red LED name (kind sysfs): steady on a fault or when stopped")
    amber: str | None = setting(None, doc="amber LED name for DEGRADED; null: green and red blink together")
    root: str = setting("/sys/class/leds", doc="where the LED class devices are (kind sysfs)")


@dataclass(frozen=True)
class HealthConfig:
    stale_s: float = setting(2.0, positive=True, max=600.0, doc="a stage silent this long is STALLED")
    min_fps: float = setting(5.0, min=0.0, doc="below this frame rate the appliance is DEGRADED")
    watchdog: bool = setting(True, doc="send WATCHDOG=1 to systemd while all stages are fresh")
    min_free_disk_mb: int = setting(1024, min=0, doc="free space the recordings directory needs (selftest)")
    require_clock_sync: bool = setting(
        True, doc="an unsynchronised system clock is a fault (NMEA carries UTC); false on a bench unit")
    leds: LedsConfig = setting(default_factory=LedsConfig)
    state_dir: str | None = setting(
        None, doc="where NMEA target numbers and track ids survive a crash; null: $STATE_DIRECTORY")


@dataclass(frozen=True)
class LoggingConfig:
    level: Literal["DEBUG", "INFO", "WARNING", "ERROR"] = setting("INFO", doc="log level")


@dataclass(frozen=True)
class AppConfig:
    version: Literal[1] = setting(1, doc="configuration format version")
    cameras: V4l2Cameras | ReplayCameras | VirtualCameras = setting(
        default_factory=VirtualCameras, doc="frame source; `kind` picks v4l2, replay or virtual"
    )
    calibration: Calibration | None = setting(
        None,
        load=calibration_ref,
        accepts="a file path or a calibration mapping, or null",
        doc="calibration YAML (path relative to this file, or inline); null: the scenario's/recording's",
    )
    site: Site | None = setting(
        None,
        load=optional_site,
        accepts="a site mapping or null",
        doc="lat_deg, lon_deg, height_m, heading_deg, optional tilt_sigma_deg (mast-lean bound, deg) and "
        "geoid_separation_m (ASTERIX I034/120's ellipsoidal height); overrides the calibration's",
    )
    pipeline: PipelineConfig = setting(default_factory=PipelineConfig)
    outputs: OutputsConfig = setting(default_factory=OutputsConfig)
    health: HealthConfig = setting(default_factory=HealthConfig)
    logging: LoggingConfig = setting(default_factory=LoggingConfig)
    alerts: AlertsConfig = setting(default_factory=AlertsConfig)  # edge/config/alerts.py
    ais: AisConfig | None = setting(None, doc="AIS input and association (docs/ais.md); null: off")
    masks: MasksConfig = setting(default_factory=MasksConfig,
                                 doc="exclusion zones: no detection, no birth (docs/site-masks.md)")
    page: PageConfig = setting(default_factory=PageConfig,
                               doc="read-only maintenance page and /metrics (docs/page.md); off by default")

    @property
    def effective_site(self) -> Site | None:
        """The configured site, else the calibration's."""
        if self.site is not None:
            return self.site
        return None if self.calibration is None else self.calibration.site


def config_from_dict(data: Any, file: str | Path | None) -> AppConfig:
    """Validate a parsed configuration mapping, resolve its relative paths, check cross-key rules."""
    cfg = load_dataclass(AppConfig, data, file)
    cams = cfg.cameras
    if isinstance(cams, V4l2Cameras):
        check_v4l2(cams, file)
        if cfg.calibration is None:
            raise ConfigError(file, "calibration", "a calibration (file path or mapping) for v4l2 cameras")
        rig = cfg.calibration.rig
        if (rig.width, rig.height) != (cams.width, cams.height):
            raise ConfigError(file, "cameras.width", f"the calibration's image size {rig.width}x{rig.height}",
                              f"{cams.width}x{cams.height}")
    elif isinstance(cams, ReplayCameras):
        cfg = replace(cfg, cameras=replace(cams, path=str(resolve_path(file, cams.path))))
    elif cams.scenario.endswith((".yaml", ".yml")):
        cfg = replace(cfg, cameras=replace(cams, scenario=str(resolve_path(file, cams.scenario))))
    if cfg.calibration is not None:  # else when the source is planned (the scenario's/recording's size)
        check_image_polygons(cfg.masks, cfg.calibration.rig.width, cfg.calibration.rig.height, file)
    ports = [p.url for p in cfg.outputs.nmea]
    if cfg.outputs.modbus.rtu.enabled:
        ports.append(cfg.outputs.modbus.rtu.url)
    for i, url in enumerate(ports):
        if url in ports[:i]:
            key = f"outputs.nmea[{i}].url" if i < len(cfg.outputs.nmea) else "outputs.modbus.rtu.url"
            raise ConfigError(file, key, "a serial port not used by another output", url)
    modbus_on = cfg.outputs.modbus.tcp.enabled or cfg.outputs.modbus.rtu.enabled
    if cfg.alerts.enabled and modbus_on and cfg.pipeline.max_tracks > MAX_TRACKS_WITH_ALERTS:
        raise ConfigError(file, "pipeline.max_tracks",
                          f"at most {MAX_TRACKS_WITH_ALERTS} with alerts.enabled "
                          "and Modbus (the alert block starts at register 900)", cfg.pipeline.max_tracks)
    if cfg.page.token_file is not None:
        cfg = replace(cfg, page=replace(cfg.page, token_file=str(resolve_path(file, cfg.page.token_file))))
    if cfg.outputs.tracks_csv is not None:
        outputs = replace(cfg.outputs, tracks_csv=str(resolve_path(file, cfg.outputs.tracks_csv)))
        cfg = replace(cfg, outputs=outputs)
    return cfg


def check_v4l2(cams: V4l2Cameras, file: str | Path | None) -> None:
    """The driver's own checks of the nested blocks, as errors naming file and key (no device opened)."""
    from drivers.camera.v4l2_config import CamerasConfigError, cameras_from_config

    try:
        cameras_from_config(cams.block())
    except CamerasConfigError as exc:
        raise ConfigError(file, exc.key, f"a valid setting ({exc.problem})") from None
    except (ValueError, TypeError) as exc:  # a value the driver could not convert (int(), float())
        raise ConfigError(file, "cameras", f"a valid setting ({exc})") from None
    if cams.left.get("device") == cams.right.get("device"):
        raise ConfigError(file, "cameras.right.device", "a device other than cameras.left's",
                          cams.right.get("device"))


def load_config(path: str | Path) -> AppConfig:
    """Read and validate the appliance configuration file."""
    return config_from_dict(load_yaml(path), path)


def schema_markdown() -> str:
    """The configuration reference table (docs/configuration.md)."""
    return markdown_table(AppConfig)
